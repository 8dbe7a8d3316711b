"""Checkpoints of the packing: a run resumed from any of its checkpoints ends bit for bit where an uninterrupted one
ends (stage steps and history included)."""

from __future__ import annotations

import numpy as np
import pytest

import porepipe.packing._api as engine  # the name the engine calls: save_checkpoint
from porepipe.packing import Settings, pack_spheres
from porepipe.packing._api import HISTORY_TIMING

SPHERE_KEYS = ("centres_um", "radii_um", "types", "max_overlap", "converged")
BOX = [600.0, 600.0, 600.0]


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
