"""``porepipe report SCENE.yaml``: the accuracy-versus-cost report of a scene (results/<scene>/report/index.html)."""

from __future__ import annotations

import sys
from pathlib import Path

from porepipe._shared.errors import PorepipeError


def _existing(scene, pattern: str) -> list[str]:
    paths = [Path("results", scene.name, pattern.format(a=f"{a:g}")) for a in scene.resolutions_um]
    return [str(p) for p in paths if p.is_file()]


def main(args) -> int:
    from porepipe.report._api import build_report  # matplotlib only when a report is built
    from porepipe.scene import grey_stage, load_scene

    scene = load_scene(args.scene)
    sweep = Path(args.sweep or Path("results", scene.name, "sweep", "sweep.h5"))
    if not sweep.is_file():
        raise PorepipeError(f"{sweep} does not exist: run the workflow first (`porepipe run {args.scene}` with "
                            "`report` in the scene's analyses)")
    grey = args.grey if args.grey is not None else _existing(scene, grey_stage(scene) + "/grey_a{a}.h5")
    binary = args.binary if args.binary is not None else _existing(scene, "segment/binary_a{a}.h5")
    lpt = args.lpt if args.lpt is not None else _existing(scene, "lpt/lpt_a{a}.h5")
    out = Path(args.out or Path("results", scene.name, "report", "index.html"))
    build_report(sweep, out, settings=scene.report, grey=grey, binary=binary, lpt=lpt, scene_name=scene.name)
    print(f"report: written {out}", file=sys.stderr)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("report", help="accuracy-versus-cost report (HTML + PNG) of a scene's sweep")
    p.add_argument("scene", help="scene YAML file")
    p.add_argument("--sweep", help="sweep.h5 (default results/<scene>/sweep/sweep.h5)")
    p.add_argument("--grey", nargs="*", help="grey_a{a}.h5 files for cross-sections (default: those present)")
    p.add_argument("--binary", nargs="*", help="binary_a{a}.h5 files for cross-sections (default: those present)")
    p.add_argument("--lpt", nargs="*", help="lpt_a{a}.h5 files for LPT curves (default: those present)")
    p.add_argument("-o", "--out", help="output index.html (default results/<scene>/report/index.html)")
    p.set_defaults(func=main)
