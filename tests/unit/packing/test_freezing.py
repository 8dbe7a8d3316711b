"""Lock-step freezing (§5.4.4): "for s > s_lock, converged spheres are frozen".

A converged pair (0 < σ ≤ σ_max) still feels the LJ attraction towards dx_eq, so it moves in every step in which it is
not frozen; an isolated sphere (σ < 0, never converged, no force) keeps the system from converging. The step in
which the pair stops moving is therefore the first step with freezing in effect: s_lock + 1 by the text.
"""

import numpy as np
import pytest

from porepipe.packing import Settings, pack_spheres

LOCK = 3
BOX = [100.0, 100.0, 100.0]
# pair: r = 10 at distance 19 (dx_eq = 17 for σ_max = 0.3: converged, attracted); lone sphere far away
SPHERES = [(30.0, 50.0, 50.0, 10.0), (49.0, 50.0, 50.0, 10.0), (80.0, 80.0, 80.0, 5.0)]


def _pair_after(steps, tmp_path, lock_step=LOCK):
    xyzr = tmp_path / "spheres.xyzr"
    np.savetxt(xyzr, np.array(SPHERES), fmt="%.17g")
    stage = {
        "name": "lock",
        "insert_file": {"path": str(xyzr), "type": "a"},
        "steps": steps,
        "dt": 0.05,
        "k": {"a": 400},
        "damping": {"a": 4},
    }
    if lock_step is not None:
        stage["freezing"] = {"lock_step": lock_step}
    settings = Settings.model_validate(
        {
            "types": [
                {"name": "a", "count": 0, "radius_um": {"min_um": 4, "max_um": 12}, "max_overlap": 0.3}
            ],
            "stages": [stage],
        }
    )
    p = pack_spheres(settings, BOX, True)
    pair = np.argsort(p.centres_um[:, 0])[:2]  # the two spheres at x = 30 and 49
    return p.centres_um[pair].copy(), p


def test_converged_pair_moves_until_the_lock_step_and_not_after(tmp_path):
    before = {s: _pair_after(s, tmp_path)[0] for s in range(LOCK - 1, LOCK + 3)}
    # steps up to s_lock move the attracted pair (their distance shrinks towards dx_eq = 17)
    assert np.abs(before[LOCK] - before[LOCK - 1]).max() > 1e-6
    # from step s_lock + 1 on the pair is frozen: exactly no motion (the kernel skips frozen spheres)
    np.testing.assert_array_equal(before[LOCK + 1], before[LOCK])
    np.testing.assert_array_equal(before[LOCK + 2], before[LOCK])


def test_without_freezing_the_pair_keeps_moving(tmp_path):
    a = _pair_after(LOCK, tmp_path, lock_step=None)[0]
    b = _pair_after(LOCK + 1, tmp_path, lock_step=None)[0]
    assert np.abs(b - a).max() > 1e-6


@pytest.mark.parametrize("lock_step", [0, 1])
def test_history_marks_freezing_from_the_step_after_lock_step(tmp_path, lock_step):
    _, p = _pair_after(4, tmp_path, lock_step=lock_step)
    steps = np.asarray(p.history["step"])
    effects = np.asarray(p.history["effects"])
    frozen_steps = steps[effects != 0]
    assert frozen_steps.min() == lock_step + 1
