"""Corner sub-samples of a binary volume (Zauner 2020 §4.6.1, Table 7.4: refined sub-samples from the same corner)."""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, hash_of, open_volume, read_attrs

#: relative tolerance for an edge to be a whole number of voxels
_WHOLE_RTOL = 1e-9


def corner_voxels(edge_um: float, voxel_um: float, shape) -> int:
    """Edge of the corner cube in voxels; the edge must be a whole number of voxels and fit in the volume."""
    n = edge_um / voxel_um
    if not edge_um > 0 or abs(n - round(n)) > _WHOLE_RTOL * max(1.0, n):
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


def crop_corner(binary_path, edge_um: float, out) -> tuple[int, int, int]:
    """Write the cube [0, edge_um)^3 at the origin corner of ``binary_path`` (volume ``pore``) to ``out``.

    The cut faces are not periodic, so ``periodic`` is (0, 0, 0). Returns the shape written.
    """
    root = read_attrs(binary_path)
    with open_volume(binary_path, "pore") as dset:
        vattrs = dict(dset.attrs.items())
        n = corner_voxels(float(edge_um), float(vattrs["voxel_um"]), dset.shape)
        cube = np.ascontiguousarray(dset[:n, :n, :n])
    extra = {k: v for k, v in vattrs.items() if k not in ("voxel_um", "origin_um", "periodic")}
    extra["sample_um"] = float(edge_um)
    with ResultWriter(
        out,
        stage="subsample",
        scene=str(root.get("scene", "")),
        scene_hash=hash_of([root.get("scene_hash", ""), float(edge_um)]),
    ) as w:
        w.write_volume(
            "pore",
            cube,
            voxel_um=float(vattrs["voxel_um"]),
            origin_um=vattrs["origin_um"],
            periodic=(0, 0, 0),
            attrs=extra,
        )
        w.attrs.update(sample_um=float(edge_um), source=str(binary_path))
    return cube.shape
