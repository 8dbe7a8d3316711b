"""Checkpoints of the packing by wall time and by steps: `porepipe pack --checkpoint F` saves the run's state with the
default settings, a run resumed from any of its checkpoints ends bit for bit where an uninterrupted one ends, and the
checkpoint intervals (run control) change neither the packing nor its result hash.

Time is a fake clock (``_checkpoint_clock``, read once at the start and once per step) that advances a fixed amount per
read, so when a wall-time checkpoint falls is exact arithmetic, not a race with the machine's speed.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

import porepipe.packing._api as engine  # the names the engine calls: save_checkpoint and the checkpoint clock
from porepipe.cli import main as cli_main
from porepipe.packing import Settings, pack_spheres
from porepipe.packing._api import HISTORY_TIMING

TINY = (
    Path(__file__).parents[2] / "hard" / "data" / "tiny" / "tiny.yaml"
)  # 40 spheres, 60 steps, not converged
SPHERE_KEYS = ("centres_um", "radii_um", "types", "max_overlap", "converged")
BOX = [600.0, 600.0, 600.0]


def _fake_clock(step_s: float):
    """A clock that advances ``step_s`` seconds per read, starting at 0."""
    counter = itertools.count()
    return lambda: step_s * next(counter)


def _record_saves(monkeypatch, die_at: int | None = None) -> list[int]:
    """Record the stage step of every checkpoint written; after the one of step ``die_at``, simulate a kill."""
    real_save, steps = engine.save_checkpoint, []

    def save(path, state, key, clock):
        real_save(path, state, key, clock)
        steps.append(state.step)
        if die_at is not None and state.step >= die_at:
            raise KeyboardInterrupt(f"simulated kill after the checkpoint of step {state.step}")

    monkeypatch.setattr(engine, "save_checkpoint", save)
    return steps


def _scene(tmp_path: Path, name: str = "tiny.yaml", **packing) -> Path:
    """The tiny scene with its packing section's keys updated (the shipped one sets no checkpoint interval)."""
    tree = yaml.safe_load(TINY.read_text())
    tree["packing"].update(packing)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(tree))
    return path


def _read(path: Path) -> dict:
    with h5py.File(path, "r") as f:
        arrays = {k: f[k][...] for k in SPHERE_KEYS}
        history = {k: f["history"][k][...] for k in f["history"] if k not in HISTORY_TIMING}
        return {"arrays": arrays, "history": history, "attrs": dict(f.attrs)}


def test_pack_with_a_checkpoint_file_saves_by_wall_time_with_the_default_settings(tmp_path, monkeypatch):
    # before: packing.checkpoint_every defaults to 0 and was the only interval, so `--checkpoint F` (which the pack
    # rule always passes) never wrote F and a killed pack job started again from step 0
    scene, ck = _scene(tmp_path), tmp_path / "ck.h5"
    assert "checkpoint_every" not in yaml.safe_load(scene.read_text())["packing"]
    # 200 s per read: the start reads 0 and step s reads 200 s; with the default interval of 300 s a checkpoint is
    # due at the first step read >= 300 s after the last one: step 2 (400 s), then step 4 (800 s), ...
    # (raising=False: an engine without the clock runs on, and the test fails on what it checks, not on the patch)
    monkeypatch.setattr(engine, "_checkpoint_clock", _fake_clock(200.0), raising=False)
    saved = _record_saves(monkeypatch, die_at=4)
    # the simulated kill is a KeyboardInterrupt, which the command reports in one line with exit code 130
    assert cli_main(["pack", str(scene), "-o", str(tmp_path / "packing.h5"), "--checkpoint", str(ck)]) == 130
    assert saved == [2, 4]
    assert Settings().checkpoint_every_s == 300.0  # the default the steps above follow from
    with h5py.File(ck, "r") as f:
        assert f.attrs["step"] == 4 and f.attrs["stage"] == 0
    assert not (tmp_path / "packing.h5").exists()  # a killed run leaves no result


def test_a_run_killed_after_a_wall_time_checkpoint_resumes_to_the_same_packing(tmp_path, monkeypatch):
    scene, ck = _scene(tmp_path), tmp_path / "ck.h5"
    ref_out, out = tmp_path / "ref.h5", tmp_path / "packing.h5"
    assert cli_main(["pack", str(scene), "-o", str(ref_out)]) == 0
    monkeypatch.setattr(engine, "_checkpoint_clock", _fake_clock(1e6))  # 1e6 s per step: every step is due
    _record_saves(monkeypatch, die_at=37)
    args = ["pack", str(scene), "-o", str(out), "--checkpoint", str(ck)]
    assert cli_main(args) == 130  # the simulated kill (a KeyboardInterrupt), reported as Ctrl-C is
    monkeypatch.undo()
    assert cli_main([*args, "--resume"]) == 0
    assert not ck.exists()  # a complete run deletes its checkpoint
    ref, got = _read(ref_out), _read(out)
    for key in SPHERE_KEYS:
        np.testing.assert_array_equal(got["arrays"][key], ref["arrays"][key], err_msg=key)  # bit for bit
    assert sorted(got["history"]) == sorted(ref["history"])
    for key in ref["history"]:
        np.testing.assert_array_equal(got["history"][key], ref["history"][key], err_msg=key)
    np.testing.assert_array_equal(got["attrs"]["stage_steps"], ref["attrs"]["stage_steps"])
    assert got["attrs"]["scene_hash"] == ref["attrs"]["scene_hash"]


def _converging(**extra) -> Settings:
    """150 spheres of one type that converge before the step limit (freezing, stochastic forces, adaptive radii)."""
    stage = {
        "name": "one",
        "insert": ["a"],
        "steps": 600,
        "dt": 0.25,
        "k": {"a": 400},
        "damping": {"a": 4},
        "freezing": {"lock_step": 10},
        "stochastic_forces": {"step_size": 0.05},
        "adaptive_radii": {"types": ["a"], "trigger": 0.2, "rate": 0.01, "from_step": 20, "to_step": 550},
    }
    radius = {"dist": "exponential", "min_um": 40, "max_um": 80, "alpha_per_um": 0.05}
    return Settings.model_validate(
        {"types": [{"name": "a", "count": 150, "radius_um": radius}], "stages": [stage], **extra}
    )


@pytest.fixture(scope="module")
def converged_reference():
    ref = pack_spheres(_converging(), BOX, True, seed=3)
    assert ref.stage_converged == [True] and 30 < ref.stage_steps[0] < 600
    return ref


@pytest.mark.parametrize("kill", ["first", "middle", "last"])
def test_resume_from_any_checkpoint_ends_where_the_uninterrupted_run_ends(
    tmp_path, monkeypatch, converged_reference, kill
):
    # a checkpoint can fall on any step (by wall time it does), so every step must resume exactly; "last" is the
    # last one written. Before, a checkpoint was also written at the step that found convergence, and a resume from
    # it ran one step more (stage_steps and the history one longer than the uninterrupted run's)
    ref, ck = converged_reference, tmp_path / "ck.h5"
    settings = _converging(checkpoint_every=1)  # a checkpoint after every step but the converging one
    saved = _record_saves(monkeypatch)
    pack_spheres(settings, BOX, True, seed=3, checkpoint_path=ck)
    die_at = {"first": saved[0], "middle": saved[len(saved) // 2], "last": saved[-1]}[kill]
    _record_saves(monkeypatch, die_at=die_at)
    with pytest.raises(KeyboardInterrupt):
        pack_spheres(settings, BOX, True, seed=3, checkpoint_path=ck)
    monkeypatch.undo()
    resumed = pack_spheres(settings, BOX, True, seed=3, checkpoint_path=ck, resume=True)
    assert resumed.stage_steps == ref.stage_steps and resumed.stage_converged == ref.stage_converged
    for key in SPHERE_KEYS:
        np.testing.assert_array_equal(getattr(resumed, key), getattr(ref, key), err_msg=key)  # bit for bit
    for key in set(ref.history) - set(HISTORY_TIMING):
        np.testing.assert_array_equal(resumed.history[key], ref.history[key], err_msg=key)


def test_checkpoint_intervals_change_neither_the_packing_nor_its_result_hash(tmp_path):
    # the result hash is the packing's provenance (voxelize and the rest include it in theirs); before, every key of
    # `packing:` entered it, run control included, so a new checkpoint interval changed the hash of an equal packing
    runs = {
        "default": {},
        "by wall time": {"checkpoint_every_s": 0.5},
        "by steps": {"checkpoint_every": 3, "checkpoint_every_s": 0.0},
        "watched": {"progress_every_s": 1.0, "parallel_min_spheres": 10**6},
        "other packing": {"cutoff": 1.25},  # the control: a setting the packing depends on
    }
    results = {}
    for i, (name, packing) in enumerate(runs.items()):
        out = tmp_path / f"{i}.h5"
        assert cli_main(["pack", str(_scene(tmp_path, f"s{i}.yaml", **packing)), "-o", str(out)]) == 0
        results[name] = _read(out)
    hashes = {name: r["attrs"]["scene_hash"] for name, r in results.items()}
    assert len(set(hashes.values())) == 2 and hashes["other packing"] != hashes["default"], hashes
    for name in ("by wall time", "by steps", "watched"):
        for key in SPHERE_KEYS:
            np.testing.assert_array_equal(results[name]["arrays"][key], results["default"]["arrays"][key])
    assert not np.array_equal(
        results["other packing"]["arrays"]["centres_um"], results["default"]["arrays"]["centres_um"]
    )


def test_no_interval_at_all_says_that_nothing_is_saved(tmp_path, capsys):
    scene, ck = _scene(tmp_path, checkpoint_every=0, checkpoint_every_s=0.0), tmp_path / "ck.h5"
    assert cli_main(["pack", str(scene), "-o", str(tmp_path / "p.h5"), "--checkpoint", str(ck)]) == 0
    assert "both 0: no checkpoint is written" in capsys.readouterr().err
    assert not ck.exists()
