"""Sub-samples of a binary volume (Zauner 2020 §4.6.1, §7.4): the origin corner cube (Table 7.4: refined sub-samples
from the same corner), or one of m³ = 8 or 64 cubes spread evenly over the volume (Fig. 7.8: the spread across
sub-samples of one size is the REV error bar).
"""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, dataset_attrs, hash_of, open_volume, read_attrs
from porepipe.sweep._settings import SUBSAMPLE_COUNTS

#: relative tolerance for an edge to be a whole number of voxels
_WHOLE_RTOL = 1e-9


def corner_voxels(edge_um: float, voxel_um: float, shape) -> int:
    """Edge of the corner cube in voxels; the edge must be a whole number of voxels and fit in the volume."""
    if not (0 < voxel_um < np.inf and 0 < edge_um < np.inf):
        raise PorepipeError(
            f"sub-sample edge {edge_um} µm and voxel size {voxel_um} µm must both be positive and finite"
        )
    n = edge_um / voxel_um
    if abs(n - round(n)) > _WHOLE_RTOL * max(1.0, n):
        raise PorepipeError(
            f"sub-sample edge {edge_um} µm is not a whole number of voxels of {voxel_um} µm "
            f"({n:.6g}); pick sweep.sample_um as multiples of every resolution"
        )
    n = round(n)
    if n > min(shape):
        raise PorepipeError(
            f"sub-sample edge {edge_um} µm = {n} voxels exceeds the volume shape {tuple(shape)}"
        )
    return n


def subsample_offsets(index: int, count: int, n: int, shape) -> tuple[int, int, int]:
    """Voxel offset of sub-sample ``index`` of ``count`` (1, 8 or 64) cubes of edge ``n`` in a volume of ``shape``.

    The m = count^(1/3) cubes per axis are spread evenly from the low to the high face: offset_i = round(i (N − n) /
    (m − 1)), so they are disjoint when N ≥ m n and overlap (evenly) otherwise; index runs x fastest.
    """
    if count not in SUBSAMPLE_COUNTS:
        raise PorepipeError(f"sweep.subsamples must be one of {SUBSAMPLE_COUNTS}, got {count}")
    if not 0 <= index < count:
        raise PorepipeError(f"sub-sample index {index} outside 0..{count - 1}")
    if not 1 <= n <= min(shape):
        raise PorepipeError(f"sub-sample edge of {n} voxels does not fit the volume shape {tuple(shape)}")
    m = round(count ** (1 / 3))
    if m == 1:
        return (0, 0, 0)
    ijk = (index % m, (index // m) % m, index // (m * m))
    return tuple(round(i * (size - n) / (m - 1)) for i, size in zip(ijk, shape))


def crop_corner(binary_path, edge_um: float, out, index: int = 0, count: int = 1) -> tuple[int, int, int]:
    """Write sub-sample ``index`` of ``count`` cubes of edge ``edge_um`` of ``binary_path`` (volume ``pore``) to ``out``.

    With ``count`` = 1 it is the cube [0, edge_um)^3 at the origin corner. The cut faces are not periodic, so
    ``periodic`` is (0, 0, 0) and the origin moves with the offset. Returns the shape written.
    """
    root = read_attrs(binary_path)
    with open_volume(binary_path, "pore") as dset:
        vattrs = dataset_attrs(dset)
        voxel_um = float(vattrs["voxel_um"])
        n = corner_voxels(float(edge_um), voxel_um, dset.shape)
        ox, oy, oz = subsample_offsets(index, count, n, dset.shape)
        cube = np.ascontiguousarray(dset[ox : ox + n, oy : oy + n, oz : oz + n])
    extra = {k: v for k, v in vattrs.items() if k not in ("voxel_um", "origin_um", "periodic")}
    extra.update(sample_um=float(edge_um), subsample_index=int(index), subsample_count=int(count))
    origin = np.asarray(vattrs["origin_um"], dtype=np.float64) + voxel_um * np.array([ox, oy, oz])
    with ResultWriter(
        out,
        stage="subsample",
        scene=str(root.get("scene", "")),
        scene_hash=hash_of([root.get("scene_hash", ""), float(edge_um), int(index), int(count)]),
    ) as w:
        w.write_volume("pore", cube, voxel_um=voxel_um, origin_um=origin, periodic=(0, 0, 0), attrs=extra)
        w.attrs.update(sample_um=float(edge_um), source=str(binary_path))
    return cube.shape
