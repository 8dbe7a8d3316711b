"""``porepipe voxelize``: grey volume of the scene's spheres at one resolution."""

from __future__ import annotations

import numpy as np
import xarray as xr

from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import ResultWriter, hash_of
from porepipe.scene import load_scene, scene_part
from porepipe.voxelize._api import grid_shape, iter_grey_slabs
from porepipe._shared.sample_points import N_SAMPLES
from porepipe._shared.spheres import spheres_from_scene


def voxelize_scene(scene, voxel_um: float, out, packing_path=None, threads: int | None = None, progress=True):
    """Write ``grey_a{a}.h5``: volume ``grey`` (uint8 0..216) and the grey histogram M(g, a) as a table."""
    threads = set_threads(threads)
    centres, radii = spheres_from_scene(scene, packing_path)
    box = scene.domain.size_um
    shape = grid_shape(box, voxel_um)
    part = scene_part(scene, "domain", "spheres") | {"voxel_um": voxel_um, "packing": str(packing_path or "")}
    with ResultWriter(out, stage="voxelize", scene=scene.name, scene_hash=hash_of(part), threads=threads) as w:
        slabs = iter_grey_slabs(centres, radii, box, voxel_um, scene.domain.periodic, scene.voxelize.method,
                                scene.voxelize.slab_planes, progress)
        write_grey_volume(w, slabs, shape, voxel_um, scene.domain.periodic, {"n_spheres": len(radii)})
        w.attrs.update(method=scene.voxelize.method.value)


def write_grey_volume(writer: ResultWriter, slabs, shape, voxel_um: float, periodic: bool, attrs: dict) -> np.ndarray:
    """Write volume ``grey`` slab by slab from ``(i0, slab)`` pairs, and the grey histogram M(g, a) as the table.

    ``attrs`` (e.g. the number of spheres or grains) go to the table and the root. Returns the histogram.
    """
    hist = np.zeros(N_SAMPLES + 1, dtype=np.int64)
    dset = writer.create_volume("grey", shape, np.uint8, voxel_um=voxel_um, periodic=(periodic,) * 3,
                                attrs={"meaning": "number of the 6x6x6 sample points in the matrix (0..216)"})
    for i0, slab in slabs:
        dset[i0:i0 + len(slab)] = slab
        hist += np.bincount(slab.ravel(), minlength=N_SAMPLES + 1)
    writer.write_table(xr.Dataset({"grey_histogram": ("g", hist, {"long_name": "M(g, a)"})},
                                  coords={"g": np.arange(N_SAMPLES + 1)}, attrs={"voxel_um": voxel_um, **attrs}))
    writer.attrs.update(voxel_um=voxel_um, shape=np.asarray(shape), **attrs)
    return hist


def main(args) -> int:
    scene = load_scene(args.scene)
    voxelize_scene(scene, args.a, args.out, args.packing, args.threads)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("voxelize", help="grey volume (0..216) of the scene's spheres at one voxel size")
    p.add_argument("scene", help="scene YAML")
    p.add_argument("--a", type=float, required=True, help="voxel size in µm")
    p.add_argument("-o", "--out", required=True, help="output grey_a{a}.h5")
    p.add_argument("--packing", help="packing.h5 from the pack stage (when spheres.pack is set)")
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=main)
