"""The ``porepipe`` command: one subcommand per stage, plus ``validate``, ``run`` and ``warm``."""

from __future__ import annotations

import argparse
import contextlib
import enum
import os
import re
import signal
import subprocess
import sys
import threading
from pathlib import Path

from porepipe import __version__
from porepipe._registry import STAGES, stage_cli_modules, stage_settings
from porepipe._shared.cost import mark_compute_start
from porepipe._shared.errors import PorepipeError
from porepipe._shared.overrides import whole_count
from porepipe.warm import STAGES as WARM_STAGES


def _validate(args) -> int:
    from porepipe._shared.resources import scene_path
    from porepipe.scene import SceneError, load_scene

    failed = 0
    for path in args.scene:
        try:
            scene = load_scene(scene_path(path))
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
    from porepipe._shared.resources import workflow_root

    snakefile = workflow_root() / "Snakefile"
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
        # not Snakemake's `input` trigger (a changed set of input files): a job's warm-up marker (porepipe.warm) is
        # its input only in the run that warms, so the next run found the set changed and redid every job after
        # voxelize; what a job reads of the scene is its stamp (porepipe.scene_stamps), which mtime covers
        "--rerun-triggers",
        "mtime",
        "params",
        "code",
        "software-env",
        "--printshellcmds",
        "--show-failed-logs",
    ]
    if dry_run:
        cmd.append("--dry-run")
    return cmd + (extra or [])


def _run(args) -> int:
    from porepipe._shared.resources import scene_path
    from porepipe.scene import load_scene

    args.scene = str(scene_path(args.scene))
    scene = load_scene(args.scene)  # fail fast, with every problem listed
    _check_run_folder(scene.name)
    extra = (["--unlock"] if args.unlock else []) + args.snakemake_args
    with _interrupts_left_to_snakemake() as interrupted:
        result = subprocess.run(
            snakemake_command(args.scene, args.cores, args.dry_run, extra),
            check=False,
            env=_job_environment(),
        )
    if interrupted and result.returncode != 0:
        print(
            f"porepipe run: interrupted; finished results are kept, `porepipe run {args.scene}` goes on from there",
            file=sys.stderr,
        )
        return 130
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


#: a folder the workflow writes directly inside results/<scene>/, as the rule files spell it
_RESULTS_FOLDER_RE = re.compile(r"results/\{scene\}/(\w+)/")
#: a rule of a rule file: its name, then its body up to the next unindented line
_RULE_RE = re.compile(r"^rule (\w+):\n((?:[ \t].*\n|\n)*)", re.MULTILINE)


def run_folder_names(rules_dir: Path | None = None) -> frozenset[str]:
    """The folders a run writes directly inside ``results/<scene>/``, read from the workflow's rule files.

    Parameters
    ----------
    rules_dir : Path, optional
        The folder of the ``*.smk`` rule files (default: this installation's ``workflow/rules``).

    Returns
    -------
    frozenset of str
        Every rule whose own lines write ``results/{scene}/<rule>/`` (rule name = results folder), Snakemake's
        ``log:`` and ``benchmark:`` folders (``logs``, ``cost``) and the scene stamps' folder
        (:data:`porepipe.scene_stamps.STAMP_FOLDER`).
    """
    from porepipe._shared.resources import workflow_root
    from porepipe.scene_stamps import STAMP_FOLDER

    rules_dir = workflow_root() / "workflow" / "rules" if rules_dir is None else Path(rules_dir)
    names = {"logs", "cost", STAMP_FOLDER}
    for smk in sorted(rules_dir.glob("*.smk")):
        for rule, body in _RULE_RE.findall(smk.read_text(encoding="utf-8")):
            if rule in _RESULTS_FOLDER_RE.findall(body):
                names.add(rule)
    return frozenset(names)


def _check_run_folder(scene_name: str) -> None:
    """Before Snakemake starts: the folders a run writes in the current directory (``results/<scene>`` and Snakemake's
    ``.snakemake``) can be made and written, and no file in ``results/<scene>/`` has the name of a folder the workflow
    writes there (:func:`run_folder_names`). Before, a read-only directory or a file named ``results`` (or
    ``results/<scene>/segment``, ``.../logs``) gave Snakemake's traceback of 45-65 lines, after it had made
    ``.snakemake`` and some of ``results/``.
    """
    from porepipe._shared.atomic import check_output_dir

    for folder in (Path("results", scene_name), Path(".snakemake")):
        try:
            check_output_dir(folder)
        except PorepipeError as err:
            raise PorepipeError(
                f"{err}; `porepipe run` writes results/{scene_name}/ and .snakemake/ in the current directory "
                f"({Path.cwd()})"
            ) from None
    scene_dir = Path("results", scene_name)
    if not scene_dir.is_dir():
        return
    with os.scandir(scene_dir) as entries:  # one listing; a folder (or a link to one) is fine
        files = sorted(e.name for e in entries if not e.is_dir())
    if not files:
        return
    # the rule files are read once, and only where a file sits in the scene's folder
    folders = run_folder_names()
    in_the_way = [name for name in files if name in folders]
    if in_the_way:
        raise PorepipeError(
            f"{scene_dir / in_the_way[0]} is a file where `porepipe run` writes the folder "
            f"{scene_dir / in_the_way[0]}/; move or remove it (current directory {Path.cwd()})"
        )


@contextlib.contextmanager
def _interrupts_left_to_snakemake():
    """While Snakemake runs, Ctrl-C does not stop ``porepipe run`` itself (yields a list that gets an entry per one).

    The terminal sends Ctrl-C to Snakemake and its jobs as well; Snakemake then cancels the jobs and releases its lock
    on the directory. Before, the KeyboardInterrupt in ``subprocess.run`` killed Snakemake (SIGKILL) in the middle of
    that: a traceback, an orphaned job still running, and a lock that made the next run fail until ``--unlock``.
    A handler (not SIG_IGN) is reset by exec, so Snakemake still gets SIGINT's default.
    """
    interrupted: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield interrupted
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: interrupted.append(signum))
    try:
        yield interrupted
    finally:
        signal.signal(signal.SIGINT, previous)


def _job_environment() -> dict:
    """The environment of the Snakemake run: on a terminal, the jobs also write sparse progress lines to it."""
    from porepipe._shared.progress import CONSOLE_ENV

    env = dict(os.environ)
    if sys.stderr.isatty() and not env.get("CI") and os.path.exists("/dev/tty"):
        env[CONSOLE_ENV] = "/dev/tty"
    return env


def _warm(args) -> int:
    from porepipe._shared.resources import scene_path
    from porepipe.warm import warm

    # a failed warm-up says so in one line and leaves the compiling to the stage's jobs
    warm(scene_path(args.scene), args.stage, main)
    if args.out:
        Path(args.out).touch()
    return 0


#: ``porepipe --help``'s text (the module docstring printed its reST markup, ``porepipe``, and left out ``warm``)
_DESCRIPTION = (
    "porepipe: one subcommand per stage of the workflow, plus validate (check scene files), run (a scene's whole "
    "workflow with Snakemake) and warm (compile a stage's kernels ahead of its jobs). `porepipe COMMAND --help` "
    "describes each."
)


def build_parser() -> argparse.ArgumentParser:
    """The ``porepipe`` argument parser with every stage's subcommands."""
    parser = argparse.ArgumentParser(prog="porepipe", description=_DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"porepipe {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("validate", help="check scene files; list every problem")
    p.add_argument("scene", nargs="+", help="scene YAML files, or names of shipped scenes (mini, …)")
    p.set_defaults(func=_validate)
    p = sub.add_parser("run", help="run the whole workflow of a scene with Snakemake")
    p.add_argument("scene", help="scene YAML file, or the name of a shipped scene (mini, granular-box, …)")
    p.add_argument(
        "--cores",
        type=whole_count("--cores"),
        default=os.cpu_count() or 1,
        help="cores Snakemake may use (default: all)",
    )
    p.add_argument(
        "-n", "--dry-run", action=argparse.BooleanOptionalAction, default=False, help="list the jobs only"
    )
    p.add_argument(
        "--unlock",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="release the lock a killed run left on this directory (Snakemake --unlock), run nothing",
    )
    p.epilog = (
        "Arguments after `--` go to Snakemake unchanged, e.g. `porepipe run S.yaml --cores 2 -- --forceall`."
    )
    p.set_defaults(func=_run, snakemake_args=[])
    p = sub.add_parser(
        "warm", help="compile one stage's kernels for a scene ahead of its jobs, on a tiny twin"
    )
    p.add_argument("stage", choices=WARM_STAGES, help="the stage whose kernels to compile")
    p.add_argument("--scene", required=True, help="scene YAML file, or the name of a shipped scene")
    p.add_argument("-o", "--out", help="a file to create when done (the workflow's marker)")
    p.set_defaults(func=_warm)
    settings = stage_settings()
    for (_package, key), module in zip(STAGES, stage_cli_modules()):
        before = set(sub.choices)
        module.register(sub)
        for name in set(sub.choices) - before:
            _help_from_settings(sub.choices[name], settings.get(key))
    return parser


def _help_from_settings(parser: argparse.ArgumentParser, model) -> None:
    """Give each option of a stage command that overrides a scene setting (of ``model``, a stage's Settings or None)
    that setting's description as help (``--threads`` brings its own: ``_shared.overrides.add_threads_option``).
    """
    for action in parser._actions:
        field = model.model_fields.get(action.dest) if model is not None else None
        if action.help is None and field is not None and field.description:
            default = field.get_default(call_default_factory=True)
            shown = str(default).lower() if isinstance(default, bool) else repr(_shown(default))
            action.help = f"{field.description} (default: the scene's, else {shown})"


def _shown(value):
    """A setting's default as a scene writes it: an Enum by its value, a list element by element (a bool is shown
    as YAML's true/false by the caller: its repr False is Python's).
    """
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, list | tuple):
        return [_shown(v) for v in value]
    return value


def _split_passthrough(argv: list[str]) -> tuple[list[str], list[str]]:
    """``run … -- ARGS``: the porepipe arguments and the ones after the first ``--`` (for Snakemake)."""
    if argv[:1] == ["run"] and "--" in argv:
        cut = argv.index("--")
        return argv[:cut], argv[cut + 1 :]
    return argv, []


#: the options that name files a subcommand writes (a checkpoint is also read on resume)
_OUTPUTS = ("out", "xyzr", "checkpoint")


def _flag(option: str) -> str:
    return "-o" if option == "out" else f"--{option}"


def _input_files(args) -> list[Path]:
    """The existing files that a subcommand's other arguments name (its inputs: volumes, scene ...)."""
    files = []
    for key, value in vars(args).items():
        if key in _OUTPUTS or key == "func":
            continue
        for item in value if isinstance(value, (list, tuple)) else (value,):
            if isinstance(item, (str, os.PathLike)) and Path(item).is_file():
                files.append(Path(item))
    return files


def _check_outputs(args) -> None:
    """Every subcommand's output names (``-o``, ``--xyzr``, ``--checkpoint``, ``--out-dir``) are checked before it
    computes anything. Refused: two of them naming one file (the last write, or the checkpoint's removal at the end,
    would take the result), one that is the command's own input file (its atomic write would replace it), and ``-o``
    with ``--out-dir`` (one of them would be ignored).
    """
    from porepipe._shared.atomic import prepare_output, prepare_output_dir

    if getattr(args, "out", None) and getattr(args, "out_dir", None):
        raise PorepipeError(
            f"-o {args.out} and --out-dir {args.out_dir} both name the output; give one of them"
        )
    named, inputs = {}, None
    for option in _OUTPUTS:
        target = getattr(args, option, None)
        if not target:
            continue
        same = named.setdefault(Path(target).resolve(), option)
        if same != option:
            raise PorepipeError(
                f"{_flag(same)} and {_flag(option)} both name {target}; give each its own file"
            )
        if Path(target).is_file():
            inputs = _input_files(args) if inputs is None else inputs
            if any(os.path.samefile(f, target) for f in inputs):
                raise PorepipeError(
                    f"output {target} ({_flag(option)}) is also an input of this command and would be "
                    "overwritten; give another output name"
                )
        prepare_output(target)
    if getattr(args, "out_dir", None):
        prepare_output_dir(args.out_dir)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``porepipe`` command; returns the exit code (2 on bad input, with one line on stderr)."""
    own, passthrough = _split_passthrough(list(sys.argv[1:] if argv is None else argv))
    args = build_parser().parse_args(own)
    if args.command == "run":
        args.snakemake_args = passthrough
    if args.command not in ("run", "validate"):
        from porepipe._shared.progress import watch_compilation

        watch_compilation()  # "compiling kernels (first run only)" and its time apart
    mark_compute_start(
        args.func
    )  # result files count their cost from here; start-up (interpreter, imports) apart
    try:
        _check_outputs(args)
        return int(args.func(args) or 0)
    except PorepipeError as err:
        print(f"porepipe {args.command}: error: {err}", file=sys.stderr)
        return 2
    except (
        KeyboardInterrupt
    ):  # Ctrl-C: one line, not a traceback; results are written atomically, so none is half there
        print(f"porepipe {args.command}: interrupted; no result written{_resume_hint(args)}", file=sys.stderr)
        return 130


def _resume_hint(args) -> str:
    """Where an interrupted stage command can continue from (its ``--checkpoint``, if it took one)."""
    checkpoint = getattr(args, "checkpoint", None)
    if not checkpoint:
        return ""
    return f" (rerun with --checkpoint {checkpoint} --resume to continue from its last checkpoint, if one was written)"


if __name__ == "__main__":
    sys.exit(main())
