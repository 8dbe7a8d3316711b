"""The kernel warm-up (porepipe.warm): after ``porepipe warm`` the stage's real jobs compile nothing; a twin that
fails says so in one line and leaves no marker; the twin keeps every kernel-selecting setting of its scene.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from porepipe import warm as W
from porepipe.cli import main
from porepipe.scene import load_scene

ROOT = Path(__file__).resolve().parents[3]
MINI = ROOT / "config" / "scenes" / "mini.yaml"

#: a scene of inline spheres whose volumes (10^3 and 20^3 voxels) run the serial kernel variants
SMALL_SCENE = {
    "name": "warm-small",
    "domain": {"size_um": [40, 40, 40], "periodic": True},
    "spheres": {"inline": [[10, 10, 10, 9], [30, 28, 31, 10], [12, 30, 25, 8], [29, 11, 12, 9]]},
    "resolutions_um": [4, 2],
    "segmentation": {"method": "otsu"},
    "analyses": ["segment", "minkowski"],
}


def _porepipe(*args, cwd, env):
    return subprocess.run(
        [sys.executable, "-m", "porepipe.cli", *map(str, args)],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
    )


@pytest.mark.slow
def test_after_the_warm_up_the_stages_own_jobs_compile_nothing(tmp_path):
    # a fresh numba cache: everything compiles here, in the warm-up, and not again in the jobs; the jobs' own
    # announcement of a real compilation ("compiling kernels") is what tells
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "CI": "1"}
    scene = tmp_path / "s.yaml"
    scene.write_text(yaml.safe_dump(SMALL_SCENE))
    warm = _porepipe("warm", "minkowski", "--scene", scene, "-o", tmp_path / "done", cwd=tmp_path, env=env)
    assert warm.returncode == 0, warm.stderr[-2000:]
    assert (tmp_path / "done").is_file() and W.marker_path(scene, "minkowski").name in os.listdir(
        tmp_path / "cache"
    )
    jobs = [
        ("voxelize", scene, "--a", 2, "-o", "g.h5", "--threads", 1),
        ("segment", "g.h5", "-o", "b.h5", "--method", "otsu"),
        ("minkowski", "b.h5", "--scene", scene, "-o", "m.h5", "--threads", 1),
    ]
    for job in jobs:
        out = _porepipe(*job, cwd=tmp_path, env=env)
        assert out.returncode == 0, out.stderr[-2000:]
        assert "compiling kernels" not in out.stderr, (job[0], out.stderr[-2000:])


def test_a_twin_that_fails_says_so_in_one_line_and_leaves_no_marker(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(
        W, "_commands", lambda *args: [["segment", str(tmp_path / "missing.h5"), "-o", "b.h5"]]
    )
    assert W.warm(MINI, "lpt", main) is False
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("porepipe warm")]
    assert (
        len(lines) == 1 and "`porepipe segment` on the twin failed" in lines[0] and "missing.h5" in lines[0]
    )
    assert not W.marker_path(MINI, "lpt").is_file()


def test_the_twin_keeps_the_kernel_selecting_settings_and_shrinks_the_rest(tmp_path):
    scene = yaml.safe_load(MINI.read_text())
    twin = W.twin(MINI, W.SMALL_EDGE)
    for key in ("segmentation", "domain"):
        assert {k: v for k, v in twin[key].items() if k != "size_um"} == {
            k: v for k, v in scene[key].items() if k != "size_um"
        }
    resized = ("resolutions_um", "whole_volume")  # the twin flows through its whole box at its one resolution
    assert {k: v for k, v in twin["permeability"].items() if k not in resized} == {
        k: v for k, v in scene["permeability"].items() if k not in resized
    }
    a = max(scene["resolutions_um"])
    assert twin["resolutions_um"] == [a] and twin["domain"]["size_um"] == [W.SMALL_EDGE * a] * 3
    assert "packing" not in twin and len(twin["spheres"]["inline"]) == 8
    (tmp_path / "twin.yaml").write_text(yaml.safe_dump(twin))
    assert load_scene(tmp_path / "twin.yaml").name == "twin"  # a valid scene
    # the mini's 100^3 volume at 1 µm runs the parallel variants: minkowski warms both twins, permeability (at
    # 4 µm only) the small one
    mini = load_scene(MINI)
    assert W.twin_edges(mini, "minkowski") == [W.SMALL_EDGE, W.LARGE_EDGE]
    assert W.twin_edges(mini, "permeability") == [W.SMALL_EDGE]
    assert W.LARGE_EDGE**3 > 2**17 >= W.SMALL_EDGE**3


def test_the_marker_follows_the_twins_not_the_scene_file(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    scene = tmp_path / "s.yaml"
    scene.write_text(yaml.safe_dump(SMALL_SCENE))
    first = W.marker_path(scene, "minkowski")
    assert first.parent == tmp_path and first != W.marker_path(scene, "lpt")
    # a finer resolution whose volume (20^3 -> 40^3) still runs the serial variants: the same twin, the same marker
    scene.write_text(yaml.safe_dump({**SMALL_SCENE, "name": "other", "resolutions_um": [4, 1]}))
    assert W.marker_path(scene, "minkowski") == first
    # what the twin keeps changes it: a kernel-selecting setting, or a volume that needs the parallel variants
    scene.write_text(yaml.safe_dump({**SMALL_SCENE, "segmentation": {"method": "fixed", "threshold": 128}}))
    assert W.marker_path(scene, "minkowski") != first
    scene.write_text(yaml.safe_dump({**SMALL_SCENE, "resolutions_um": [4, 0.5]}))
    assert W.marker_path(scene, "minkowski") != first


def test_every_shipped_scene_with_a_warm_up_has_valid_twins(tmp_path):
    # a twin the scene schema refused would only cost its warm-up (one line, the jobs compile), but it would cost
    # it on every cold run of that scene
    checked = 0
    for path in sorted((ROOT / "config" / "scenes").glob("*.yaml")):
        scene = load_scene(path)
        if not W.warmable(scene):
            continue
        for edge in {e for stage in W.STAGES for e in W.twin_edges(scene, stage)}:
            twin = tmp_path / f"{path.stem}-{edge}.yaml"
            twin.write_text(yaml.safe_dump(W.twin(path, edge)))
            load_scene(twin)
            checked += 1
    assert checked >= 10


def test_a_marker_folder_that_cannot_be_written_costs_the_marker_not_the_run(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(blocker / "cache"))  # a folder inside a file: mkdir fails
    monkeypatch.setattr(W, "_run_twin", lambda *args: True)
    assert W.warm(MINI, "minkowski", main) is True
    assert "no marker kept" in capsys.readouterr().err and not W.marker_path(MINI, "minkowski").is_file()
