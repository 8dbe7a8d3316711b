"""``porepipe segment``: binary pore volume from a grey volume."""

from __future__ import annotations

import numpy as np
import xarray as xr

from porepipe._shared.store import ResultWriter, hash_of, open_volume, read_attrs, read_table
from porepipe.scene import SegmentationMethod
from porepipe.segment._api import choose_threshold, segment


def segment_file(grey_path, out, method: SegmentationMethod, threshold: int | None = None, slab_planes: int = 64):
    """Write ``binary_a{a}.h5``: volume ``pore`` (uint8, 1 = pore) with threshold and method as attributes."""
    src = read_attrs(grey_path)
    hist = read_table(grey_path)["grey_histogram"].values
    decision = choose_threshold(hist, method, threshold)
    part = {"grey": src.get("scene_hash", ""), "method": str(decision.method.value), "threshold": decision.value}
    with ResultWriter(out, stage="segment", scene=src.get("scene", ""), scene_hash=hash_of(part)) as w, \
            open_volume(grey_path, "grey") as grey:
        attrs = dict(grey.attrs)
        pore = w.create_volume("pore", grey.shape, np.uint8, voxel_um=attrs["voxel_um"], origin_um=attrs["origin_um"],
                               periodic=attrs["periodic"],
                               attrs={"threshold": decision.value, "method": decision.method.value,
                                      "meaning": "1 = pore (grey <= threshold), 0 = matrix"})
        n_pore = 0
        for i0 in range(0, grey.shape[0], slab_planes):
            slab = segment(grey[i0:i0 + slab_planes], decision.value)
            pore[i0:i0 + len(slab)] = slab
            n_pore += int(slab.sum(dtype=np.int64))
        n = int(np.prod(grey.shape, dtype=np.int64))
        w.write_table(xr.Dataset({"porosity": ((), n_pore / n)}, attrs={"threshold": decision.value}))
        w.attrs.update(threshold=decision.value, method=decision.method.value, note=decision.note,
                       voxel_um=attrs["voxel_um"], porosity=n_pore / n)
    return decision


def main(args) -> int:
    decision = segment_file(args.grey, args.out, SegmentationMethod(args.method), args.threshold)
    if decision.note:
        print(decision.note)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("segment", help="binary pore volume (pore if grey <= threshold)")
    p.add_argument("grey", help="grey_a{a}.h5")
    p.add_argument("-o", "--out", required=True, help="output binary_a{a}.h5")
    p.add_argument("--method", choices=[m.value for m in SegmentationMethod], default="otsu")
    p.add_argument("--threshold", type=int, default=None, help="g_th for --method fixed (0..215)")
    p.set_defaults(func=main)
