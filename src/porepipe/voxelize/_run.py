"""File in, compute, file out: the grey volume of a scene's spheres at one voxel size (``grey_a{a}.h5``)."""

from __future__ import annotations

import numpy as np

from porepipe._shared.budget import planes_within
from porepipe._shared.grey import write_grey_volume
from porepipe._shared.numba_config import set_threads
from porepipe._shared.spheres import spheres_from_scene
from porepipe._shared.store import ResultWriter, result_hash
from porepipe.scene import scene_part
from porepipe.voxelize._api import grid_shape, iter_grey_slabs

#: bytes per voxel of a plane each thread works on (voxel status, 4 words of sample bits, counts)
_THREAD_BYTES_PER_VOXEL = 1 + 32 + 4


def slab_planes(scene, shape, threads: int) -> int:
    """Planes per slab: the scene's ``voxelize.slab_planes``, fewer where ``resources.memory_budget_mb`` says so.

    A slab holds 1 byte per voxel; each thread also holds the work arrays of one plane. Voxels are independent of
    their neighbours, so the slabs need no halo.

    Parameters
    ----------
    scene : Scene
        The validated scene (``voxelize.slab_planes``, ``resources.memory_budget_mb``).
    shape : 3 ints
        Voxels per axis of the volume.
    threads : int
        Numba threads in use.

    Returns
    -------
    int
        Planes per slab, >= 1.
    """
    plane = shape[1] * shape[2]
    fixed = threads * _THREAD_BYTES_PER_VOXEL * plane
    what = f"one x plane of {shape[1]}x{shape[2]} voxels with the work arrays of {threads} thread(s)"
    return planes_within(scene.resources.memory_budget_mb, plane, fixed, scene.voxelize.slab_planes, what)


def run(
    scene, voxel_um: float, out, *, packing_path=None, threads: int | None = None, progress: bool = True
) -> np.ndarray:
    """Write ``grey_a{a}.h5``: volume ``grey`` (uint8 0..216) and the grey histogram M(g, a) as its table.

    Parameters
    ----------
    scene : Scene
        The validated scene (its ``domain``, ``spheres`` and ``voxelize`` sections are used).
    voxel_um : float
        Voxel edge a in µm; it must divide every box edge.
    out : path-like
        The result file.
    packing_path : path-like, optional
        ``packing.h5`` of the pack stage, when ``spheres.pack`` is set.
    threads : int, optional
        Numba threads (default: all).
    progress : bool
        Print progress lines.

    Returns
    -------
    (217,) ndarray of int64
        The grey histogram M(g, a).
    """
    threads = set_threads(threads)
    centres, radii = spheres_from_scene(scene, packing_path)
    box = scene.domain.size_um
    shape = grid_shape(box, voxel_um)
    digest = result_hash(
        "voxelize",
        scene_part=scene_part(scene, "domain", "spheres"),
        voxel_um=voxel_um,
        packing=str(packing_path or ""),
    )
    with ResultWriter(out, stage="voxelize", scene=scene.name, scene_hash=digest, threads=threads) as w:
        slabs = iter_grey_slabs(
            centres,
            radii,
            box,
            voxel_um,
            scene.domain.periodic,
            scene.voxelize.method,
            slab_planes(scene, shape, threads),
            progress,
        )
        hist = write_grey_volume(w, slabs, shape, voxel_um, scene.domain.periodic, {"n_spheres": len(radii)})
        w.attrs.update(method=scene.voxelize.method.value)
    return hist
