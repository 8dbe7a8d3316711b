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


def _spectral_radius(w, c, gear=True):
    """Linear stability of one step for h'' = -omega² h - c h', as the kernel discretises it: forces at the
    predicted h, the damping from the backward difference of predicted overlaps; w = omega dt, c = c dt."""
    n = 6 if gear else 3
    pred = np.array([[math.comb(j, i) if j >= i else 0 for j in range(n)] for i in range(n)], float)
    if not gear:
        pred[1, 2] = 1.0  # velocity Verlet: r0 += r1 + r2, r1 += r2 (half-step velocity)
        pred[0] = [1.0, 1.0, 1.0]
    m = np.zeros((n + 1, n + 1))
    p = np.zeros((n, n + 1))
    p[:, :n] = pred
    acc = 0.5 * (-w * w * p[0] - c * (p[0] - np.eye(n + 1)[n]))  # dt²/2 h''
    if gear:
        m[:n] = p + np.outer(GEAR_C, acc - p[2])
    else:
        m[0] = p[0]
        m[1] = p[1] + acc
        m[2] = acc
    m[n] = p[0]
    return float(np.max(np.abs(np.linalg.eigvals(m))))


def test_damping_stability_bound_of_the_default_dt():
    # below the bound the default dt uses (c dt = 0.15 Gear, 0.4 Verlet) every damping ratio is stable, for the
    # omega dt that the rule allows at those c dt (<= 0.6); past it (Gear c dt = 0.4, damping ratio 1) it is not
    for ratio2 in (0.25, 0.5, 1.0, 2.0, 4.0, 8.0):
        assert _spectral_radius(min(0.15 / ratio2, 0.6), 0.15) < 0.999
        assert _spectral_radius(min(0.4 / ratio2, 1.2), 0.4, gear=False) < 0.999
    assert _spectral_radius(0.2, 0.4) > 1.05


@pytest.mark.parametrize("c_dt", [0.25, 0.40])
def test_kernel_damping_is_stable_where_the_linear_analysis_says(c_dt):
    # a 20 x 5 mm plate lying flat on the floor under g: overlap A = L h (exactly linear), stiffness E L/l and
    # damping rate c = gamma sqrt(E/m) L/l; gamma sets c/omega = 2 (overdamped). The analysis puts the Gear bound
    # at c dt = 0.34 for this ratio: at 0.25 a 0.5 nm kick decays (to < 1e-3 in 1500 steps), at 0.40 it grows
    # (spectral radius 1.08: > 3x in the steps the analysis needs for 30x of its growing mode, measured 9x, still
    # linear: < half the 28 nm static overlap)
    L, m, E, rho = 0.02, 0.1, 1e7, 1000.0
    r = math.sqrt(L * 0.005 / math.pi)
    omega = math.sqrt(E * L / (r * m))
    gamma = 2.0 / math.sqrt(L / r)
    dt = c_dt / (2.0 * omega)
    h_eq = m * 9.81 * r / (E * L)
    v0 = 1e-5
    sim = simulation(
        [
            {
                "vertices_m": [(-0.01, -0.0025), (0.01, -0.0025), (0.01, 0.0025), (-0.01, 0.0025)],
                "position_m": (0.0, 0.0025 - h_eq),
                "velocity_m_s": (0.0, -v0),
            }
        ],
        [floor()],
        dt_s=dt,
        gravity_m_s2=(0.0, -9.81),
        material={
            "young_N_m": E,
            "density_kg_m2": rho,
            "damping": gamma,
            "friction": 0.5,
            "application_point": "centroid",
        },
    )
    assert len(sim.aold) == 1
    sim.aold[:] = L * h_eq  # an established contact (at first touch A_old = 0 would kick it by c h_eq)
    rho_pred = _spectral_radius(omega * dt, c_dt)
    amp0 = v0 / omega
    if rho_pred < 1:
        sim.advance(1500)
        assert abs(sim.position[0, 1] - (0.0025 - h_eq)) < 1e-3 * amp0
    else:
        n = math.ceil(math.log(30.0) / math.log(rho_pred))  # the analysis: x30 in n steps
        dev = 0.0
        for _ in range(n):
            sim.advance(1)
            dev = max(dev, abs(sim.position[0, 1] - (0.0025 - h_eq)))
        assert 3 * amp0 < dev < 0.5 * h_eq
