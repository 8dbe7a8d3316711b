"""``porepipe estimate``: grey-value estimators over all resolutions of a scene."""

from __future__ import annotations

from porepipe._shared.store import ResultWriter, hash_of, read_attrs, read_table
from porepipe.estimate._api import estimate_from_histograms


def estimate_files(grey_paths, out):
    """Write ``estimate.h5`` from the grey histograms stored in the ``grey_a{a}.h5`` files."""
    attrs = [read_attrs(p) for p in grey_paths]
    hists = [read_table(p)["grey_histogram"].values for p in grey_paths]
    ds = estimate_from_histograms([a["voxel_um"] for a in attrs], hists)
    part = sorted(a.get("scene_hash", "") for a in attrs)
    with ResultWriter(out, stage="estimate", scene=attrs[0].get("scene", ""), scene_hash=hash_of(part)) as w:
        w.write_table(ds)
    return ds


def main(args) -> int:
    ds = estimate_files(args.grey, args.out)
    if "phi_limit" in ds:
        print(f"phi(a->0) = {float(ds.phi_limit):.6f} +- {float(ds.phi_limit_err):.1e}")
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("estimate", help="porosity and specific-surface estimators from grey histograms")
    p.add_argument("grey", nargs="+", help="grey_a{a}.h5 files, one per resolution")
    p.add_argument("-o", "--out", required=True, help="output estimate.h5")
    p.set_defaults(func=main)
