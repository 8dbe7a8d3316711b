"""Optional effects and sources against their closed forms: time-dependent gravity, a vibrating wall, a wall
surface velocity (conveyor), velocity-weakening friction (one compiled variant with all four), drop sources."""

import math

import numpy as np
import pytest
from naive_granular import floor, simulation, square

from porepipe.granular._kernels import _gravity_scale, _vibration

A = 0.01


def test_waveforms_and_gravity_schedules():
    w, f = 2e-3, 5.0
    t = 0.13
    assert _vibration(1, w, f, t)[0] == pytest.approx(
        w * 0.5 * (1 - math.cos(2 * math.pi * f * t)), rel=1e-14
    )
    assert _vibration(2, w, f, t)[0] == pytest.approx(w * ((t * f) % 1), rel=1e-14)
    assert _vibration(3, w, f, t)[0] == pytest.approx(w * math.sin(2 * math.pi * f * t) ** 30, rel=1e-12)
    a = (t * f) % 1
    assert _vibration(4, w, f, t)[0] == pytest.approx(2 * w * (a if a < 0.5 else 1 - a), rel=1e-14)
    # dA/dt by central differences (h = 1e-7 s: error ~ h^2 A''' ~ 1e-12 relative)
    for kind in (1, 3):
        h = 1e-7
        num = (_vibration(kind, w, f, t + h)[0] - _vibration(kind, w, f, t - h)[0]) / (2 * h)
        assert _vibration(kind, w, f, t)[1] == pytest.approx(num, rel=1e-6)
    gp = np.array([1, 9.81, 0.0, 1.0, 2.0, 1, 0])
    assert _gravity_scale(gp, 1.5) == pytest.approx(4.905)
    gp = np.array([2, 0.0, 1.0, 0.0, 1.0, 4, 0])  # 4 steps of 0.25
    assert [_gravity_scale(gp, t) for t in (0.1, 0.3, 0.6, 0.99, 1.5)] == pytest.approx(
        [0, 0.25, 0.5, 0.75, 1.0]
    )
    gp = np.array([3, 0.0, 1.0, 0.0, 1.0, 4, 1.0])  # ramp width 1 = LINEAR
    assert _gravity_scale(gp, 0.6) == pytest.approx(0.6)


@pytest.mark.slow
def test_effects_against_closed_forms():
    g0, g1, t_ramp = 9.81, 4.905, 0.1
    u_belt, w, f = 0.1, 1e-3, 5.0
    mu = 0.5
    belt = {**floor(top=0.0), "name": "belt", "surface_velocity_m_s": u_belt}
    shaker = {
        **floor(top=0.0),
        "name": "shaker",
        "offset_m": (10.0, 0.0),
        "vibration": {"waveform": "COSINUS", "amplitude_m": w, "frequency_hz": f},
    }
    sled = {**floor(top=0.0), "name": "sled", "offset_m": (20.0, 0.0)}
    parts = [
        {"vertices_m": square(A), "position_m": (0.0, 5.0)},  # free fall
        {"vertices_m": square(A), "position_m": (0.0, 0.5 * A)},  # on the belt
        {"vertices_m": square(A), "position_m": (10.0, 0.5 * A)},  # on the shaker
        {
            "vertices_m": square(A),
            "position_m": (20.0, 0.5 * A - 1e-6),
            "velocity_m_s": (10.0, 0.0),
        },  # sliding
    ]
    sim = simulation(
        parts,
        [belt, shaker, sled],
        dt_s=1e-5,
        gravity_m_s2=(0.0, -1.0),
        gravity={"kind": "LINEAR", "g1_m_s2": g0, "g2_m_s2": g1, "time_s": (0.0, t_ramp)},
        material={"young_N_m": 1e7, "density_kg_m2": 1000.0, "friction": mu, "velocity_weakening": True},
    )
    assert all(
        v for k, v in sim.effects.items() if k not in ("cohesion", "drag_springs", "piston", "size_change")
    )
    # velocity weakening on the first step: |F_t| = mu (|v_t| / 1 m/s)^(-1/10) F_el at v_t = 10 m/s
    sim.advance(1)
    c = sim.contacts()
    k = int(np.nonzero(c["i"] == 3)[0][0])
    el = 1e7 * c["area_m2"][k] / math.sqrt(A * A / math.pi)
    assert abs(c["ft_N"][k]) == pytest.approx(mu * 10.0**-0.1 * el, rel=1e-6)
    sim.advance(9999)
    t = sim.time_s
    # free fall under g(t) = g0 + (g1 - g0) t / T: v = -(g0 t + (g1 - g0) t^2 / 2T); Gear starts with r_3 = 0,
    # a transient of O(g' dt) in v: tolerance 1e-6 relative
    assert sim.velocity[0, 1] == pytest.approx(-(g0 * t + 0.5 * (g1 - g0) * t * t / t_ramp), rel=1e-6)
    # the belt drags the square along its surface (CCW boundary of the slab: -x on its top face) at u_belt
    assert sim.velocity[1, 0] == pytest.approx(-u_belt, rel=0.02)
    # the shaker moves by A(t) = W (1 - cos 2 pi f t)/2; the square rides on it (peak acceleration 0.5 m/s^2 < g)
    lift = w * 0.5 * (1 - math.cos(2 * math.pi * f * t))
    shaker_idx = sim.n_mob + 1
    assert sim.G[0, shaker_idx, 1] - sim.wall_base[shaker_idx, 1] == pytest.approx(lift, rel=1e-12)
    assert sim.position[2, 1] - 0.5 * A == pytest.approx(lift, abs=5e-5)


def test_drop_sources_abs_and_rel():
    src_abs = {
        "mode": "ABS",
        "x_m": 0.0,
        "y_m": 0.05,
        "width_m": 0.02,
        "every_s": 0.01,
        "to_s": 0.05,
        "velocity_m_s": (0.0, -1.0),
        "shape": {"size_m": (0.002, 0.002), "corners": 6},
    }
    src_rel = {
        "mode": "REL",
        "x_m": 0.3,
        "y_m": 0.02,
        "every_s": 0.02,
        "from_s": 0.01,
        "to_s": 0.03,
        "shape": {"size_m": (0.002, 0.002), "corners": 6},
    }
    sim = simulation(
        [{"vertices_m": square(A), "position_m": (0.3, 0.1)}],
        [floor()],
        dt_s=1e-5,
        drop_sources=[src_abs, src_rel],
    )
    assert sim.n_mob == 1 + 6 + 2 and sim.active[: sim.n_mob].sum() == 2  # the square and the t = 0 drop
    sim.advance(
        2001
    )  # just past t = 0.02: ABS drops at 0, .01, .02; REL at .01 (inserted before the step from t)
    assert sim.active[: sim.n_mob].sum() == 1 + 3 + 1
    ins = sim.insert_s
    abs_idx = np.nonzero(sim.drop == 0)[0]
    np.testing.assert_allclose(ins[abs_idx], [0, 0.01, 0.02, 0.03, 0.04, 0.05], atol=1e-12)
    assert np.all(
        np.abs(sim.G[0, abs_idx, 0]) <= 0.01
    )  # uniform in [x - w/2, x + w/2] (they fall straight down)
    rel = np.nonzero(sim.drop == 1)[0][0]
    # REL: inserted at the highest centroid in its window (the square at y = 0.1) plus y_m
    assert sim.G[0, rel, 1] == pytest.approx(0.1 + 0.02, abs=1e-9)
