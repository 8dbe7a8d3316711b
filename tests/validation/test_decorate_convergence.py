"""Acceptance of the grain model's voxelisation: volume convergence of one grain, Monte Carlo agreement, porosity of a
decorated packing from the grey-value extrapolation vs an independent Monte Carlo estimate on the continuum model,
and the overlap minimiser against random orientations."""

import numpy as np
import pytest

from porepipe.decorate import decorate, mean_overlap_volume, points_in_grains, voxelize_grains
from porepipe.decorate._settings import Settings
from porepipe.estimate import porosity_bounds, porosity_mean_grey, richardson_limit
from porepipe.voxelize import grey_histogram

QUARTZ = [{"name": "q", "generator": "quartz", "count": 1, "elongation": (0.5, 0.5), "perturbation": 0.2}]
BOX1 = (24.0, 24.0, 24.0)


@pytest.fixture(scope="module")
def grain():
    return decorate(np.array([[12.1, 11.9, 12.05]]), np.array([5.0]), Settings(families=QUARTZ), seed=3)


def _shell_bound(deco, voxel_um):
    """Steiner bound on |lattice volume − V|: points whose (a/6)-cells straddle the boundary lie within t = √3 h / 2
    of it, so the error is at most V(K ⊕ tB) − V(K ⊖ tB) <= 2 S t + M t² + 4/3 π t³."""
    t_ = deco.library[0]
    s = deco.scales[0]
    t = np.sqrt(3.0) * voxel_um / 6 / 2
    return 2 * t_.area * s**2 * t + t_.mean_curvature * s * t**2 + 4 / 3 * np.pi * t**3


def test_single_grain_volume_converges(grain):
    exact = grain.volumes_um3()[0]
    errors = {}
    for a in (4.0, 2.0, 1.0, 0.5, 0.25):
        grey = voxelize_grains(grain, BOX1, a, periodic=False)
        volume = grey.sum(dtype=np.int64) / 216 * a**3
        errors[a] = (volume - exact) / exact
        assert abs(volume - exact) <= _shell_bound(grain, a)
    print("relative volume error per voxel size a (um):", {a: f"{e:+.2e}" for a, e in errors.items()})
    # measured on this grain: 1.2e-3 at a = 4 down to 1.5e-6 at a = 0.25 (lattice sums converge faster than h)
    assert abs(errors[0.25]) < 1e-4 < abs(errors[4.0])


def test_monte_carlo_agrees_with_grey_values(grain):
    rng = np.random.default_rng(21)
    a = 1.0
    grey = voxelize_grains(grain, BOX1, a, periodic=False)
    # (1) the continuum point test at the 216 sample points of random voxels reproduces their grey values exactly
    vox = np.column_stack([rng.integers(6, 18, 300) for _ in range(3)])
    k = (np.arange(6) + 0.5) / 6
    sub = np.stack(np.meshgrid(k, k, k, indexing="ij"), axis=-1).reshape(-1, 3)
    pts = (vox[:, None, :] + sub[None, :, :]).reshape(-1, 3) * a
    counts = points_in_grains(pts, grain, BOX1, periodic=False).reshape(len(vox), 216).sum(axis=1)
    assert np.array_equal(counts, grey[vox[:, 0], vox[:, 1], vox[:, 2]])
    # (2) uniform random points: the volume fraction agrees with the grey-value volume within 4σ + lattice bound
    n = 400_000
    inside = points_in_grains(rng.uniform(0, 24, (n, 3)), grain, BOX1, periodic=False)
    frac = inside.mean()
    sigma = np.prod(BOX1) * np.sqrt(frac * (1 - frac) / n)
    volume = grey.sum(dtype=np.int64) / 216 * a**3
    assert abs(frac * np.prod(BOX1) - volume) < 4 * sigma + _shell_bound(grain, a)


def test_porosity_extrapolation_matches_monte_carlo():
    rng = np.random.default_rng(0)
    box = (30.0, 30.0, 30.0)
    centres, radii = rng.uniform(0, 30, (45, 3)), rng.uniform(3, 6, 45)
    deco = decorate(centres, radii, Settings(), seed=1)
    a_um = [1.5, 1.0, 0.75, 0.5]
    phi = []
    for a in a_um:
        hist = grey_histogram(voxelize_grains(deco, box, a))
        phi.append(porosity_mean_grey(hist))
        lo, hi = porosity_bounds(hist)
        assert lo < phi[-1] < hi
    phi_inf, phi_err = richardson_limit(a_um, phi)
    n = 1_000_000
    mc = 1.0 - points_in_grains(rng.uniform(0, 30, (n, 3)), deco, box).mean()
    sigma = np.sqrt(mc * (1 - mc) / n)
    print(f"porosity: grey-value limit {phi_inf:.5f} ± {phi_err:.1e}, Monte Carlo {mc:.5f} ± {sigma:.1e}")
    # 3σ of the combined statistical (MC) and extrapolation errors
    assert abs(phi_inf - mc) < 3 * np.hypot(sigma, phi_err)


def test_overlap_minimiser_reduces_mean_overlap():
    rng = np.random.default_rng(5)
    box = (40.0, 40.0, 40.0)
    centres, radii = rng.uniform(0, 40, (50, 3)), rng.uniform(4, 7, 50)
    fams = [{"name": "q", "generator": "quartz", "count": 6, "elongation": (0.3, 0.8)}]
    random = decorate(centres, radii, Settings(families=fams), seed=2, box_um=box)
    om = decorate(
        centres, radii, Settings(families=fams, orientation={"mode": "overlap_minimizer"}), seed=2, box_um=box
    )
    before, after = mean_overlap_volume(random, box), mean_overlap_volume(om, box)
    print(f"mean exact overlap volume per grain: random {before:.1f} um3, minimised {after:.1f} um3")
    assert after < 0.9 * before
