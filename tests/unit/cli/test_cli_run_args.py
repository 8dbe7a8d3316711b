"""`porepipe run` parses its own options wherever they stand and passes only what follows `--` to Snakemake."""

import subprocess
import sys

import pytest

from porepipe import cli

SCENE = "config/scenes/mini.yaml"


@pytest.fixture
def calls(monkeypatch):
    seen = []

    def fake_run(cmd, *args, **kwargs):
        seen.append(cmd)
        return subprocess.CompletedProcess(cmd, 0)

    monkeypatch.setattr(cli.subprocess, "run", fake_run)
    return seen


def _tail(cmd):
    return cmd[cmd.index("--show-failed-logs") + 1 :]


def test_options_after_the_scene_are_porepipes_and_after_dashes_snakemakes(calls, capsys):
    assert cli.main(["run", SCENE, "--cores", "2", "--", "--unlock"]) == 0
    cmd = calls[0]
    assert cmd[cmd.index("--cores") + 1] == "2"
    assert _tail(cmd) == ["--unlock"]  # before: ['--cores', '2', '--', '--unlock'] went to Snakemake


def test_dry_run_flag_is_understood_and_prints_no_results_line(calls, capsys):
    assert cli.main(["run", SCENE, "-n"]) == 0
    assert _tail(calls[0]) == ["--dry-run"]
    assert "results of scene" not in capsys.readouterr().out


def test_unlock_option(calls, capsys):
    assert cli.main(["run", SCENE, "--unlock"]) == 0
    assert _tail(calls[0]) == ["--unlock"]
    assert "results of scene" not in capsys.readouterr().out


def test_plain_run_passes_nothing_extra(calls, capsys):
    assert cli.main(["run", SCENE, "--cores", "1"]) == 0
    assert _tail(calls[0]) == []
    assert "results of scene 'mini'" in capsys.readouterr().out


def test_arguments_after_dashes_may_look_like_porepipe_options(calls):
    assert cli.main(["run", SCENE, "--", "--cores", "9", "-n"]) == 0
    cmd = calls[0]
    assert cmd[cmd.index("--cores") + 1] != "9"  # porepipe's own --cores default
    assert _tail(cmd) == ["--cores", "9", "-n"]


def test_ctrl_c_leaves_snakemake_to_cancel_its_jobs_and_release_its_lock(monkeypatch, tmp_path, capsys):
    """Ctrl-C reaches Snakemake and ``porepipe run`` alike. Before, the KeyboardInterrupt in ``porepipe run`` killed
    Snakemake while it cancelled its jobs: a traceback, an orphaned job, and a lock the next run tripped over. Here a
    stand-in for Snakemake interrupts its parent, then takes 0.5 s to clean up; ``porepipe run`` must wait for it."""
    import sys

    cleaned = tmp_path / "cleaned-up"
    child = (
        "import os, signal, sys, time; os.kill(os.getppid(), signal.SIGINT); time.sleep(0.5); "
        f"open({str(cleaned)!r}, 'w').close(); sys.exit(1)"
    )
    monkeypatch.setattr(cli, "snakemake_command", lambda *args, **kwargs: [sys.executable, "-c", child])
    try:
        code = cli.main(["run", SCENE, "--cores", "1"])
    except KeyboardInterrupt:
        code = "KeyboardInterrupt"
    assert code == 130
    assert cleaned.is_file()  # Snakemake was not killed before it was done
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "interrupted" in err and "Traceback" not in err


@pytest.mark.parametrize("in_the_way", ["results", "results/mini", ".snakemake"])
def test_a_file_in_the_way_of_the_run_folders_is_one_line_before_snakemake(
    in_the_way, calls, monkeypatch, tmp_path, capsys
):
    """Before: Snakemake's traceback (45-65 lines), after it had made .snakemake/ and part of results/."""
    scene = str(cli.Path(SCENE).resolve())
    monkeypatch.chdir(tmp_path)
    (tmp_path / in_the_way).parent.mkdir(parents=True, exist_ok=True)
    (tmp_path / in_the_way).write_text("not a folder")
    before = sorted(tmp_path.rglob("*"))
    assert cli.main(["run", scene, "--cores", "1"]) == 2
    assert calls == []  # Snakemake never started
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"a file is in the way ({in_the_way})" in err
    assert sorted(tmp_path.rglob("*")) == before


def test_an_unwritable_run_folder_is_one_line_before_snakemake(calls, monkeypatch, tmp_path, capsys):
    """A read-only directory (a read-only mount: root's os.access sees it too; faked here, the tests may run as
    root): before, Snakemake's 45-line traceback."""
    from porepipe._shared import atomic

    scene = str(cli.Path(SCENE).resolve())
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(atomic.os, "access", lambda path, mode: cli.Path(path).resolve() != tmp_path)
    assert cli.main(["run", scene, "--cores", "1"]) == 2
    assert calls == []
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{tmp_path} is not writable" in err
    assert list(tmp_path.iterdir()) == []


def test_python_dash_m_porepipe_is_the_porepipe_command(tmp_path):
    """`python -m porepipe` (a venv whose scripts folder is not on PATH) runs the same command, exit codes included."""
    ok = subprocess.run(
        [sys.executable, "-m", "porepipe", "--version"], capture_output=True, text=True, check=False
    )
    assert ok.returncode == 0 and ok.stdout.startswith("porepipe ")
    bad = subprocess.run(
        [sys.executable, "-m", "porepipe", "validate", str(tmp_path / "none.yaml")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert bad.returncode == 2 and "none.yaml" in bad.stderr


@pytest.mark.parametrize("name", ["segment", "logs", "scene", "cost", "voxelize_grains"])
def test_a_file_where_the_workflow_writes_a_folder_in_the_scene_folder_is_one_line_before_snakemake(
    name, calls, monkeypatch, tmp_path, capsys
):
    """Before: Snakemake's traceback ending in NotADirectoryError: 'results/mini/segment' (a dry run too), after it
    had written the scene stamps."""
    scene = str(cli.Path(SCENE).resolve())
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results/mini").mkdir(parents=True)
    (tmp_path / "results/mini" / name).write_text("not a folder")
    before = sorted(tmp_path.rglob("*"))
    assert cli.main(["run", scene, "--cores", "1"]) == 2
    assert calls == []
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"results/mini/{name} is a file where `porepipe run` writes the folder results/mini/{name}/" in err
    assert sorted(tmp_path.rglob("*")) == before


def test_files_of_other_names_and_linked_folders_in_the_scene_folder_are_left_alone(
    calls, monkeypatch, tmp_path, capsys
):
    scene = str(cli.Path(SCENE).resolve())
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results/mini").mkdir(parents=True)
    (tmp_path / "results/mini/notes.txt").write_text("mine")
    (tmp_path / "results/mini/all").write_text("a rule that writes no folder here")
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "results/mini/segment").symlink_to(tmp_path / "elsewhere")
    assert cli.main(["run", scene, "--cores", "1"]) == 0
    assert len(calls) == 1


def test_the_run_folder_names_cover_every_folder_the_rule_files_write_in_a_scene_folder():
    """The names are read from the rule files (rule name = results folder, plus logs, cost and the stamps' folder);
    every `results/{scene}/<x>/` (and `results/{wildcards.scene}/<x>`) the rule files spell must be among them."""
    import re

    from porepipe._shared.resources import workflow_root

    names = cli.run_folder_names()
    rules = sorted((workflow_root() / "workflow" / "rules").glob("*.smk"))
    assert len(rules) >= 10
    written = set()
    for smk in rules:
        written |= set(re.findall(r"results/\{(?:wildcards\.)?scene\}/(\w+)", smk.read_text()))
    assert {"segment", "logs", "cost", "report", "acquire_compare"} <= written
    assert written <= names, sorted(written - names)
    assert "all" not in names and "warm" not in names  # rules that write no folder there
    # the stamps' folder: common.smk writes results/<scene>/<STAMP_FOLDER>/
    assert "STAMP_FOLDER" in (workflow_root() / "workflow/rules/common.smk").read_text() and "scene" in names
