"""File in, compute, file out: ``binary_a{a}.h5`` (volume ``pore``, 1 = pore) from a grey volume."""

from __future__ import annotations

import numpy as np
import xarray as xr

from porepipe._shared.budget import planes_within
from porepipe._shared.grey import read_grey_histogram
from porepipe._shared.store import ResultWriter, open_volume, read_attrs, result_hash, volume_meta
from porepipe.segment._api import Threshold, choose_threshold, segment

#: bytes per voxel of a slab: the grey values read, the comparison's booleans and the binary values written
_BYTES_PER_VOXEL = 3


def run(
    grey_path,
    out,
    method,
    threshold: int | None = None,
    slab_planes: int = 64,
    memory_budget_mb: int | None = None,
) -> Threshold:
    """Write ``binary_a{a}.h5`` from ``grey_a{a}.h5``, slab by slab, with threshold and method as attributes.

    Parameters
    ----------
    grey_path : path-like
        A grey volume (volume ``grey``, table ``grey_histogram``).
    out : path-like
        The result file.
    method : SegmentationMethod
        ``otsu`` or ``fixed``.
    threshold : int, optional
        g_th for ``fixed`` (0..215); pore if g <= g_th.
    slab_planes : int
        x planes held in memory at once (fewer where the budget says so).
    memory_budget_mb : int, optional
        The scene's ``resources.memory_budget_mb``; segmentation is voxel by voxel (no halo), so the budget only
        sets the slab thickness; a budget below one plane is an error naming it.

    Returns
    -------
    Threshold
        The threshold chosen, its method and a note.
    """
    src = read_attrs(grey_path)
    hist, _ = read_grey_histogram(grey_path)
    decision = choose_threshold(hist, method, threshold)
    digest = result_hash(
        "segment", inputs=[grey_path], method=str(decision.method.value), threshold=decision.value
    )
    with (
        ResultWriter(out, stage="segment", scene=src.get("scene", ""), scene_hash=digest) as w,
        open_volume(grey_path, "grey") as grey,
    ):
        meta = volume_meta(grey, grey_path)
        plane = _BYTES_PER_VOXEL * grey.shape[1] * grey.shape[2]
        what = f"one x plane of {grey.shape[1]}x{grey.shape[2]} voxels to segment"
        slab_planes = planes_within(memory_budget_mb, plane, 0, slab_planes, what)
        pore = w.create_volume(
            "pore",
            grey.shape,
            np.uint8,
            voxel_um=meta.voxel_um,
            origin_um=meta.origin_um,
            periodic=meta.periodic,
            attrs={
                "threshold": decision.value,
                "method": decision.method.value,
                "meaning": "1 = pore (grey <= threshold), 0 = matrix",
            },
        )
        n_pore = 0
        for i0 in range(0, grey.shape[0], slab_planes):
            slab = segment(grey[i0 : i0 + slab_planes], decision.value)
            pore[i0 : i0 + len(slab)] = slab
            n_pore += int(slab.sum(dtype=np.int64))
        n = int(np.prod(grey.shape, dtype=np.int64))
        w.write_table(xr.Dataset({"porosity": ((), n_pore / n)}, attrs={"threshold": decision.value}))
        w.attrs.update(
            threshold=decision.value,
            method=decision.method.value,
            note=decision.note,
            voxel_um=meta.voxel_um,
            porosity=n_pore / n,
        )
    return decision
