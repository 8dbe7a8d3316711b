"""``porepipe granular``: run a scene's 2-D polygon DEM and write ``granular.h5``."""

from __future__ import annotations

import argparse

from porepipe._shared.errors import PorepipeError
from porepipe._shared.overrides import add_threads_option, check_resume_has_checkpoint, seed_number


def main(args) -> int:
    from porepipe._shared.numba_config import openmp_wait_for_idle_cores, set_threads

    check_resume_has_checkpoint(args)
    # before set_threads starts numba's thread pool: GNU OpenMP reads its waiting policy once
    openmp_wait_for_idle_cores(args.threads)
    from porepipe.granular._run import run
    from porepipe.scene import load_scene

    scene = load_scene(args.scene)
    settings = scene.granular
    if settings is None or not (settings.particles or settings.blocks or settings.drop_sources):
        raise PorepipeError(
            f"{args.scene}: the scene has no `granular:` section with particles, blocks or drop_sources"
        )
    threads = set_threads(args.threads)
    run(
        settings,
        args.out,
        seed=scene.seed if args.seed is None else args.seed,
        scene=scene.name,
        threads=threads,
        checkpoint=args.checkpoint,
        resume=args.resume,
        progress=not args.quiet,
    )
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("granular", help="2-D frictional DEM of convex polygons (gc2d) -> granular.h5")
    p.add_argument("scene", help="scene YAML with a `granular:` section")
    p.add_argument("-o", "--out", required=True, help="output granular.h5")
    p.add_argument(
        "--checkpoint", help="checkpoint file, written every granular.checkpoint_every_steps steps"
    )
    p.add_argument(
        "--resume",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="continue from --checkpoint if it exists",
    )
    add_threads_option(p)
    p.add_argument(
        "--seed",
        type=seed_number,
        default=None,
        help="seed instead of the scene's (one realisation of an ensemble, e.g. a heap's floor-pressure dip)",
    )
    p.add_argument("--quiet", action=argparse.BooleanOptionalAction, default=False, help="no progress lines")
    p.set_defaults(func=main)
