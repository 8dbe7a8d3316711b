"""``porepipe pack``: run the scene's DEM packing protocol and write ``packing.h5`` (and optionally ``xyzr``)."""

from __future__ import annotations

from pathlib import Path

from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import ResultWriter, hash_of
from porepipe.packing._api import pack_spheres
from porepipe.packing._io import write_packing, write_xyzr_file
from porepipe.scene import load_scene, scene_part


def pack_scene(scene_path, out, xyzr=None, threads: int | None = None, checkpoint=None, resume: bool = False,
               progress: bool = True):
    """Pack the spheres of the scene at ``scene_path`` and write the result file ``out``; returns the Packing."""
    scene = load_scene(scene_path)
    settings = scene.packing
    if not settings.types or not settings.stages:
        raise PorepipeError(f"{scene_path}: the scene has no `packing:` section with types and stages to run")
    threads = set_threads(threads)
    part = scene_part(scene, "seed", "domain", "packing")
    with ResultWriter(out, stage="pack", scene=scene.name, scene_hash=hash_of(part), threads=threads) as w:
        packing = pack_spheres(settings, scene.domain.size_um, scene.domain.periodic, scene.seed,
                               base_dir=Path(scene_path).parent, checkpoint_path=checkpoint, resume=resume,
                               progress=progress)
        write_packing(w, packing)
    if xyzr:
        write_xyzr_file(xyzr, packing)
    return packing


def main(args) -> int:
    packing = pack_scene(args.scene, args.out, args.xyzr, args.threads, args.checkpoint, args.resume)
    if not packing.all_converged:
        print(f"porepipe pack: warning: not every sphere converged (stage steps {packing.stage_steps}); "
              "see the history in the output file")
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("pack", help="DEM packing of overlapping spheres (PackDEM protocol) -> packing.h5")
    p.add_argument("scene", help="scene YAML with a `packing:` section")
    p.add_argument("-o", "--out", required=True, help="output packing.h5")
    p.add_argument("--xyzr", help="also write the spheres as an 'x y z r' text file (µm)")
    p.add_argument("--checkpoint", help="checkpoint file, written every packing.checkpoint_every steps")
    p.add_argument("--resume", action="store_true", help="continue from --checkpoint if it exists")
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=main)
