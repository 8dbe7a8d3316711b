"""`pip install .` (not -e) ships the workflow: a wheel built from this tree holds the Snakefile, the rules and the
scenes under porepipe/_workflow, and `porepipe run -n` from the unpacked wheel, in a folder without the repository,
plans the mini scene's jobs with that Snakefile."""

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from porepipe._shared.errors import PorepipeError
from porepipe._shared.resources import scene_path, workflow_root

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(out), str(ROOT)],
        check=True,
        capture_output=True,
    )
    (path,) = out.glob("porepipe-*.whl")
    return path


def test_wheel_holds_every_rule_file_and_scene(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    wanted = ["Snakefile", "config/config.yaml"]
    wanted += [str(p.relative_to(ROOT)) for p in (ROOT / "workflow").rglob("*") if p.is_file()]
    wanted += [str(p.relative_to(ROOT)) for p in (ROOT / "config" / "scenes").glob("*.yaml")]
    missing = [w for w in wanted if f"porepipe/_workflow/{w}" not in names]
    assert not missing


def test_installed_run_finds_its_snakefile_outside_the_repository(wheel, tmp_path):
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    assert workflow_root(site / "porepipe") == site / "porepipe" / "_workflow"
    work = tmp_path / "work"
    work.mkdir()
    env = dict(os.environ, PYTHONPATH=str(site))
    code = "import sys, porepipe.cli as c; print(c.__file__, flush=True); sys.exit(c.main(sys.argv[1:]))"
    run = subprocess.run(
        [sys.executable, "-c", code, "run", "mini", "-n", "--cores", "1"],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    # flushed before the run starts: Snakemake, a child process, writes to the same pipe
    assert run.stdout.splitlines()[0].startswith(str(site))  # the unpacked copy ran, not the repository's
    assert "rule voxelize" in run.stdout + run.stderr  # the DAG of the shipped mini scene was planned


def test_editable_layout_uses_the_repository_and_a_bare_tree_is_refused(tmp_path):
    assert workflow_root() == ROOT  # tests run from an editable install of this repository
    assert scene_path("mini") == ROOT / "config" / "scenes" / "mini.yaml"
    assert scene_path("no/such.yaml") == Path("no/such.yaml")  # paths are left to the scene loader's message
    (tmp_path / "a" / "porepipe").mkdir(parents=True)
    with pytest.raises(PorepipeError, match="Snakefile"):
        workflow_root(tmp_path / "a" / "porepipe")
