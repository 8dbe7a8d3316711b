"""Time integration (App. F): Gear 6-value predictor-corrector with the Tab. F.1 coefficients and velocity
Verlet, against exact solutions; the time-step rule of Eq. 2.9."""

import math

import numpy as np
import pytest
from naive_granular import floor, simulation, square

from porepipe.granular import time_step_rule
from porepipe.granular._kernels import GEAR_C


def test_tab_f1_coefficients():
    # p = 2, six values (Allen & Tildesley Tab. E.1 / Schinner Tab. F.1): 3/20, 251/360, 1, 11/18, 1/6, 1/60
    assert GEAR_C == (3 / 20, 251 / 360, 1.0, 11 / 18, 1 / 6, 1 / 60)


@pytest.mark.parametrize("integrator", ["gear", "verlet"])
def test_free_fall_and_spin_are_exact(integrator):
    # constant acceleration: both schemes reproduce x0 + v0 t + g t^2/2 and phi0 + w t to round-off
    g = (0.3, -9.81)
    sim = simulation(
        [
            {
                "vertices_m": square(0.01),
                "position_m": (0.1, 2.0),
                "velocity_m_s": (0.5, 1.0),
                "angular_velocity_rad_s": 3.0,
            }
        ],
        gravity_m_s2=g,
        dt_s=1e-4,
        integrator=integrator,
    )
    sim.advance(2000)
    t = 0.2
    expect = [0.1 + 0.5 * t + 0.5 * g[0] * t * t, 2.0 + t + 0.5 * g[1] * t * t, 3.0 * t]
    np.testing.assert_allclose(sim.position[0], expect, rtol=1e-11)
    np.testing.assert_allclose(sim.velocity[0], [0.5 + g[0] * t, 1.0 + g[1] * t, 3.0], rtol=1e-11)


@pytest.mark.parametrize("integrator", ["gear", "verlet"])
def test_elastic_flat_bounce_is_a_half_oscillation(integrator):
    # a square falling flat on the floor (g = 0, gamma = mu = 0) feels F = (E a / l) h: contact time pi sqrt(m/k),
    # rebound speed = impact speed. dt = T/100: tolerance 1.5 % on the time (one step + start/end detection)
    # and 0.5 % on the speed (Gear/Verlet energy error over one half-oscillation at this dt)
    E, a, rho, v0 = 1e5, 0.01, 5000.0, 0.05
    m = rho * a * a
    k = E * a / math.sqrt(a * a / math.pi)
    period = math.pi * math.sqrt(m / k)
    dt = period / 100
    sim = simulation(
        [{"vertices_m": square(a), "position_m": (0.0, 0.5 * a + 2 * v0 * dt), "velocity_m_s": (0, -v0)}],
        [floor()],
        dt_s=dt,
        integrator=integrator,
        material={"young_N_m": E, "density_kg_m2": rho, "damping": 0.0, "friction": 0.0},
    )
    touching = []
    for _ in range(300):
        sim.advance(1)
        touching.append(len(sim.contacts()["i"]) > 0)
    duration = sum(touching) * dt
    assert duration == pytest.approx(period, rel=0.015)
    assert sim.velocity[0, 1] == pytest.approx(v0, rel=0.005)
    assert abs(sim.velocity[0, 0]) < 1e-12 and abs(sim.velocity[0, 2]) < 1e-9


def test_time_step_rule():
    assert time_step_rule(1.0, (math.pi / 10) ** 2) == pytest.approx(1.0)
    sim = simulation(
        [
            {"vertices_m": square(0.01), "position_m": (0, 0)},
            {
                "vertices_m": [(-0.02, -0.001), (0.02, -0.001), (0.02, 0.001), (-0.02, 0.001)],
                "position_m": (1, 1),
            },
        ],
        material={"young_N_m": 1e7, "density_kg_m2": 5000.0},
    )
    # the needle (4 cm x 2 mm) is lighter than the square, and m = pi r_in^2 rho with r_in = 1 mm is lighter still
    assert sim.dt_rule == pytest.approx(0.1 * math.pi * math.sqrt(math.pi * 1e-6 * 5000 / 1e7), rel=1e-12)
    # damping limit: c = gamma sqrt(2 E/m) 2 L/r (a pair of such grains, L = longest edge, r = sqrt(area/pi)) is
    # largest for the needle (L = 4 cm, m = 0.4 kg, r = 5.05 mm): dt = 0.15/c = 2.7 us < dt_rule/2 = 6.2 us
    m, r = 5000 * 0.04 * 0.002, math.sqrt(0.04 * 0.002 / math.pi)
    c = 0.5 * math.sqrt(2 * 1e7 / m) * 2 * 0.04 / r
    assert sim.dt_damping == pytest.approx(0.15 / c, rel=1e-12)
    assert sim.dt == pytest.approx(min(0.5 * sim.dt_rule, sim.dt_damping), rel=1e-15) == sim.dt_damping
