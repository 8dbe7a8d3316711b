"""Exact invariants of free-molecular flow, each against a value computed independently of the engine.

- Diffuse (Lambert) walls in any closed pore: the mean flight between wall hits is 4V/S (Cauchy's mean chord; V and
  S counted voxel by voxel), i.e. the hit rate is v̄S/(4V).
- Long tubes: D -> d·v̄/3 (Knudsen 3.46), from the mean-square displacement in a tube periodic along its axis.
- A medium with the symmetry of the cube has an isotropic D tensor.
- Wicke-Kallenbach counter-diffusion with Δc = 2N/V_P equals v̄·L·W/4 from transmission (module docstring).
Tolerances: 3 σ of the batch-means (ratio) errors, plus the measured voxelisation error where a staircase enters.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "unit" / "diffusion"))
from naive_diffusion import wall_area_naive

from porepipe.diffusion import Settings, Setup, closed_box, cylinder, equilibrium, square_capillary, transport

SETTINGS = Settings(batches=32, batch_particles=200, max_rounds=1)


def _spheres(shape, radius, n, seed, overlap):
    """Solid balls (random sequential addition without overlap, or a Boolean model with overlap) in a box."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(*[np.arange(s) + 0.5 for s in shape], indexing="ij"), axis=-1)
    solid = np.zeros(shape, dtype=bool)
    centres = []
    for _ in range(50 * n):
        if len(centres) >= n:
            break
        c = rng.uniform(0, shape, 3)
        if not overlap and centres and np.min(np.linalg.norm(np.array(centres) - c, axis=1)) < 2 * radius + 1:
            continue
        centres.append(c)
        solid |= np.sum((grid - c) ** 2, axis=-1) <= radius**2
    return (~solid).astype(np.uint8)


def _check_four_v_over_s(pore, voxel, seed, t_end):
    r = equilibrium(pore, SETTINGS, voxel_um=voxel, seed=seed, t_end=t_end)
    h = np.broadcast_to(np.asarray(voxel, float), (3,)) / np.min(voxel)
    expected = 4 * pore.sum() * np.prod(h) / wall_area_naive(pore, h)
    v = r.values
    assert v["four_v_over_s"] == pytest.approx(expected, rel=1e-12)
    assert v["wall_hits"] > 20 * v["particles"]
    assert abs(v["mean_free_flight"] - expected) <= 3 * v["mean_free_flight_err"], (
        v["mean_free_flight"],
        expected,
    )
    assert v["mean_free_flight_err"] < 0.01 * expected  # the test has teeth: a 3 % error would be caught
    return v


def test_box_anisotropic_voxels():
    v = _check_four_v_over_s(closed_box((8, 10, 6)).pore, (1.0, 1.5, 2.0), 1, 400.0)
    assert v["four_v_over_s"] == pytest.approx(4 * 1440 / 792)  # V = 8·15·12, S = 2(15·12 + 8·12 + 8·15)


def test_packing_like_pore_space():
    pore = _spheres((30, 30, 30), 4.5, 40, 2, overlap=False)
    _check_four_v_over_s(pore, 1.0, 2, 300.0)


def test_porous_sample_with_closed_pores():
    """A Boolean model of grains at porosity ≈ 0.3 (like the mini scene's pore space): many closed pores."""
    pore = _spheres((28, 28, 28), 4.0, 140, 3, overlap=True)
    assert 0.15 < pore.mean() < 0.45
    _check_four_v_over_s(pore, 1.0, 3, 300.0)


def test_long_tube_knudsen_limit():
    """D_zz of a periodic tube -> d v̄ / 3 within 3 σ + the voxelisation error |D(12) - D(6)| (relative)."""
    s = Settings(batches=32, batch_particles=400, max_rounds=1)  # Maxwell speeds, kept: D averages to d·v̄/3
    rel = {}
    for radius in (6, 12):
        r = equilibrium(
            cylinder(radius, 6).pore, s, periodic=(False, False, True), seed=radius, t_end=300.0 * radius
        )
        v = r.values
        assert "D_xx" not in v and "D_yy" not in v  # walled axes have no long-time diffusion
        rel[radius] = (v["D_zz"] / (2 * radius / 3), v["D_zz_err"] / (2 * radius / 3))
    (d6, _), (d12, e12) = rel[6], rel[12]
    assert abs(d12 - 1.0) <= 3 * e12 + abs(d12 - d6), rel
    assert e12 < 0.04


def test_cubic_symmetric_medium_has_isotropic_tensor():
    """Solid cubes on a periodic cubic lattice: D_xx = D_yy = D_zz, and Ψ, χ, τ follow their definitions."""
    pore = np.ones((10, 10, 10), np.uint8)
    pore[2:8, 2:8, 2:8] = 0
    s = Settings(batches=32, batch_particles=200, max_rounds=1)
    v = equilibrium(pore, s, periodic=(True, True, True), seed=4, t_end=1500.0).values
    d = np.array([v["D_xx"], v["D_yy"], v["D_zz"]])
    e = np.array([v["D_xx_err"], v["D_yy_err"], v["D_zz_err"]])
    for a in range(3):
        for b in range(a):
            assert abs(d[a] - d[b]) <= 3 * math.hypot(e[a], e[b])
    eps = 1 - 216 / 1000
    assert v["accessible_porosity"] == pytest.approx(eps)
    assert v["D_eff"] == pytest.approx(eps * d.mean())
    assert v["psi"] == pytest.approx(v["D_eff"] / v["D_ref"])
    assert v["labyrinth_factor"] == pytest.approx(v["psi"] / eps)
    assert v["tortuosity"] == pytest.approx(1 / v["labyrinth_factor"])


def test_wicke_kallenbach_equals_transmission():
    """Counter-diffusion flux with Δc = 2N/V_P reproduces v̄LW/4 (Lambert inlet, flux-weighted speeds), and the
    species-1 profile falls monotonically from the species-1 face."""
    pore = square_capillary(8, 40).pore
    wk = transport(
        pore,
        2,
        Settings(
            setup=Setup.wicke_kallenbach,
            batches=32,
            batch_particles=40,
            max_rounds=1,
            wk_time_jiffies=20000.0,
        ),
        seed=7,
    )
    tr = transport(pore, 2, Settings(batches=32, batch_particles=1000, max_rounds=1), seed=7)
    a, b = wk.values, tr.values
    assert abs(a["D"] - b["D"]) <= 3 * math.hypot(a["D_err"], b["D_err"]), (a["D"], b["D"])
    assert a["D_wk_thesis"] == pytest.approx(2 * a["D"])
    c = wk.arrays["concentration"]
    assert np.all(np.diff(c) < 0)
    # both species alive half of the time: the species-1 amount is half the particles (time-averaged)
    assert c.mean() * 8 * 8 * 40 == pytest.approx(0.5, rel=0.05)
