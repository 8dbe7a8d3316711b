"""Every option of every `porepipe` command has help text, every on/off flag is a BooleanOptionalAction (--x/--no-x),
and a misspelt scene key is answered with the closest allowed key."""

import argparse

import pytest

from porepipe.cli import build_parser
from porepipe.scene import SceneError, parse_scene


def _actions(parser, name="porepipe"):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                yield from _actions(sub, f"{name} {sub_name}")
        elif not isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
            yield name, action


def test_every_option_has_help_text():
    missing = [f"{name} {a.option_strings or a.dest}" for name, a in _actions(build_parser()) if not a.help]
    assert not missing


def test_no_store_true_flags_and_no_true_false_strings():
    bad = [
        f"{name} {a.option_strings}"
        for name, a in _actions(build_parser())
        if isinstance(a, (argparse._StoreTrueAction, argparse._StoreFalseAction))
        or (a.type is not None and getattr(a.type, "__name__", "") == "_bool")
    ]
    assert not bad
    flags = {
        (name, a.option_strings[0])
        for name, a in _actions(build_parser())
        if isinstance(a, argparse.BooleanOptionalAction)
    }
    assert ("porepipe permeability", "--write-fields") in flags
    assert ("porepipe acquire", "--grains") in flags


@pytest.mark.parametrize(
    ("section", "typo", "meant"),
    [(None, "sead", "seed"), ("domain", "periodc", "periodic"), ("permeability", "colision", "collision")],
)
def test_unknown_key_gets_the_closest_allowed_key(section, typo, meant):
    raw = {
        "name": "t",
        "domain": {"size_um": [8, 8, 8]},
        "resolutions_um": [4],
        "spheres": {"inline": [[4, 4, 4, 2]]},
        "analyses": ["segment"],
    }
    (raw.setdefault(section, {}) if section else raw)[typo] = 1
    with pytest.raises(SceneError) as err:
        parse_scene(raw)
    (line,) = [p for p in err.value.problems if typo in p]
    assert line.endswith(f"did you mean {meant!r}?")


def test_a_key_unlike_any_gets_no_suggestion():
    with pytest.raises(SceneError) as err:
        parse_scene({"name": "t", "domain": {"size_um": [8, 8, 8]}, "resolutions_um": [4], "zzqqxx": 1})
    (line,) = [p for p in err.value.problems if p.startswith("zzqqxx")]
    assert "did you mean" not in line


class _Terminal:
    def isatty(self):
        return True

    def write(self, text):
        return len(text)

    def flush(self):
        pass


def test_run_names_its_terminal_to_the_jobs_only_on_a_terminal_outside_ci(monkeypatch):
    import sys

    from porepipe import cli
    from porepipe._shared.progress import CONSOLE_ENV

    monkeypatch.delenv("CI", raising=False)
    monkeypatch.delenv(CONSOLE_ENV, raising=False)
    assert CONSOLE_ENV not in cli._job_environment()  # pytest's stderr is no terminal
    monkeypatch.setattr(sys, "stderr", _Terminal())
    monkeypatch.setattr(cli.os.path, "exists", lambda path: path == "/dev/tty")
    assert cli._job_environment()[CONSOLE_ENV] == "/dev/tty"
    monkeypatch.setenv("CI", "1")
    assert CONSOLE_ENV not in cli._job_environment()


def test_threads_below_one_are_refused_by_every_subcommand(capsys):
    """``--threads 0`` or ``-3`` ran on one thread without a word; every subcommand that takes it now refuses it."""
    taking = [(name, a) for name, a in _actions(build_parser()) if "--threads" in a.option_strings]
    assert len(taking) >= 11
    for name, action in taking:
        assert action.type("2") == 2, name
        for bad in ("0", "-3", "two"):
            with pytest.raises(argparse.ArgumentTypeError):
                action.type(bad)
    with pytest.raises(SystemExit) as stop:
        build_parser().parse_args(["minkowski", "b.h5", "-o", "m.h5", "--threads", "0"])
    assert stop.value.code == 2
    assert "argument --threads: 0: give 1 or more" in capsys.readouterr().err


def test_run_refuses_fewer_than_one_core(capsys):
    """``porepipe run S --cores 0`` handed Snakemake 0 cores, which scheduled nothing and waited for ever."""
    assert build_parser().parse_args(["run", "mini", "--cores", "3"]).cores == 3
    with pytest.raises(SystemExit) as stop:
        build_parser().parse_args(["run", "mini", "--cores", "0"])
    assert stop.value.code == 2
    assert "argument --cores: 0: give 1 or more (leave --cores out for every core)" in capsys.readouterr().err


def test_a_negative_seed_is_refused_by_every_subcommand(tmp_path, capsys):
    """``--seed -1`` got past the command line and ended in the random streams' raw ValueError ('seed must be >= 0')
    once diffusion or granular had started; the scene's ``seed:`` refuses it, and so does every ``--seed`` now."""
    from porepipe.cli import main

    taking = [(name, a) for name, a in _actions(build_parser()) if "--seed" in a.option_strings]
    assert {name for name, _ in taking} >= {"porepipe diffusion", "porepipe granular"}
    for name, action in taking:
        assert action.type("0") == 0, name
        for bad in ("-1", "1.5", "seven"):
            with pytest.raises(argparse.ArgumentTypeError):
                action.type(bad)
    out = tmp_path / "d.h5"
    with pytest.raises(SystemExit) as stop:
        main(["diffusion", str(tmp_path / "binary_a1.h5"), "-o", str(out), "--seed", "-1"])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "porepipe diffusion: error: argument --seed: -1: give a whole number >= 0, as the scene's seed"
    )
    assert not out.exists()


@pytest.mark.parametrize("name", ["a/b", "x y", "", "_model"])
def test_acquire_calibrate_refuses_a_name_no_scene_may_have(tmp_path, capsys, name):
    """``acquire-calibrate --name a/b`` ran the calibration, then the scene it wrote was refused in a multi-line scene
    error; ``--name ''`` fell back to the default name without a word. A scene name is now checked on the command
    line, against the pattern of the scene's ``name:``."""
    from porepipe.cli import main

    out = tmp_path / "model.yaml"
    with pytest.raises(SystemExit) as stop:
        main(["acquire-calibrate", str(tmp_path / "statistics.h5"), "--name", name, "-o", str(out)])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        f"porepipe acquire-calibrate: error: argument --name: {name!r}: a scene name is a letter or digit, "
        "then letters, digits, '_', '.' or '-'"
    )
    assert not out.exists()
    assert build_parser().parse_args(
        ["acquire-calibrate", "s.h5", "--name", "rock-1.b_2", "-o", "m.yaml"]
    ).name == ("rock-1.b_2")


def test_sweep_adaptive_refuses_fewer_than_one_core(capsys):
    """``porepipe sweep --adaptive S --cores 0`` wrote the round's scene copies and then handed Snakemake 0 cores,
    which scheduled nothing and waited for ever (parsed here only: the old code would hang)."""
    assert build_parser().parse_args(["sweep", "--adaptive", "s.yaml"]).cores == 1
    assert build_parser().parse_args(["sweep", "--adaptive", "s.yaml", "--cores", "2"]).cores == 2
    for bad in ("0", "-1"):
        with pytest.raises(SystemExit) as stop:
            build_parser().parse_args(["sweep", "--adaptive", "s.yaml", "--cores", bad])
        assert stop.value.code == 2
        assert capsys.readouterr().err.splitlines()[-1] == (
            f"porepipe sweep: error: argument --cores: {bad}: give 1 or more (leave --cores out for one core)"
        )


def test_subsample_count_is_one_of_the_grids_on_the_command_line(capsys):
    """``subsample --count 3`` was refused by the cutting code naming the scene key sweep.subsamples, not the
    option; argparse now names --count and the choices."""
    assert (
        build_parser().parse_args(["subsample", "b.h5", "--edge-um", "8", "-o", "s.h5", "--count", "8"]).count
        == 8
    )
    with pytest.raises(SystemExit) as stop:
        build_parser().parse_args(["subsample", "b.h5", "--edge-um", "8", "-o", "s.h5", "--count", "3"])
    assert stop.value.code == 2
    assert "argument --count: invalid choice: 3 (choose from 1, 8, 64)" in capsys.readouterr().err


def test_the_top_level_help_is_plain_text_and_names_every_command_beside_the_stages(capsys):
    # before: the module docstring, with its reST markup (``porepipe``) and without `warm`
    with pytest.raises(SystemExit):
        build_parser().parse_args(["--help"])
    text = capsys.readouterr().out
    assert "``" not in text
    description = text.split("positional arguments")[0]
    assert all(name in description for name in ("validate", "run", "warm"))


def test_a_boolean_settings_default_is_shown_as_a_scene_writes_it(capsys):
    # before: "(default: the scene's, else False)", Python's spelling
    with pytest.raises(SystemExit):
        build_parser().parse_args(["permeability", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "else False" not in text and "else True" not in text
    assert "(default: the scene's, else false)" in text


@pytest.mark.parametrize(
    ("extra", "hint"), [([], ""), (["--checkpoint", "ck.h5"], " (rerun with --checkpoint ck.h5 --resume")]
)
def test_ctrl_c_in_a_stage_command_is_one_line_and_exit_130(monkeypatch, tmp_path, capsys, extra, hint):
    # before: Ctrl-C in `porepipe pack` printed the whole KeyboardInterrupt traceback
    import porepipe.packing._cli as pack_cli
    from porepipe.cli import main

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(pack_cli, "main", interrupted)
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "s.yaml"
    scene.write_text("name: s\n")
    assert main(["pack", str(scene), "-o", "out.h5", *extra]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("porepipe pack: interrupted; no result written" + hint)
    assert not (tmp_path / "out.h5").exists()
