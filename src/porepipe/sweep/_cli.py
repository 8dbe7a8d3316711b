"""``porepipe sweep`` (gather + extrapolate, or ``--adaptive SCENE``) and ``porepipe subsample`` (corner crop).

Argparse only; the work is in ``_run`` (and ``_adaptive``, which drives whole workflow runs).
"""

from __future__ import annotations

import argparse
import sys

from porepipe._shared.errors import PorepipeError
from porepipe._shared.overrides import given_options, merge_settings, whole_count
from porepipe.sweep._settings import SUBSAMPLE_COUNTS, Exponent, Settings


def _sweep(args) -> int:
    if args.adaptive:
        from porepipe.sweep._adaptive import Outcome, run_adaptive

        if len(args.inputs) != 1:
            raise PorepipeError(f"sweep --adaptive takes one scene file, got {args.inputs}")
        dec = run_adaptive(args.inputs[0], cores=args.cores)
        print(f"adaptive sweep stopped: {dec.outcome.value}: {dec.message}")
        return 0 if dec.outcome is Outcome.target_met else 3
    if not args.inputs or not args.out:
        raise PorepipeError("sweep needs result files and -o OUT (or --adaptive SCENE)")
    base, scene_name = None, ""
    if args.scene:
        from porepipe.scene import load_scene

        scene = load_scene(args.scene)
        base, scene_name = scene.sweep, scene.name
    # the options given lie over the scene's (or the defaults) and are checked as the scene's keys are
    settings = merge_settings(
        Settings, base, given_options(args, ("exponent", "confidence")), "sweep options"
    )
    exponent, confidence = settings.exponent, settings.confidence
    from porepipe.sweep._run import run

    ds = run(
        args.inputs,
        args.out,
        volumes=args.volumes,
        cost_dir=args.cost_dir,
        exponent=exponent,
        confidence=confidence,
        scene_name=scene_name,
    )
    ok = int((ds.status == "ok").sum())
    print(
        f"sweep: {ds.sizes['quantity']} quantities x {ds.sizes['a_um']} resolutions x {ds.sizes['sample_um']} "
        f"samples; {ok} supported limits; written {args.out}",
        file=sys.stderr,
    )
    return 0


def _subsample(args) -> int:
    from porepipe.sweep._run import run_subsample

    shape = run_subsample(args.binary, args.edge_um, args.out, index=args.index, count=args.count)
    print(
        f"subsample: cube {args.index} of {args.count}, {shape} voxels, written to {args.out}",
        file=sys.stderr,
    )
    return 0


def register(subparsers) -> None:
    """Add ``sweep`` and ``subsample`` to the ``porepipe`` command."""
    p = subparsers.add_parser(
        "sweep",
        help="gather results over resolutions and sample sizes into sweep.h5 and "
        "extrapolate to a -> 0; or --adaptive SCENE: refine until a target error is met",
    )
    p.add_argument(
        "inputs", nargs="*", help="result files (*_a{a}*.h5, estimate.h5); with --adaptive: the scene"
    )
    p.add_argument("-o", "--out", help="output sweep.h5")
    p.add_argument(
        "--volumes", nargs="*", default=[], help="grey/binary volume files (upstream cost, voxel counts)"
    )
    p.add_argument("--cost-dir", help="directory of Snakemake benchmark TSVs (results/<scene>/cost)")
    p.add_argument(
        "--scene", help="scene file: takes sweep.exponent and sweep.confidence from it (the options win)"
    )
    p.add_argument("--exponent", default=None, choices=[e.value for e in Exponent])
    p.add_argument("--confidence", type=float, default=None)
    p.add_argument(
        "--adaptive",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="run the scene's adaptive refinement (sweep.adaptive); exit 0 = target met, 3 = stopped first",
    )
    p.add_argument(
        "--cores",
        type=whole_count("--cores", unset="one core"),
        default=1,
        help="with --adaptive: cores for each workflow run",
    )
    p.set_defaults(func=_sweep)
    p = subparsers.add_parser("subsample", help="cut the corner cube of edge L µm from a binary volume")
    p.add_argument("binary", help="binary_a{a}.h5")
    p.add_argument("--edge-um", type=float, required=True, help="edge L of the cube, µm")
    p.add_argument("-o", "--out", required=True, help="binary_a{a}_L{L}.h5 (binary_a{a}_L{L}_k{index}.h5)")
    p.add_argument(
        "--count",
        type=int,
        choices=SUBSAMPLE_COUNTS,
        default=1,
        help="sub-samples in all: 1 (origin corner), 8 or 64 (a 2³ / 4³ grid of cubes)",
    )
    p.add_argument("--index", type=int, default=0, help="which of the --count cubes (x fastest)")
    p.set_defaults(func=_subsample)
