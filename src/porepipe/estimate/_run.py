"""File in, compute, file out: ``estimate.h5`` from the grey histograms of all resolutions."""

from __future__ import annotations

import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_attrs, read_table, result_hash
from porepipe.estimate._api import estimate_from_histograms


def run(grey_paths, out) -> xr.Dataset:
    """Write ``estimate.h5`` from the grey histograms stored in the ``grey_a{a}.h5`` files.

    Parameters
    ----------
    grey_paths : sequence of path-like
        One grey volume per resolution.
    out : path-like
        The result file.

    Returns
    -------
    xarray.Dataset
        The estimators (:func:`porepipe.estimate.estimate_from_histograms`).
    """
    attrs = [read_attrs(p) for p in grey_paths]
    hists = [_grey_histogram(p) for p in grey_paths]
    ds = estimate_from_histograms([a["voxel_um"] for a in attrs], hists)
    digest = result_hash("estimate", inputs=sorted(grey_paths, key=str))
    with ResultWriter(out, stage="estimate", scene=attrs[0].get("scene", ""), scene_hash=digest) as w:
        w.write_table(ds)
    return ds


def _grey_histogram(path):
    """The grey-value histogram a grey volume file stores; any other file is refused with one line."""
    table = read_table(path)
    if "grey_histogram" not in table:
        stage = read_attrs(path).get("stage", "unknown")
        raise PorepipeError(
            f"{path}: no grey-value histogram (a {stage!r} result); estimate needs grey volumes "
            "grey_a{a}.h5 from voxelize or decorate, not binary or other results"
        )
    return table["grey_histogram"].values
