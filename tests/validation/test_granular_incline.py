"""Thesis §2.5.1 incline and pull tests, with the incline made by tilting gravity by Theta over a horizontal
floor (the same mechanics as a tilted plane): static friction until tan Theta = mu in 1-degree steps, tipping when
tan Theta > b/h, rolling without slip iff tan Theta <= 3 mu, and the pull threshold mu F_n independent of the
contact area (shapes of equal mass 100 g)."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "unit" / "granular"))
from naive_granular import floor, simulation

from porepipe.granular import rectangle, regular_polygon

G = 9.81
E = 1e7  # the thesis's particle modulus (§4.3.3)
RHO = 1000.0


def _tilted(theta_deg, poly, mu, steps, dt, damping=0.5, y0=None, point="midpoint"):
    th = math.radians(theta_deg)
    lo = np.min(np.asarray(poly)[:, 1])
    sim = simulation(
        [{"vertices_m": [tuple(v) for v in poly], "position_m": (0.0, -lo if y0 is None else y0)}],
        [floor(width=2.0)],
        dt_s=dt,
        gravity_m_s2=(G * math.sin(th), -G * math.cos(th)),
        material={
            "young_N_m": E,
            "density_kg_m2": RHO,
            "damping": damping,
            "friction": mu,
            "application_point": point,
        },
    )
    sim.advance(steps)
    return sim


@pytest.mark.parametrize("theta_deg", [24, 25, 26, 27, 28, 29])
def test_block_rests_until_tan_theta_equals_mu(theta_deg):
    # mu = 0.5: arctan mu = 26.57 deg. Below, the block must not creep: with the force at the overlap centroid a
    # flat face is restored when it tilts (at the midpoint of c1c2 it is not, and the block rocks and creeps by
    # ~1e-5-1e-4 m/s), so after the initial elastic settling (< 0.3 um measured) it is at rest: drift over the
    # second 0.1 s below 1e-9 m/s (measured ~1e-19, round-off). Above, it slides with a = g (sin - mu cos) within
    # 2 % (measured 1.3 % at 27 deg, 0.4 % at 28 deg: the settling transient), flat (|phi| < 1e-5 rad).
    mu = 0.5
    sim = _tilted(theta_deg, rectangle(0.02, 0.005), mu, 10000, 1e-5, point="centroid")
    x0 = sim.position[0, 0]
    sim.advance(10000)
    v = sim.velocity[0, 0]
    th = math.radians(theta_deg)
    if math.tan(th) < mu:
        assert abs(sim.position[0, 0] - x0) / 0.1 < 1e-9
        assert abs(sim.position[0, 0]) < 1e-6
    else:
        a = G * (math.sin(th) - mu * math.cos(th))
        t = sim.time_s
        assert v == pytest.approx(a * t, rel=0.02)
        assert abs(sim.position[0, 2]) < 1e-5


@pytest.mark.parametrize(("theta_deg", "tips"), [(12, False), (18, True)])
def test_tall_block_tips_when_tan_theta_exceeds_b_over_h(theta_deg, tips):
    # b/h = 0.25 -> 14.0 deg; mu = 0.9 so it cannot slide first (tan^-1 0.9 = 42 deg)
    sim = _tilted(theta_deg, rectangle(0.005, 0.02), 0.9, 15000, 1e-5, point="centroid")
    angle = abs(sim.position[0, 2])
    if tips:
        assert angle > 0.1  # rotating away about its downhill corner (0.1 rad within 0.15 s at 18 deg)
    else:
        # it leans on a wedge-shaped overlap at its downhill corner, by ~1e-3 rad (static estimate 9e-4 rad,
        # measured 3.4e-3 rad at 0.15 s, still settling), far from the 0.245 rad (arctan b/h) of toppling
        assert angle < 0.01


@pytest.mark.parametrize(("theta_deg", "rolls"), [(12, True), (22, False)])
def test_disk_rolls_without_slipping_iff_tan_theta_below_3_mu(theta_deg, rolls):
    # 64-gon disk R = 5 mm, mu = 0.1: 3 mu -> 16.7 deg. Rolling: a = g sin / (1 + I/(m R^2)) (2/3 g sin for a disk)
    # and slip speed |v + w R| < 3 % of v; slipping: a = g (sin - mu cos) within 5 %, slip > 20 % of v.
    mu, R = 0.1, 0.005
    poly = regular_polygon(64, R, phase_rad=math.pi / 64)
    sim = _tilted(theta_deg, poly, mu, 8000, 1e-5, damping=0.5)
    th = math.radians(theta_deg)
    v, w = sim.velocity[0, 0], sim.velocity[0, 2]
    r_eff = R * math.cos(math.pi / 64)
    slip = abs(v + w * r_eff)
    t = sim.time_s
    if rolls:
        ratio = sim.inertia[0] / (sim.mass[0] * r_eff**2)
        assert v == pytest.approx(G * math.sin(th) / (1 + ratio) * t, rel=0.05)
        assert slip < 0.03 * v
    else:
        assert v == pytest.approx(G * (math.sin(th) - mu * math.cos(th)) * t, rel=0.05)
        assert slip > 0.2 * v


@pytest.mark.parametrize("shape", ["square", "plate", "strip", "hexagon"])
def test_pull_threshold_is_mu_Fn_for_any_contact_area(shape):
    # §2.5.1: 100 g shapes with contact lengths 10, 20, 40 and 7.2 mm pulled by a drag spring (DRAG_K = 100 N/m,
    # free end at 0.01 m/s: the force rises by 1 N/s); mu = 0.3, so the threshold mu m g = 0.294 N whatever the
    # contact area. Onset = the first displacement beyond 1 um (5x the elastic tangential deflection of the
    # contact spring at the threshold, 0.2 um). Force at the overlap centroid and the default dt (which keeps the
    # strip's damping rate c dt <= 0.15; at dt = 1e-5 s its c dt = 0.36 is past the Gear's stability bound and
    # it rang and crept early, at 0.92-0.95 mu m g). The onset force lies in [1, 1.04] mu m g: never before the
    # threshold, after it by the detection lag (the force rises 0.34 % per ms; measured 1.026-1.031).
    mu, k, v = 0.3, 100.0, 0.01
    polys = {
        "square": rectangle(0.01, 0.01),
        "plate": rectangle(0.02, 0.005),
        "strip": rectangle(0.04, 0.0025),
        "hexagon": regular_polygon(6, math.sqrt(2e-4 / (3 * math.sqrt(3)))),
    }
    poly = polys[shape]
    lo = poly[:, 1].min()
    sim = simulation(
        [{"vertices_m": [tuple(p) for p in poly], "position_m": (0.0, -lo)}],
        [floor(width=2.0)],
        gravity_m_s2=(0.0, -G),
        material={
            "young_N_m": E,
            "density_kg_m2": RHO,
            "damping": 0.5,
            "friction": mu,
            "application_point": "centroid",
        },
        drag_springs=[{"particle": 0, "k_N_m": k, "velocity_m_s": (v, 0.0)}],
    )
    assert sim.mass[0] == pytest.approx(0.1, rel=1e-9)
    x0 = sim.position[0, 0]
    threshold = mu * 0.1 * G
    while True:
        sim.advance(100)
        moved = sim.position[0, 0] - x0
        force = k * (v * sim.time_s - moved)
        if moved > 1e-6:
            break
        assert sim.time_s < 0.4
    assert threshold <= force <= 1.04 * threshold
