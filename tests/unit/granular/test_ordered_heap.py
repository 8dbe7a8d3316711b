"""Ordered heap (Schinner 2001 §4.1): hexagonally stacked disks on a base of fixed disks.

A triangle of 8 rows (36 free disks, regular 32-gons of radius 1 mm, mu = 0.6, E = 1e6 N/m) rests on 9 fixed disks;
every lattice site has its neighbours 2 r (1 + 1e-4) away, so all six neighbours of an interior disk are touching
to 1e-4 r. The heap settles under gravity for 0.3 s (30 000 steps, ~1 s CPU).

Truths:
- statics, exact: the base disks carry the whole weight (1e-6 measured; tolerance 1e-4, the kinetic residue).
- the thesis's observation and its mechanism: each disk wedges its two lower neighbours apart, so same-row
  neighbours separate and carry no force; a disk with two disks above it has 4 loaded contacts, not the lattice's
  6 (thesis: "mean coordination ~ 4 despite 6 neighbours"). Measured: no same-row contact; 18 of the 21 disks with
  two disks above have exactly 4 contacts (3 flank disks lost one by sliding a little, as the thesis saw the foot
  slide). Required: no same-row contact, at least 3/4 of them with 4.
- Hong's counting argument (thesis §4.1): on a base of fixed disks the floor load is roughly constant, not the
  heap's height profile. Measured: base loads 3.8-4.5 grain weights (mean N/2 = 4); a column picture would give
  1 : 8 from the foot to the centre. Required: every base load within 25 % of N/2 grain weights.
"""

import numpy as np
import pytest

from porepipe.granular import Simulation
from porepipe.granular._settings import Settings

R, CORNERS, ROWS = 1e-3, 32, 8
SPACING = 2 * R * (1 + 1e-4)


def _heap() -> tuple[Simulation, np.ndarray, np.ndarray]:
    """The settled heap, each free disk's (row, position in row), and one disk's weight."""
    a = 2 * np.pi * np.arange(CORNERS) / CORNERS
    disk = [(float(R * np.cos(t)), float(R * np.sin(t))) for t in a]
    walls = [
        {"name": f"base {k}", "vertices_m": [(x + k * SPACING, y + R) for x, y in disk]}
        for k in range(ROWS + 1)
    ]
    lattice = [(i, j) for i in range(1, ROWS + 1) for j in range(ROWS + 1 - i)]
    rise = SPACING * np.sqrt(3) / 2
    particles = [
        {"vertices_m": disk, "position_m": ((j + 0.5 * i) * SPACING, R + i * rise)} for i, j in lattice
    ]
    settings = {
        "dt_s": 1e-5,
        "integrator": "verlet",
        "material": {"young_N_m": 1e6, "density_kg_m2": 5000, "damping": 0.75, "friction": 0.6},
        "walls": walls,
        "particles": particles,
    }
    sim = Simulation(Settings.model_validate(settings), seed=1)
    sim.advance(int(round(0.3 / sim.dt)))
    weight = 5000 * 0.5 * CORNERS * R**2 * np.sin(2 * np.pi / CORNERS) * 9.81
    return sim, np.array(lattice), weight


@pytest.fixture(scope="module")
def heap():
    return _heap()


def test_the_base_carries_the_weight(heap):
    sim, lattice, weight = heap
    c = sim.contacts()
    on_base = c["j"] >= sim.n_mob  # forces act on the disk i: the base pushes up
    assert c["fy_N"][on_base].sum() == pytest.approx(len(lattice) * weight, rel=1e-4)


def test_same_row_neighbours_carry_no_force_and_loaded_disks_have_four_contacts(heap):
    sim, lattice, _ = heap
    c = sim.contacts()
    n = sim.n_mob
    free = c["j"] < n
    rows = lattice[:, 0]
    assert not np.any(rows[c["i"][free]] == rows[c["j"][free]])
    k = np.bincount(c["i"], minlength=n) + np.bincount(c["j"][free], minlength=n)
    sites = {tuple(s): q for q, s in enumerate(lattice.tolist())}
    loaded = [q for (i, j), q in sites.items() if (i + 1, j - 1) in sites and (i + 1, j) in sites]
    assert len(loaded) == 21
    assert np.mean(k[loaded] == 4) >= 0.75
    assert k.max() <= 4  # never the lattice's 6


def test_base_load_is_flat_as_hongs_counting_argument(heap):
    sim, lattice, weight = heap
    c = sim.contacts()
    loads = np.array([c["fy_N"][c["j"] == sim.n_mob + b].sum() for b in range(ROWS + 1)]) / weight
    np.testing.assert_allclose(loads, ROWS / 2, rtol=0.25)
