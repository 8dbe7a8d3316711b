"""``porepipe report SCENE.yaml``: the accuracy-versus-cost report of a scene (results/<scene>/report/index.html).

Argparse only; the work is in ``_run``.
"""

from __future__ import annotations

import sys


def main(args) -> int:
    """Run the subcommand; returns the exit code."""
    from porepipe.report._run import run  # matplotlib only when a report is built
    from porepipe.scene import load_scene

    out = run(
        load_scene(args.scene),
        args.scene,
        sweep=args.sweep,
        out=args.out,
        grey=args.grey,
        binary=args.binary,
        lpt=args.lpt,
        granular=args.granular,
        compare=(args.compare_scene, args.compare_granular),
    )
    print(f"report: written {out}", file=sys.stderr)
    return 0


def register(subparsers) -> None:
    """Add ``report`` to the ``porepipe`` command."""
    p = subparsers.add_parser("report", help="accuracy-versus-cost report (HTML + PNG) of a scene's sweep")
    p.add_argument("scene", help="scene YAML file")
    p.add_argument("--sweep", help="sweep.h5 (default results/<scene>/sweep/sweep.h5)")
    p.add_argument("--grey", nargs="*", help="grey_a{a}.h5 files for cross-sections (default: those present)")
    p.add_argument(
        "--binary", nargs="*", help="binary_a{a}.h5 files for cross-sections (default: those present)"
    )
    p.add_argument("--lpt", nargs="*", help="lpt_a{a}.h5 files for LPT curves (default: those present)")
    p.add_argument(
        "--granular",
        nargs="+",
        help="granular.h5 of a 2-D granular scene: its silo or heap report (default when no sweep); several "
        "(one per seed) add the heap floor-pressure dip over seeds",
    )
    p.add_argument(
        "--compare-scene", help="scene YAML of a second heap ensemble (e.g. layered against poured)"
    )
    p.add_argument("--compare-granular", nargs="+", help="granular.h5 of --compare-scene, one per seed")
    p.add_argument("-o", "--out", help="output index.html (default results/<scene>/report/index.html)")
    p.set_defaults(func=main)
