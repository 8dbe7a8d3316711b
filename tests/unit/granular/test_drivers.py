"""Drivers and sources against closed forms: the force-controlled piston (App. B.1.5.1) comes to rest where the
grains push back with its force, the global size change s(t) (Eqs. 2.30-2.32, B.1) scales a grain about its
centroid at constant mass, the shrinking line source (§4.2.1) and the point source (§4.2.2) place their grains
where they are told."""

import math

import numpy as np
import pytest
from naive_granular import floor, simulation, square
from scipy import stats

from porepipe.granular._kernels import _size_scale

A = 0.01  # square edge, m
E = 1e7
F = 10.0  # piston force, N (2-D: per unit depth)


def _polygon_area(v):
    return 0.5 * float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))


def test_size_scale_is_eq_b1():
    hp = np.array([0.05, 10.0, 8.0, 0.0, 0.05])
    for t in (0.0, 0.013, 0.031, 0.05, 0.2):
        tt = min(t, 0.05)
        expect = 1 + 0.05 * (0.5 - 0.5 * math.tanh(8 * math.cos(2 * math.pi * 10 * tt)))
        assert _size_scale(hp, t) == pytest.approx(expect, rel=1e-15)


@pytest.mark.slow
def test_piston_settles_where_the_grain_pushes_back_and_follows_its_growth():
    # a square (g = 0) between the floor (top y = 0) and a piston slab pressed down with F. At rest both contacts
    # carry F = E A_c / l with l = r = sqrt(area/pi) (wall: r = inf): overlap A_c = F r / E, depth h = A_c / a,
    # so the piston sits 2h below the square's top. The grain then grows by s(t) (a = 5 %, S = 8, f = 10 Hz,
    # t clamped to [0.1, 0.15] s: s = 1 + 5.6e-9 until 0.1 s, then up to 1.05 at 0.15 s, held): its top rises by
    # (s - 1) a; l and the face both scale by s, so h is unchanged and the overlap area A_c = F s r / E grows by s.
    # Tolerances: 1e-4 of 2h = 1.1 um on the piston (residual ringing after 50 ms of contact damping at a decay
    # rate ~ 4000/s), 1e-6 relative on areas and forces.
    piston = {
        "name": "piston",
        "vertices_m": [(-0.05, A), (0.05, A), (0.05, A + 0.01), (-0.05, A + 0.01)],
        "piston": {"force_N": F, "mass_kg": 0.1, "v_max_m_s": 0.5},
    }
    sim = simulation(
        [{"vertices_m": square(A), "position_m": (0.0, 0.5 * A)}],
        [floor(), piston],
        material={"young_N_m": E, "density_kg_m2": 1000.0, "damping": 0.5, "application_point": "centroid"},
        size_change={"amplitude": 0.05, "frequency_hz": 10.0, "slope": 8.0, "time_s": (0.1, 0.15)},
        duration_s=0.2,
    )
    assert sim.effects["piston"] and sim.effects["size_change"]
    r = math.sqrt(A * A / math.pi)
    h = F * r / (E * A)
    w = sim.n_mob + 1
    for t_end, s_expect in (
        (0.1, 1 + 0.05 * (0.5 - 0.5 * math.tanh(8.0))),
        (0.2, 1 + 0.05 * (0.5 + 0.5 * math.tanh(8.0))),
    ):
        sim.advance(round(t_end / sim.dt) - sim.step)
        s = sim.size_scale()
        assert s == pytest.approx(s_expect, rel=1e-14)
        assert sim.piston[w, 6] == pytest.approx(2 * h - (s - 1) * A, abs=1e-4 * 2 * h)
        c = sim.contacts()
        assert np.abs(c["fn_N"]) == pytest.approx([F, F], rel=1e-6)
        assert c["area_m2"] == pytest.approx([F * s * r / E] * 2, rel=1e-6)
    # the grain: corners scaled by s about the centroid (area s² a²), mass unchanged
    assert _polygon_area(sim.wv[0, :4]) == pytest.approx(s * s * A * A, rel=1e-12)
    assert sim.mass[0] == pytest.approx(1000.0 * A * A, rel=1e-12)
    assert abs(sim.position[0, 0]) < 1e-9


def test_piston_speed_is_capped():
    # pressing into nothing (no grain below for 1 m): m s'' = F until |s'| reaches v_max, then s' = v_max
    piston = {
        "name": "piston",
        "vertices_m": [(-0.05, 1.0), (0.05, 1.0), (0.05, 1.01), (-0.05, 1.01)],
        "piston": {"force_N": 1.0, "mass_kg": 0.5, "v_max_m_s": 0.01},
    }
    sim = simulation(
        [{"vertices_m": square(A), "position_m": (0.0, 0.5 * A)}],
        [floor(), piston],
        dt_s=1e-4,
        material={"young_N_m": E, "density_kg_m2": 1000.0},
    )
    w = sim.n_mob + 1
    sim.advance(20)  # 2 ms: v = F t / m = 4 mm/s, s = F t^2 / 2m (symplectic Euler: + F dt t / 2m)
    t = sim.time_s
    assert sim.piston[w, 7] == pytest.approx(2.0 * t, rel=1e-12)
    assert sim.piston[w, 6] == pytest.approx(t * t + 1e-4 * t, rel=1e-12)
    sim.advance(80)  # capped at 10 mm/s from t = 5 ms on
    assert sim.piston[w, 7] == 0.01
    assert sim.G[0, w, 1] == pytest.approx(1.005 - sim.piston[w, 6], rel=1e-14)


def test_line_source_shrinks_and_point_source_is_a_point():
    # shrinking line source: the k-th grain (time t_k) is placed uniformly on x0 ± w(t_k)/2, w(t) = w0 (1 - t/T);
    # u_k = (x_k - x0)/w(t_k) + 1/2 must be U(0, 1): Kolmogorov-Smirnov p > 1e-3 (a correct source fails 1 in
    # 1000 seeds; the fixed seed passes). Point source (width 0): every grain exactly at x0.
    line = {
        "x_m": 0.5,
        "y_m": 0.3,
        "width_m": 0.4,
        "every_s": 0.001,
        "to_s": 0.4,
        "shrink": True,
        "shape": {"size_m": (0.002, 0.002), "corners": 6},
    }
    point = {**line, "x_m": 0.9, "width_m": 0.0, "shrink": False, "to_s": 0.01}
    sim = simulation([], [floor()], dt_s=1e-5, drop_sources=[line, point])
    k = np.nonzero(sim.drop == 0)[0]
    t = sim.insert_s[k]
    width = 0.4 * (1 - t / 0.4)
    x = sim.G[0, k, 0]
    assert np.all(np.abs(x - 0.5) <= 0.5 * width + 1e-15)
    u = (x[width > 0] - 0.5) / width[width > 0] + 0.5
    assert len(u) == 400
    assert stats.kstest(u, "uniform").pvalue > 1e-3
    np.testing.assert_array_equal(sim.G[0, np.nonzero(sim.drop == 1)[0], 0], 0.9)


def test_rising_source_follows_a_fill():
    """rise_m_s: the k-th grain (time t_k) is inserted at y + rise (t_k - from_s); a fixed source stays at y."""
    src = {
        "x_m": 0.5,
        "y_m": 0.02,
        "width_m": 0.0,
        "every_s": 0.01,
        "from_s": 0.05,
        "to_s": 0.15,
        "rise_m_s": 0.3,
        "shape": {"size_m": (0.002, 0.002), "corners": 6},
    }
    sim = simulation([], [floor()], dt_s=1e-5, drop_sources=[src, {**src, "x_m": 0.9, "rise_m_s": 0.0}])
    k = np.nonzero(sim.drop == 0)[0]
    np.testing.assert_allclose(sim.G[0, k, 1], 0.02 + 0.3 * (sim.insert_s[k] - 0.05), rtol=0, atol=1e-15)
    assert len(k) == 11
    np.testing.assert_array_equal(sim.G[0, np.nonzero(sim.drop == 1)[0], 1], 0.02)


def test_bad_driver_inputs_name_the_problem():
    from pydantic import ValidationError

    from porepipe._shared.errors import PorepipeError

    slab = {"name": "lid", "vertices_m": [(0, 1), (1, 1), (1, 2), (0, 2)]}
    with pytest.raises(ValidationError, match="cannot be a piston and vibrate"):
        simulation([], [{**slab, "piston": {"force_N": 1.0, "mass_kg": 1.0}, "vibration": {}}])
    with pytest.raises(ValidationError, match="mass_kg"):
        simulation([], [{**slab, "piston": {"force_N": 1.0, "mass_kg": 0.0}}])
    grain = [{"vertices_m": square(A), "position_m": (0.5, 0.5)}]
    with pytest.raises(PorepipeError, match="t2 must not precede t1"):
        simulation(grain, size_change={"time_s": (1.0, 0.5)})
