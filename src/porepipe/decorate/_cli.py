"""``porepipe decorate`` (grains.h5) and ``porepipe voxelize-grains`` (grey volume of the grain model)."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import ResultWriter, hash_of
from porepipe.decorate._api import decorate, iter_grain_slabs
from porepipe.decorate._io import decoration_dataset, read_grains
from porepipe.scene import load_scene, scene_part
from porepipe.voxelize._api import grid_shape
from porepipe.voxelize._cli import write_grey_volume
from porepipe._shared.spheres import spheres_from_scene


def _sphere_types(scene, packing_path, n: int) -> np.ndarray:
    """Sphere types from a packing file (dataset ``types``) when the spheres come from one, else all 0."""
    path = scene.spheres.hdf5 if scene.spheres.hdf5 is not None else (packing_path if scene.spheres.pack else None)
    if path is not None:
        with h5py.File(path, "r") as f:
            if "types" in f:
                types = np.asarray(f["types"][...], dtype=np.int64)
                if types.shape != (n,):
                    raise PorepipeError(f"{path}: dataset types has shape {types.shape}, expected ({n},)")
                return types
    return np.zeros(n, dtype=np.int64)


def decorate_scene(scene, scene_path, out, packing_path=None, threads: int | None = None, progress=True) -> None:
    """Write ``grains.h5`` for a scene with a ``decoration`` section."""
    if scene.decoration is None:
        raise PorepipeError(f"scene {scene.name!r} has no `decoration:` section; nothing to decorate")
    threads = set_threads(threads)
    centres, radii = spheres_from_scene(scene, packing_path)
    types = _sphere_types(scene, packing_path, len(radii))
    deco = decorate(centres, radii, scene.decoration, scene.seed, types, scene.domain.size_um,
                    scene.domain.periodic, base_dir=Path(scene_path).parent, progress=progress)
    part = scene_part(scene, "seed", "domain", "spheres", "decoration") | {"packing": str(packing_path or "")}
    with ResultWriter(out, stage="decorate", scene=scene.name, scene_hash=hash_of(part), threads=threads) as w:
        w.write_table(decoration_dataset(deco, radii))
        w.attrs.update(n_grains=len(deco), n_types=len(deco.library), scale_rule=scene.decoration.scale.value,
                       orientation=scene.decoration.orientation.mode.value,
                       grain_volume_um3=float(deco.volumes_um3().sum()))


def voxelize_grains_scene(scene, grains_path, voxel_um: float, out, threads: int | None = None, progress=True):
    """Write a grey volume ``grey`` (uint8 0..216) of the grain model, and its histogram M(g, a), like voxelize."""
    threads = set_threads(threads)
    deco, _ = read_grains(grains_path)
    box = scene.domain.size_um
    shape = grid_shape(box, voxel_um)
    method = scene.decoration.method if scene.decoration is not None else "boundary"
    slab = scene.decoration.slab_planes if scene.decoration is not None else 32
    part = scene_part(scene, "seed", "domain", "spheres", "decoration") | {"voxel_um": voxel_um}
    with ResultWriter(out, stage="voxelize_grains", scene=scene.name, scene_hash=hash_of(part), threads=threads) as w:
        slabs = iter_grain_slabs(deco, box, voxel_um, scene.domain.periodic, method, slab, progress)
        write_grey_volume(w, slabs, shape, voxel_um, scene.domain.periodic, {"n_grains": len(deco)})
        w.attrs.update(method=str(method))


def _main_decorate(args) -> int:
    scene = load_scene(args.scene)
    decorate_scene(scene, args.scene, args.out, args.packing, args.threads)
    return 0


def _main_voxelize(args) -> int:
    scene = load_scene(args.scene)
    voxelize_grains_scene(scene, args.grains, args.a, args.out, args.threads)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("decorate", help="give every sphere a grain type, rotation and scale (grains.h5)")
    p.add_argument("scene", help="scene YAML with a `decoration:` section")
    p.add_argument("-o", "--out", required=True, help="output grains.h5")
    p.add_argument("--packing", help="packing.h5 from the pack stage (when spheres.pack is set)")
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=_main_decorate)
    p = subparsers.add_parser("voxelize-grains", help="grey volume (0..216) of the decorated grains at one voxel size")
    p.add_argument("scene", help="scene YAML")
    p.add_argument("--grains", required=True, help="grains.h5 from `porepipe decorate`")
    p.add_argument("--a", type=float, required=True, help="voxel size in µm")
    p.add_argument("-o", "--out", required=True, help="output grey_a{a}.h5")
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=_main_voxelize)
