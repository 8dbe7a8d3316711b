"""File in, compute, file out: ``grains.h5`` of a decorated scene, and the grey volumes of the grain model."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.grey import write_grey_volume
from porepipe._shared.numba_config import set_threads
from porepipe._shared.spheres import spheres_from_scene
from porepipe._shared.store import ResultWriter, result_hash
from porepipe.decorate._api import iter_grain_slabs
from porepipe.decorate._decorate import decorate
from porepipe.decorate._io import decoration_dataset, read_grains
from porepipe.scene import scene_part
from porepipe.voxelize import grid_shape

_SCENE_KEYS = ("seed", "domain", "spheres", "decoration")


def _sphere_types(scene, packing_path, n: int) -> np.ndarray:
    """Sphere types from a packing file (dataset ``types``) when the spheres come from one, else all 0."""
    path = (
        scene.spheres.hdf5
        if scene.spheres.hdf5 is not None
        else (packing_path if scene.spheres.pack else None)
    )
    if path is not None:
        with h5py.File(path, "r") as f:
            if "types" in f:
                types = np.asarray(f["types"][...], dtype=np.int64)
                if types.shape != (n,):
                    raise PorepipeError(f"{path}: dataset types has shape {types.shape}, expected ({n},)")
                return types
    return np.zeros(n, dtype=np.int64)


def run(scene, scene_path, out, *, packing_path=None, threads: int | None = None, progress: bool = True):
    """Write ``grains.h5`` (grain type, rotation and scale of every sphere, and the type library).

    Parameters
    ----------
    scene : Scene
        A validated scene with a ``decoration`` section.
    scene_path : path-like
        The scene file (plane files of the library are relative to it).
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
    Decoration
    """
    if scene.decoration is None:
        raise PorepipeError(f"scene {scene.name!r} has no `decoration:` section; nothing to decorate")
    threads = set_threads(threads)
    centres, radii = spheres_from_scene(scene, packing_path)
    types = _sphere_types(scene, packing_path, len(radii))
    deco = decorate(
        centres,
        radii,
        scene.decoration,
        scene.seed,
        types,
        scene.domain.size_um,
        scene.domain.periodic,
        base_dir=Path(scene_path).parent,
        progress=progress,
    )
    digest = result_hash(
        "decorate", scene_part=scene_part(scene, *_SCENE_KEYS), packing=str(packing_path or "")
    )
    with ResultWriter(out, stage="decorate", scene=scene.name, scene_hash=digest, threads=threads) as w:
        w.write_table(decoration_dataset(deco, radii))
        w.attrs.update(
            n_grains=len(deco),
            n_types=len(deco.library),
            scale_rule=scene.decoration.scale.value,
            orientation=scene.decoration.orientation.mode.value,
            grain_volume_um3=float(deco.volumes_um3().sum()),
        )
    return deco


def run_grey(
    scene, grains_path, voxel_um: float, out, *, threads: int | None = None, progress: bool = True
) -> np.ndarray:
    """Write the grey volume ``grey`` (uint8 0..216) of the grain model and its histogram M(g, a), like voxelize.

    Parameters
    ----------
    scene : Scene
        The validated scene (``domain``; ``decoration.method`` and ``slab_planes``).
    grains_path : path-like
        ``grains.h5`` from :func:`run`.
    voxel_um : float
        Voxel edge a in µm.
    out : path-like
        The result file.
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
    deco, _ = read_grains(grains_path)
    box = scene.domain.size_um
    shape = grid_shape(box, voxel_um)
    method = scene.decoration.method if scene.decoration is not None else "boundary"
    slab = scene.decoration.slab_planes if scene.decoration is not None else 32
    digest = result_hash(
        "voxelize_grains", scene_part=scene_part(scene, *_SCENE_KEYS), inputs=[grains_path], voxel_um=voxel_um
    )
    with ResultWriter(
        out, stage="voxelize_grains", scene=scene.name, scene_hash=digest, threads=threads
    ) as w:
        slabs = iter_grain_slabs(deco, box, voxel_um, scene.domain.periodic, method, slab, progress)
        hist = write_grey_volume(w, slabs, shape, voxel_um, scene.domain.periodic, {"n_grains": len(deco)})
        w.attrs.update(method=str(method))
    return hist
