"""A settled pile restarted at rest stays at rest at the default time step (energy conservation's weak form: no
energy may come from nowhere), and heats up at twice that step with the Gear integrator, so the bound is where the
instability is. The pile: 8-10-gons (circumradius 5 mm +- 10 %, E = 10^7 N/m, rho = 5000 kg/m², friction 0.6) in
a box, settled under gravity with velocity Verlet (stable there up to 2 dt_rule), then restarted with zero
velocities. Its default Gear step is set by the tangential damping (TANGENTIAL_DT: c_t dt = 0.06, 0.15 dt_rule).

Thresholds: the kinetic energy left from settling decays below 1e-5 J/m per grain within 30 ms at a stable step
(measured 1.5-3e-6; the contacts' own vibration), while the unstable step reaches > 1e-4 (measured 2-6e-4): an
order of magnitude on either side of the line between them.
"""

import math

import numpy as np
import pytest

from porepipe.granular import Settings, Simulation, regular_polygon
from porepipe.granular._api import TANGENTIAL_DT

N, SIZE, RHO, E = 200, 0.005, 5000.0, 1e7


def pile(positions=None, integrator="verlet", dt_s=None):
    """N grains in a loose lattice (no two touching), or at ``positions`` (x, y, angle) at rest."""
    rng = np.random.default_rng(3)
    radii = SIZE * (1.0 + 0.1 * rng.uniform(-1.0, 1.0, N))
    corners = rng.integers(8, 11, N)
    width = 30 * SIZE
    parts, x, y = [], 0.0, 0.0
    for k, (r, c) in enumerate(zip(radii, corners, strict=True)):
        x += r if x == 0.0 else 2.1 * SIZE
        if x + r > width:
            x, y = r, y + 2.3 * SIZE
        pos, phi = (x, y + 1.2 * SIZE), float(rng.uniform(0, 2 * math.pi))
        if positions is not None:
            pos, phi = tuple(positions[k, :2]), float(positions[k, 2])
        parts.append(
            {"vertices_m": regular_polygon(int(c), float(r)).tolist(), "position_m": pos, "angle_rad": phi}
        )
    return Simulation(
        Settings.model_validate(
            {
                "dt_s": dt_s,
                "integrator": integrator,
                "gravity_m_s2": (0.0, -9.81),
                "material": {"young_N_m": E, "density_kg_m2": RHO, "damping": 0.5, "friction": 0.6},
                "box": {"lower_m": (-SIZE, -0.5 * SIZE), "upper_m": (width + SIZE, y + 4 * SIZE)},
                "particles": parts,
            }
        )
    )


@pytest.fixture(scope="module")
def settled():
    sim = pile()
    sim.advance(int(round(0.8 / sim.dt)))
    return sim.position.copy()


def kinetic_energy_after(sim, seconds):
    sim.advance(int(round(seconds / sim.dt)))
    return sim.kinetic_energy() / sim.n_mob


def test_default_gear_step_is_the_tangential_damping_bound(settled):
    sim = pile(settled, "gear")
    assert sim.dt < 0.2 * sim.dt_rule
    per = 1.0 / sim.mass + sim.r_circ**2 / sim.inertia
    assert sim.dt == pytest.approx(
        TANGENTIAL_DT[sim.settings.integrator] / math.sqrt(4.0 / 7.0 * E * per.max())
    )


@pytest.mark.parametrize("integrator", ["gear", "verlet"])
def test_settled_pile_stays_at_rest_at_the_default_step(settled, integrator):
    sim = pile(settled, integrator)
    assert kinetic_energy_after(sim, 0.03) < 3e-6


def test_settled_pile_heats_up_at_twice_the_default_gear_step(settled):
    default = pile(settled, "gear").dt
    hot = pile(settled, "gear", 2.0 * default)
    assert kinetic_energy_after(hot, 0.03) > 3e-5
    # the step that heats the pile is named on the console (granular.run prints this line), the default is not
    line = hot.damping_bound_notice()
    assert line.startswith("granular.dt_s = ") and "c_t dt = 0.120, bound 0.06" in line and "verlet" in line
    assert pile(settled, "gear", default).damping_bound_notice() is None
    assert pile(settled, "gear").damping_bound_notice() is None
