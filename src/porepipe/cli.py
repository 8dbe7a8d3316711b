"""The ``porepipe`` command: one subcommand per stage, plus ``validate`` and ``run``."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from porepipe import __version__
from porepipe._registry import stage_cli_modules
from porepipe._shared.cost import mark_compute_start
from porepipe._shared.errors import PorepipeError

#: the repository root holding the Snakefile (src layout: <root>/src/porepipe/cli.py)
REPO_ROOT = Path(__file__).resolve().parents[2]


def _validate(args) -> int:
    from porepipe.scene import SceneError, load_scene

    failed = 0
    for path in args.scene:
        try:
            scene = load_scene(path)
        except SceneError as err:
            failed += 1
            print(err, file=sys.stderr)
            continue
        print(f"{path}: ok (scene {scene.name!r}, analyses {[a.value for a in scene.analyses]})")
    return 2 if failed else 0


def snakemake_command(
    scene_path, cores: int, dry_run: bool = False, extra: list[str] | None = None
) -> list[str]:
    """The Snakemake invocation that runs one scene from the current directory."""
    snakefile = REPO_ROOT / "Snakefile"
    if not snakefile.is_file():
        raise PorepipeError(
            f"Snakefile not found at {snakefile}; install porepipe from its repository (pip install -e .)"
        )
    cmd = [
        sys.executable,
        "-m",
        "snakemake",
        "--snakefile",
        str(snakefile),
        "--directory",
        os.getcwd(),
        "--cores",
        str(cores),
        "--config",
        f"scene={Path(scene_path).resolve()}",
        "--rerun-incomplete",
        "--printshellcmds",
        "--show-failed-logs",
    ]
    if dry_run:
        cmd.append("--dry-run")
    return cmd + (extra or [])


def _run(args) -> int:
    from porepipe.scene import load_scene

    scene = load_scene(args.scene)  # fail fast, with every problem listed
    extra = (["--unlock"] if args.unlock else []) + args.snakemake_args
    result = subprocess.run(snakemake_command(args.scene, args.cores, args.dry_run, extra), check=False)
    if result.returncode == 0 and not (args.dry_run or args.unlock):
        print(f"porepipe: results of scene {scene.name!r} are in {Path('results', scene.name).resolve()}")
    elif (
        result.returncode != 0
        and Path(".snakemake", "locks").is_dir()
        and any(Path(".snakemake", "locks").iterdir())
    ):
        print(
            f"porepipe run: if no other run of this directory is alive (a killed run leaves its lock), "
            f"`porepipe run {args.scene} --unlock` releases the lock; then run again",
            file=sys.stderr,
        )
    return result.returncode


def build_parser() -> argparse.ArgumentParser:
    """The ``porepipe`` argument parser with every stage's subcommands."""
    parser = argparse.ArgumentParser(prog="porepipe", description=__doc__)
    parser.add_argument("--version", action="version", version=f"porepipe {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("validate", help="check scene files; list every problem")
    p.add_argument("scene", nargs="+")
    p.set_defaults(func=_validate)
    p = sub.add_parser("run", help="run the whole workflow of a scene with Snakemake")
    p.add_argument("scene")
    p.add_argument("--cores", type=int, default=os.cpu_count() or 1)
    p.add_argument("-n", "--dry-run", action="store_true", help="list the jobs only")
    p.add_argument(
        "--unlock",
        action="store_true",
        help="release the lock a killed run left on this directory (Snakemake --unlock), run nothing",
    )
    p.epilog = (
        "Arguments after `--` go to Snakemake unchanged, e.g. `porepipe run S.yaml --cores 2 -- --forceall`."
    )
    p.set_defaults(func=_run, snakemake_args=[])
    for module in stage_cli_modules():
        module.register(sub)
    return parser


def _split_passthrough(argv: list[str]) -> tuple[list[str], list[str]]:
    """``run … -- ARGS``: the porepipe arguments and the ones after the first ``--`` (for Snakemake)."""
    if argv[:1] == ["run"] and "--" in argv:
        cut = argv.index("--")
        return argv[:cut], argv[cut + 1 :]
    return argv, []


def _check_outputs(args) -> None:
    """Every subcommand's output names (``-o``, ``--xyzr``) are checked before it computes anything."""
    from porepipe._shared.atomic import prepare_output

    for option in ("out", "xyzr"):
        if getattr(args, option, None):
            prepare_output(getattr(args, option))


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``porepipe`` command; returns the exit code (2 on bad input, with one line on stderr)."""
    own, passthrough = _split_passthrough(list(sys.argv[1:] if argv is None else argv))
    args = build_parser().parse_args(own)
    if args.command == "run":
        args.snakemake_args = passthrough
    mark_compute_start(
        args.func
    )  # result files count their cost from here; start-up (interpreter, imports) apart
    try:
        _check_outputs(args)
        return int(args.func(args) or 0)
    except PorepipeError as err:
        print(f"porepipe {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
