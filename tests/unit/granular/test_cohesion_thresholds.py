"""Cohesion F = k_coh x contact-line length (Eq. 2.28) against hand-derived thresholds on a single square block.

Under a ceiling the flat face's contact line is the whole side a, so the most the contact can pull is k a (the
elastic E A / l vanishes as A -> 0): the block hangs iff k a > m g, at the overlap A = (k a - m g) l / E where the
net normal force carries its weight; a chain of n blocks hangs iff k a > n m g. (A block on a vertical wall cannot
be checked this way: the elastic and cohesive forces act at the same point, so one contact with zero net normal
force has no moment to balance the friction's, and the block peels off.)
"""

import math

import numpy as np
import pytest
from naive_granular import simulation, square

E = 1e6
SIDE = 0.01
RHO = 5000.0
MASS = RHO * SIDE**2
G = 9.81
R_EQ = math.sqrt(SIDE**2 / math.pi)  # l of a particle-wall contact: the particle's equivalent radius
DT = 1e-5
K_HANG = MASS * G / SIDE  # critical cohesion under a ceiling, 49.05 N/m


def _hanging(k, n=1, depths=None, damping=1.0):
    """n squares stacked under a ceiling whose face is at y = 0, at rest, each face ``depths[b]`` (default 1e-7 m)
    into the one above."""
    depths = np.cumsum(depths if depths is not None else [1e-7] * n)
    mat = {
        "young_N_m": E,
        "density_kg_m2": RHO,
        "damping": damping,  # 1: damping ratio ~0.67 of the normal oscillation (period 3 ms): settled in ~20 ms
        "friction": 0.5,
        "cohesion_N_m": k,
    }
    parts = [
        {"vertices_m": square(SIDE), "position_m": (0.0, -(b + 0.5) * SIDE + depths[b])} for b in range(n)
    ]
    ceiling = {"name": "ceiling", "vertices_m": [(-1.0, 0.0), (1.0, 0.0), (1.0, 0.1), (-1.0, 0.1)]}
    return simulation(parts, [ceiling], dt_s=DT, material=mat, gravity_m_s2=(0.0, -G))


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.9, 1.1])
def test_block_hangs_under_a_ceiling_iff_k_a_exceeds_m_g(factor):
    sim = _hanging(factor * K_HANG)
    sim.advance(5000)  # 50 ms: 16 periods of the normal oscillation
    y = sim.position[0, 1] + 0.5 * SIDE  # top face; overlap depth = y (the face is at 0)
    if factor < 1:
        # detached at once: free fall from rest over 50 ms is 12.3 mm (1 % covers the first steps in contact)
        assert -y == pytest.approx(0.5 * G * 0.05**2, rel=0.01)
        assert len(sim.contacts()["i"]) == 0
    else:
        # the equilibrium overlap A = (k a - m g) l / E to 1e-3 (the damped oscillation has decayed by e^-30)
        c = sim.contacts()
        assert c["area_m2"][0] == pytest.approx((factor - 1) * MASS * G * R_EQ / E, rel=1e-3)
        assert c["fn_N"][0] == pytest.approx(-MASS * G, rel=1e-3)  # the contact pulls the block up by m g


@pytest.mark.parametrize("factor", [1.5, 2.2])
def test_chain_of_two_blocks_hangs_iff_k_a_exceeds_2_m_g(factor):
    # two squares stacked under the ceiling: the top contact carries both (k a > 2 m g), the lower one m g. Started
    # at the hand-derived equilibrium depths (from tiny overlaps the lower block's pull tears the top one off in the
    # first oscillation), lightly damped: the first step sees the whole overlap appear, and damping 1 would kick
    # the blocks apart; 0.2 kicks them by ~1/3 of the depths and settles in 100 ms (e-fold 3.7 ms). At 1.5 the
    # ceiling depth is 1e-9 m: the ceiling lets go and the pair falls, stuck together.
    k = factor * K_HANG
    pair = (k * SIDE - MASS * G) * 0.5 * R_EQ / (E * SIDE)  # l_pair = R_EQ / 2 (two equal radii)
    ceiling = max((k * SIDE - 2 * MASS * G) * R_EQ / (E * SIDE), 1e-9)
    sim = _hanging(k, 2, depths=(ceiling, pair), damping=0.2)
    sim.advance(10000)
    c = sim.contacts()
    wall = c["j"] == 2
    if factor < 2:
        assert not wall.any() and len(c["i"]) == 1  # off the ceiling, the pair's own contact holds
        # the pair's centre of mass in free fall once released: g t over 100 ms to 5e-3 (the release takes ~0.2 ms,
        # within a quarter of the pair's own normal period of 2.3 ms, at a net pull below m g)
        assert -sim.velocity[:, 1].mean() == pytest.approx(G * 0.1, rel=5e-3)
    else:
        # equilibrium overlaps: (k a - 2 m g) l_wall / E at the ceiling, (k a - m g) l_pair / E between, to 1e-3
        # (the kick's oscillation has decayed by e^-27)
        assert c["area_m2"][wall][0] == pytest.approx(ceiling * SIDE, rel=1e-3)
        assert c["area_m2"][~wall][0] == pytest.approx(pair * SIDE, rel=1e-3)
        assert c["fn_N"][wall][0] == pytest.approx(-2 * MASS * G, rel=1e-3)
