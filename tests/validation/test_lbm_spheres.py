"""LBM permeability against published Stokes drag of simple-cubic sphere arrays; τ-independence; the κ stop rule.

Reference: Zick & Homsy (1982), J. Fluid Mech. 115, 13, Table 2 (simple cubic), dimensionless drag
K = F/(6π μ a U) with U the superficial velocity, in ``porepipe.lbm._calibration.ZICK_HOMSY_SC``; checked here
against the independent dilute series of Sangani & Acrivos (1982). κ̂ = L³/(6π a K) for one sphere of radius a in
a periodic cell of L voxels (``drag_coefficient``). Interpolated walls (CLI) use the exact ray-sphere distances.
Tolerances are the issue's accuracy targets (1 % at 16 voxels per diameter, 0.3 % at 32) and, for the
τ-independence, 0.1 % (TRT with Λ = 3/16 is τ-independent up to the O(Ma²) inertia of the run, ~1e-4 here).
"""

import numpy as np
import pytest

from porepipe.lbm import Settings, SphereWalls, permeability
from porepipe.lbm import _calibration as cal


def _drag(c: float, diameter: float, walls: str, tau: float = 0.857) -> float:
    cells = cal.cells_for_diameter(c, diameter)
    pore, geometry, a = cal.sphere_array(cells, c)
    res = permeability(
        pore, "x", Settings(walls=walls, tau=tau, tolerance_kappa=1e-6), progress=False, geometry=geometry
    )
    assert res.converged and res.walls == walls
    return cal.drag_coefficient(res.kappa_lu, cells, a)


def _porous(n: int = 20, count: int = 14, seed: int = 2):
    """Overlapping spheres (radius 3-4.5 voxels) in a periodic box: porosity 0.65, one-voxel gaps included."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(0, n, (count, 3))
    radii = rng.uniform(3.0, 4.5, count)
    x = np.arange(n) + 0.5
    grid = np.stack(np.meshgrid(x, x, x, indexing="ij"), -1)
    solid = np.zeros((n,) * 3, dtype=bool)
    for c, r in zip(centres, radii):
        d = np.abs(grid - c)
        d = np.minimum(d, n - d)
        solid |= (d**2).sum(-1) < r * r
    return ~solid, SphereWalls(centres, radii, (float(n),) * 3)


def test_published_drag_agrees_with_the_dilute_series():
    """Zick & Homsy's K(c) against the Sangani-Acrivos series: 0.1 % for c ≤ 0.125, 1 % at 0.216 (the series is
    truncated at c^{10/3}; it is the dilute limit, not meant for dense arrays)."""
    for c in (0.027, 0.064, 0.125):
        assert cal.sangani_acrivos_dilute(c) == pytest.approx(cal.ZICK_HOMSY_SC[c], rel=1e-3)
    assert cal.sangani_acrivos_dilute(0.216) == pytest.approx(cal.ZICK_HOMSY_SC[0.216], rel=1e-2)


def test_a_shifted_sphere_array_is_the_same_array_moved():
    """A whole-voxel shift rolls the voxels (periodic images included); a sub-voxel one keeps c to the staircase's
    O(1/L) and moves the exact walls with it."""
    pore, walls, a = cal.sphere_array(20, 0.45)
    moved, moved_walls, a_moved = cal.sphere_array(20, 0.45, (1.0, 0.0, -3.0))
    assert a_moved == a and np.array_equal(moved, np.roll(pore, (1, 0, -3), axis=(0, 1, 2)))
    half, half_walls, _ = cal.sphere_array(20, 0.45, (0.5, 0.5, 0.5))
    assert abs(1 - half.mean() - 0.45) < 0.02 and not np.array_equal(half, pore)
    np.testing.assert_allclose(half_walls.centres - walls.centres, 0.5)


@pytest.mark.parametrize("c", [0.125, 0.343, 0.45])
def test_interpolated_walls_within_one_percent_at_16_voxels_per_diameter(c):
    """CLI walls: |K/K_ZH − 1| < 1 % at ~16 voxels per diameter (measured +0.51, +0.88, +0.94 % before the floor
    q ≥ Q_MIN = 0.1; c = 0.45 now +0.60 %); halfway bounce-back on the same lattice is worse (+5.9, +4.4, +6.5 %).
    At other places of the sphere on the lattice c = 0.45 is up to +2.7 % (CLI) and +1.8 % (MR1)."""
    k_cli = _drag(c, 16, "cli")
    k_half = _drag(c, 16, "halfway")
    ref = cal.ZICK_HOMSY_SC[c]
    assert abs(k_cli / ref - 1) < 0.01
    assert abs(k_half / ref - 1) > 2 * abs(k_cli / ref - 1)


def test_interpolated_walls_converge_at_second_order_from_16_to_32():
    """c = 0.343 at 15.6 and 32.1 voxels per diameter: error +0.88 % -> +0.17 % (order 2.3; ≥ 1.8 asked). Indicative
    only: at 24.3 and 40.0 it is +0.51 and +0.32 % (the error moves with the sphere's place on the lattice), and
    Zick & Homsy print K = 15.4, ±0.32 %."""
    ref = cal.ZICK_HOMSY_SC[0.343]
    coarse, fine = (abs(_drag(0.343, d, "cli") / ref - 1) for d in (16, 32))
    d_coarse = 2 * cal.sphere_array(cal.cells_for_diameter(0.343, 16), 0.343)[2]
    d_fine = 2 * cal.sphere_array(cal.cells_for_diameter(0.343, 32), 0.343)[2]
    assert fine < 0.003
    assert np.log(coarse / fine) / np.log(d_fine / d_coarse) > 1.8


@pytest.mark.slow
def test_interpolated_walls_within_0p3_percent_at_32_where_the_reference_has_four_digits():
    """c = 0.216, K = 7.442 printed to ±0.007 %: |error| < 0.3 % at 32 voxels per diameter (measured −0.04 %; −0.20
    and +0.22 % at 15.6 and 23.8, the sign set by where the sphere sits on the lattice). For c = 0.343 and 0.45 Zick &
    Homsy print three digits (±0.32 and ±0.18 %), too few to test 0.3 % against."""
    assert cal.ZICK_HOMSY_SC_ROUNDING[0.216] < 0.1 * 0.003 < cal.ZICK_HOMSY_SC_ROUNDING[0.343]
    assert abs(_drag(0.216, 32, "cli") / cal.ZICK_HOMSY_SC[0.216] - 1) < 0.003


@pytest.mark.slow
def test_multireflection_walls_within_0p3_percent_at_32_averaged_over_the_lattice_position():
    """c = 0.45 at 32.3 voxels per diameter, MR1 walls, the sphere at the five SUBVOXEL_SHIFTS: mean error against
    Zick & Homsy's printed 28.1 below 0.3 % (measured +0.15 %: +0.12, +0.29, +0.07, +0.12, +0.13; CLI +0.26 %:
    +0.38, +0.49, −0.05, +0.28, +0.19). The printed value is itself ±0.18 % (28.05 … 28.15): the mean K = 28.142 is
    within 0.3 % of every value in that interval above 28.058. What is left is mostly the voxel-sum quadrature of
    the superficial velocity near the wall (in a slit MR1's nodes are exact and κ̂ differs from the integral by that
    sum's error, tests/hard/test_lbm_hard.py), which is why it moves with the sphere's place."""
    ref = cal.ZICK_HOMSY_SC[0.45]
    cells = cal.cells_for_diameter(0.45, 32)
    errors = []
    for shift in cal.SUBVOXEL_SHIFTS:
        pore, geometry, a = cal.sphere_array(cells, 0.45, shift)
        res = permeability(
            pore, "x", Settings(walls="mr1", tolerance_kappa=1e-6), progress=False, geometry=geometry
        )
        assert res.converged and res.walls == "mr1"
        errors.append(cal.drag_coefficient(res.kappa_lu, cells, a) / ref - 1)
    assert abs(np.mean(errors)) < 0.003
    assert max(errors) < 0.004  # no position far off (measured ≤ 0.29 %)


@pytest.mark.parametrize("walls", ["halfway", "cli", "mr1"])
def test_kappa_is_tau_independent_on_a_sphere_array(walls):
    """TRT Λ = 3/16: K at τ = 0.6, 1, 2 within 0.1 % (8 voxels per diameter, c = 0.125)."""
    ks = [_drag(0.125, 8, walls, tau) for tau in (0.6, 1.0, 2.0)]
    assert (max(ks) - min(ks)) / np.mean(ks) < 1e-3


@pytest.mark.parametrize("walls", ["halfway", "cli", "mr1"])
def test_kappa_is_tau_independent_on_a_porous_sample(walls):
    """Random overlapping spheres with one-voxel gaps: κ̂ at τ = 0.6 and 2 within 0.1 % (measured 1.5e-4 and
    1.0e-4: the inertia of the faster flow at low viscosity, not the walls)."""
    pore, geometry = _porous()
    ks = [
        permeability(pore, "x", Settings(walls=walls, tau=tau), progress=False, geometry=geometry).kappa_lu
        for tau in (0.6, 2.0)
    ]
    assert abs(ks[0] / ks[1] - 1) < 1e-3


def test_kappa_stop_ends_early_with_kappa_within_0p1_percent_of_a_tight_run():
    """stop=kappa (tolerance 1e-5 on the window change and on the tail estimate) against the thesis's density
    rule (δρ < 1e-9, δv < 1e-4) on the porous sample with CLI walls at τ = 1: no more steps, the same κ̂ within 0.1 %
    (measured: equal); each result names the rule that stopped it, and the actual distance to the tight κ̂ stays
    within 10× the tolerance the error estimate certified. (Both rules stop at 1500 steps here since Q_MIN: the
    density rule's 13 000 steps before were the slow drift of links with q → 0; benchmarks/lbm_kappa_stop.py
    compares the step counts on the larger porous samples.)"""
    pore, geometry = _porous()
    fast = permeability(pore, "x", Settings(tau=1.0), progress=False, geometry=geometry)
    tight = permeability(pore, "x", Settings(tau=1.0, stop="density"), progress=False, geometry=geometry)
    assert fast.stopped_by == "kappa" and tight.stopped_by == "density"
    assert fast.steps <= tight.steps
    assert abs(fast.kappa_lu / tight.kappa_lu - 1) < 1e-3
    assert fast.kappa_error < 1e-5 and abs(fast.kappa_lu / tight.kappa_lu - 1) < 1e-4
