"""A 2-D granular scene with `report` in its analyses: the workflow ends in its granular report page (no sweep).

Dry runs only (the CI silo and heap tests build the page itself through the same function); one real run of the
report command on a tiny result checks the rule's command line.
"""

import re
import subprocess
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]


def _porepipe(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "porepipe.cli", *args], cwd=cwd, capture_output=True, text=True, check=False
    )


def _scene(tmp_path, analyses, name="heap"):
    scene = yaml.safe_load((ROOT / "config" / "scenes" / "granular-heap-ci.yaml").read_text())
    scene.update(name=name, analyses=analyses)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path


def test_granular_scene_with_report_ends_in_the_granular_report(tmp_path):
    out = _porepipe("run", str(_scene(tmp_path, ["granular", "report"])), "--cores", "1", "-n", cwd=tmp_path)
    assert out.returncode == 0, out.stderr + out.stdout
    rules = dict(re.findall(r"^(\w+)\s+(\d+)\s*$", out.stdout, flags=re.MULTILINE))
    # no sweep, no accuracy-versus-cost report: the granular run and its own report page
    assert rules == {"all": "1", "granular": "1", "granular_report": "1", "total": "3"}
    assert "results/heap/report/index.html" in out.stdout


def test_granular_scene_without_report_runs_granular_only(tmp_path):
    out = _porepipe("run", str(_scene(tmp_path, ["granular"])), "--cores", "1", "-n", cwd=tmp_path)
    assert out.returncode == 0, out.stderr + out.stdout
    rules = dict(re.findall(r"^(\w+)\s+(\d+)\s*$", out.stdout, flags=re.MULTILINE))
    assert rules == {"all": "1", "granular": "1", "total": "2"}


def test_report_granular_names_a_missing_result(tmp_path):
    path = _scene(tmp_path, ["granular", "report"])
    out = _porepipe("report", str(path), "--granular", str(tmp_path / "none.h5"), cwd=tmp_path)
    assert out.returncode != 0
    assert "none.h5 does not exist" in out.stderr and "Traceback" not in out.stderr
