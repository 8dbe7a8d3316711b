"""``porepipe minkowski``: φ, S_V, K_V, T_V, χ of pore and matrix of a binary volume (and optionally of the grey
volume at every threshold), written to ``minkowski_a{a}.h5``."""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import ResultWriter, hash_of, open_volume, read_attrs
from porepipe.minkowski._api import (
    configuration_histogram_slabs,
    iter_slabs,
    minkowski_from_histogram,
    threshold_dataset,
    threshold_histograms_slabs,
)
from porepipe.minkowski._settings import Settings
from porepipe.minkowski._settings import Adjacency

#: table group of the Minkowski functions of the grey threshold in the result file
THRESHOLD_GROUP = "threshold"


def _volume_meta(dset, path) -> tuple[float, tuple[bool, bool, bool]]:
    attrs = dict(dset.attrs)
    if "voxel_um" not in attrs:
        raise PorepipeError(f"{path}: volume {dset.name} has no 'voxel_um' attribute")
    periodic = tuple(bool(p) for p in np.broadcast_to(np.asarray(attrs.get("periodic", [1, 1, 1])), (3,)))
    return float(attrs["voxel_um"]), periodic


def minkowski_file(binary_path, out, settings: Settings = Settings(), grey_path=None, threads: int | None = None):
    """Write ``minkowski_a{a}.h5`` from ``binary_a{a}.h5`` (volume ``pore``), reading it slab by slab.

    The root table is the Dataset of :func:`porepipe.minkowski.minkowski_from_histogram`; with ``grey_path`` the
    group ``threshold`` holds the same quantities for every threshold g_th of the grey volume (volume ``grey``).
    """
    threads = set_threads(threads)
    src = read_attrs(binary_path)
    part = {"binary": src.get("scene_hash", ""), "settings": settings.model_dump(mode="json"),
            "grey": read_attrs(grey_path).get("scene_hash", "") if grey_path else ""}
    with open_volume(binary_path, "pore") as pore:
        voxel_um, periodic = _volume_meta(pore, binary_path)
        hist, shape = configuration_histogram_slabs(iter_slabs(pore, settings.slab_planes), periodic)
    table = minkowski_from_histogram(hist, voxel_um, settings.adjacency, periodic)
    with ResultWriter(out, stage="minkowski", scene=src.get("scene", ""), scene_hash=hash_of(part),
                      threads=threads) as w:
        w.write_table(table)
        if grey_path:
            with open_volume(grey_path, "grey") as grey:
                grey_voxel, grey_periodic = _volume_meta(grey, grey_path)
                hists, _ = threshold_histograms_slabs(iter_slabs(grey, settings.slab_planes), grey_periodic)
            all_pore = np.flatnonzero(hists[:, -1] == hists.sum(axis=1))      # thresholds at/above max(grey)
            last = int(all_pore[0]) if len(all_pore) else len(hists) - 1
            w.write_table(threshold_dataset(hists[: last + 1], grey_voxel, grey_periodic, settings.adjacency),
                          group=THRESHOLD_GROUP)
        pore_values = table.sel(phase="pore")
        w.attrs.update(voxel_um=voxel_um, shape=np.asarray(shape), periodic=np.asarray(periodic, dtype=np.int8),
                       adjacency=settings.adjacency.value, boundary=table.attrs["boundary"],
                       **{f"{k}_pore": float(pore_values[k]) for k in ("phi", "S_V", "K_V", "T_V", "chi")})
    return table


def main(args) -> int:
    settings = Settings()
    if args.scene:
        from porepipe.scene import load_scene
        settings = getattr(load_scene(args.scene), "minkowski", None) or settings
    if args.adjacency or args.slab_planes:
        settings = settings.model_copy(update={k: v for k, v in (("adjacency", args.adjacency and
                                                                  Adjacency(args.adjacency)),
                                                                 ("slab_planes", args.slab_planes)) if v})
    grey = args.grey if (args.grey or not settings.threshold_functions) else None
    if settings.threshold_functions and not grey:
        raise PorepipeError("minkowski.threshold_functions is on: give the grey volume with --grey GREY.h5")
    table = minkowski_file(args.binary, args.out, settings, grey, args.threads)
    pore = table.sel(phase="pore")
    print(f"φ={float(pore.phi):.6f} S_V={float(pore.S_V):.6g} µm^-1 K_V={float(pore.K_V):.6g} µm^-2 "
          f"T_V={float(pore.T_V):.6g} µm^-3 χ={float(pore.chi):.6g}")
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("minkowski", help="φ, S_V, K_V, T_V, χ of pore and matrix of a binary volume")
    p.add_argument("binary", help="binary_a{a}.h5 (volume 'pore', 1 = pore)")
    p.add_argument("-o", "--out", required=True, help="output minkowski_a{a}.h5")
    p.add_argument("--scene", help="scene YAML (its minkowski section gives the settings)")
    p.add_argument("--grey", help="grey_a{a}.h5: also the functionals at every threshold g_th (one pass)")
    p.add_argument("--adjacency", choices=[a.value for a in Adjacency], help="overrides the scene")
    p.add_argument("--slab-planes", type=int, help="x planes read at once (overrides the scene)")
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=main)
