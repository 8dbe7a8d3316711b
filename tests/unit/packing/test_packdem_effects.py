"""The optional PackDEM effects of §5.4, each switched on and off on hand-built sphere sets.

Each test checks what the effect must change against an expectation derived by hand from the rule (the kernel's
integrator, §5.4.2 stochastic forces, §5.4.3 radius protocol, PackDEM `gww` pair switches, the multiple-time-step
rebuild interval s_mts) and that everything it must not touch comes out bit-identical to the run without it.
Spheres are given by files (PackDEM ``init = file``), so nothing random enters but the effect under test.
"""

import numpy as np
import pytest
from scipy import stats

from porepipe.packing import Settings, pack_spheres
from porepipe.packing._api import EFFECT_BITS
from porepipe.packing._settings import Effect

BOX = [200.0, 200.0, 200.0]
SIGMA_MAX = 0.3
# sigma = (r_i + r_j - d) / min(r_i, r_j): the r = 10 pair at distance 19 has sigma = 0.1 (converged, and attracted
# towards dx_eq = 17); the pair at distance 12 has sigma = 0.8 > sigma_max (over-overlapping); LONE has no partner
CONVERGED_PAIR = [(30.0, 30.0, 30.0, 10.0), (49.0, 30.0, 30.0, 10.0)]
DEEP_PAIR = [(30.0, 120.0, 30.0, 10.0), (42.0, 120.0, 30.0, 10.0)]
LONE = [(150.0, 150.0, 150.0, 8.0)]


def _settings(stages, types=("a",), rebuild_interval=0, r_range=(4.0, 12.0)):
    return Settings.model_validate(
        {
            "types": [
                {
                    "name": t,
                    "count": 0,
                    "radius_um": {"min_um": r_range[0], "max_um": r_range[1]},
                    "max_overlap": SIGMA_MAX,
                }
                for t in types
            ],
            "stages": stages,
            "rebuild_interval": rebuild_interval,
        }
    )


def _stage(path, steps, typ="a", k=400.0, **extra):
    return {
        "name": f"s{typ}",
        "insert_file": {"path": str(path), "type": typ},
        "steps": steps,
        "dt": 0.05,
        "k": {typ: k},
        "damping": {typ: 4},
        **extra,
    }


def _file(tmp_path, spheres, name="spheres.xyzr"):
    path = tmp_path / name
    np.savetxt(path, np.array(spheres, dtype=float), fmt="%.17g")
    return path


def _run(tmp_path, spheres, steps, **extra):
    return pack_spheres(_settings([_stage(_file(tmp_path, spheres), steps, **extra)]), BOX, True)


# -- stochastic forces (§5.4.2) ---------------------------------------------------------------------------------------
def _lattice(n_side=8, spacing=25.0, r=5.0):
    g = (np.arange(n_side) + 0.5) * spacing
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    return [(a, b, c, r) for a, b, c in zip(x.ravel(), y.ravel(), z.ravel())]


def test_stochastic_first_step_is_uniform_in_the_symmetric_cube(tmp_path):
    """512 isolated spheres, one step from rest: f = f_max (2U - 1) per axis with f_max = 2 m h r / dt², so the
    integrator moves x by f dt²/(2m) (1 + C-/C+) = h r (1 + C-/C+) (2U - 1): uniform on a symmetric interval.
    Kolmogorov-Smirnov against U(-1, 1) at p > 1e-3 (fixed seed: deterministic); the printed [0, f_max]³ would give
    p ~ 0 and a mean of +0.5."""
    spheres = _lattice()
    h, dt, xi = 0.1, 0.05, 4.0
    p = _run(tmp_path, spheres, 1, stochastic_forces={"step_size": h})
    cm, cp = 1 - 0.5 * dt * xi, 1 + 0.5 * dt * xi
    d = (p.centres_um - np.array(spheres)[:, :3]) / (h * 5.0 * (1 + cm / cp))
    assert np.abs(d).max() <= 1.0 + 1e-12
    assert stats.kstest(d.ravel(), stats.uniform(-1, 2).cdf).pvalue > 1e-3
    assert abs(d.mean()) < 4 * np.sqrt(1 / 3) / np.sqrt(d.size)  # 4 standard errors of U(-1, 1)'s mean


def test_stochastic_forces_move_only_force_free_unconverged_spheres(tmp_path):
    """A converged pair and an over-overlapping pair (both feel pair forces) move bit-identically with and
    without stochastic forces; the isolated sphere stays put without them and moves with them."""
    spheres = CONVERGED_PAIR + DEEP_PAIR + LONE
    off = _run(tmp_path, spheres, 3)
    on = _run(tmp_path, spheres, 3, stochastic_forces={"step_size": 0.1})
    np.testing.assert_array_equal(on.centres_um[:4], off.centres_um[:4])
    np.testing.assert_array_equal(off.centres_um[4], LONE[0][:3])
    assert np.abs(on.centres_um[4] - LONE[0][:3]).min() > 0.0


def test_stochastic_forces_leave_unlisted_types_alone(tmp_path):
    """`types: [b]`: an isolated sphere of type a does not move; one of type b does."""
    a = _file(tmp_path, LONE, "a.xyzr")
    b = _file(tmp_path, [(50.0, 150.0, 150.0, 8.0)], "b.xyzr")
    stages = [
        _stage(a, 1, "a", k=0.0),
        {**_stage(b, 2, "b"), "k": {"a": 400, "b": 400}, "damping": {"a": 4, "b": 4}},
    ]
    stages[1]["stochastic_forces"] = {"step_size": 0.1, "types": ["b"]}
    p = pack_spheres(_settings(stages, types=("a", "b")), BOX, True)
    np.testing.assert_array_equal(p.centres_um[0], LONE[0][:3])
    assert np.abs(p.centres_um[1] - [50.0, 150.0, 150.0]).min() > 0.0


# -- adaptive radii (§5.4.3) ------------------------------------------------------------------------------------------
def _adapt(tmp_path, steps=3, **radii):
    """k = 0: nobody moves, so the overlaps, and with them the converged count, stay as built."""
    rule = {"types": ["a"], "trigger": 0.2, "rate": 0.05, "from_step": 0, "to_step": 100, "quiet_steps": 0}
    spheres = CONVERGED_PAIR + DEEP_PAIR + LONE
    return _run(tmp_path, spheres, steps, k=0.0, adaptive_radii={**rule, **radii})


def test_radius_rule_grows_isolated_shrinks_over_overlapping_keeps_converged(tmp_path):
    """Hand-derived: step 1 sees N_c = 2 new converged spheres out of 2 (growth 1 >= t_rc: no change); step 2 sees
    none new (growth 0 < t_rc): one change of δr = rate (r_max - r_min) = 0.4 µm; step 3 is the last (s < steps -
    s_nrc fails). So r changes exactly once: isolated +0.4, over-overlapping -0.4, converged pair unchanged."""
    p = _adapt(tmp_path)
    r0 = np.array([s[3] for s in CONVERGED_PAIR + DEEP_PAIR + LONE])
    dr = 0.05 * (12.0 - 4.0)
    np.testing.assert_allclose(p.radii_um, r0 + np.array([0, 0, -dr, -dr, dr]), rtol=0, atol=1e-12)
    bit = EFFECT_BITS[Effect.adaptive_radii]
    assert [int(e) & bit != 0 for e in p.history["effects"]] == [False, True, False]
    np.testing.assert_array_equal(p.centres_um, np.array(CONVERGED_PAIR + DEEP_PAIR + LONE)[:, :3])


@pytest.mark.parametrize(
    ("change", "times"),
    [
        ({"trigger": 1.5}, 2),  # growth 1 at step 1 is below t_rc = 1.5: steps 1 and 2 change
        ({"from_step": 2}, 0),  # window (2, 100) is exclusive: step 2 is outside
        ({"to_step": 2}, 0),  # window (0, 2): step 1 is inside but fails the trigger, step 2 is outside
        ({"quiet_steps": 1}, 0),  # s < 3 - 1: only step 1 qualifies, and it fails the trigger
    ],
)
def test_radius_rule_trigger_window_and_quiet_steps(tmp_path, change, times):
    p = _adapt(tmp_path, **change)
    np.testing.assert_allclose(p.radii_um[4] - LONE[0][3], times * 0.05 * 8.0, rtol=0, atol=1e-12)


def test_radius_rule_respects_the_type_bounds(tmp_path):
    """An isolated sphere 0.1 µm below r_max grows to r_max exactly (not r_max + 0.3)."""
    spheres = CONVERGED_PAIR + [(150.0, 150.0, 150.0, 11.9)]
    rule = {"types": ["a"], "trigger": 0.2, "rate": 0.05, "from_step": 0, "to_step": 100, "quiet_steps": 0}
    p = _run(tmp_path, spheres, 3, k=0.0, adaptive_radii=rule)
    assert p.radii_um[2] == 12.0


# -- gww: type pairs switched off --------------------------------------------------------------------------------------
def test_switched_off_pair_neither_pushes_nor_counts(tmp_path):
    """An a-b pair overlapping by sigma = 0.8 with `interactions_off: [[a, b]]` stays where it is and has no
    partner (max sigma = -inf); the a-a pair in the same run moves exactly as in a run without the switch."""
    a = _file(tmp_path, CONVERGED_PAIR + [DEEP_PAIR[0]], "a.xyzr")
    b = _file(tmp_path, [DEEP_PAIR[1]], "b.xyzr")

    def run(off):
        stages = [
            _stage(a, 1, "a", k=0.0),
            {**_stage(b, 3, "b"), "k": {"a": 400, "b": 400}, "damping": {"a": 4, "b": 4}},
        ]
        if off:
            stages[1]["interactions_off"] = [["a", "b"]]
        return pack_spheres(_settings(stages, types=("a", "b")), BOX, True)

    on, off = run(False), run(True)
    np.testing.assert_array_equal(off.centres_um[2:], np.array(DEEP_PAIR)[:, :3])
    assert np.all(off.max_overlap[2:] == -np.inf)
    assert np.abs(on.centres_um[2:] - np.array(DEEP_PAIR)[:, :3]).max() > 1e-3  # the switch is what held them
    np.testing.assert_array_equal(off.centres_um[:2], on.centres_um[:2])


# -- neighbour-list rebuild interval (s_mts) ---------------------------------------------------------------------------
def _mover(tmp_path, interval, steps=10):
    spheres = CONVERGED_PAIR + DEEP_PAIR + LONE
    s = _settings([_stage(_file(tmp_path, spheres), steps)], rebuild_interval=interval)
    return pack_spheres(s, BOX, True)


@pytest.mark.parametrize(
    ("interval", "expected"), [(1, list(range(1, 11))), (3, [1, 4, 7, 10]), (4, [1, 5, 9])]
)
def test_rebuild_interval_rebuilds_every_n_steps(tmp_path, interval, expected):
    """s_mts = n: the list built before step 1 (a rebuild: the spheres were just inserted) serves n steps, so
    rebuilds happen before steps 1, 1 + n, 1 + 2n, ..."""
    p = _mover(tmp_path, interval)
    steps = np.asarray(p.history["step"])
    assert steps[np.asarray(p.history["rebuilt"]) == 1].tolist() == expected


def test_rebuild_interval_does_not_change_the_physics_when_no_partner_is_missed(tmp_path):
    """Every pair stays in the Verlet skin here, so rebuilding every step, every 4 steps or by the displacement
    criterion gives the same trajectory (to 1e-12 µm: a rebuild reorders spheres, which may reorder force sums)."""
    ref = _mover(tmp_path, 0)
    for interval in (1, 4):
        np.testing.assert_allclose(_mover(tmp_path, interval).centres_um, ref.centres_um, rtol=0, atol=1e-12)
