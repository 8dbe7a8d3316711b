"""Statistics recover the known parameters of an image of non-overlapping spheres made here with NumPy alone
(independent of porepipe's packer and voxeliser): porosity exactly, sphere count and radii, S_V against the
analytic Σ 4π r² / V, and the two-point correlation's limits."""

import numpy as np
import pytest
import tifffile

from porepipe.acquire._api import acquire
from porepipe.acquire._settings import Settings

N = 96
VOXEL_UM = 2.5


def _spheres(seed=1, count=36, r_lo=5.0, r_hi=10.0):
    """Non-overlapping spheres (gap >= 1.5 voxels) fully inside the box, radii uniform in voxels."""
    rng = np.random.default_rng(seed)
    centres, radii = [], []
    while len(centres) < count:
        r = rng.uniform(r_lo, r_hi)
        c = rng.uniform(r + 1, N - r - 1, 3)
        if all(np.linalg.norm(c - c2) > r + r2 + 1.5 for c2, r2 in zip(centres, radii)):
            centres.append(c), radii.append(r)
    grid = (np.indices((N, N, N)) + 0.5).reshape(3, -1).T
    solid = np.zeros(N**3, bool)
    for c, r in zip(centres, radii):
        solid |= ((grid - c) ** 2).sum(axis=1) <= r * r
    return np.array(centres), np.array(radii), solid.reshape(N, N, N)


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    centres, radii, solid = _spheres()
    rng = np.random.default_rng(7)
    grey = np.where(solid, 180, 50).astype(np.int16) + rng.integers(
        -20, 21, solid.shape
    )  # noise < half the gap
    path = tmp_path_factory.mktemp("spheres") / "spheres.tif"
    tifffile.imwrite(
        path,
        grey.astype(np.uint8).transpose(2, 1, 0),
        imagej=True,
        resolution=(1 / VOXEL_UM, 1 / VOXEL_UM),
        metadata={"spacing": VOXEL_UM, "unit": "um"},
    )
    tables = acquire(Settings(image=path), path.with_name("statistics.h5"))
    return centres, radii, solid, tables[None]


def test_porosity_exact(measured):
    centres, radii, solid, ds = measured
    assert float(ds.porosity) == 1.0 - np.count_nonzero(solid) / solid.size  # exact: same voxels, same count


def test_grain_count_and_density(measured):
    centres, radii, solid, ds = measured
    assert ds.sizes["grain"] == len(radii)
    box_mm3 = (N * VOXEL_UM / 1000.0) ** 3
    assert float(ds.grains_per_mm3) == pytest.approx(len(radii) / box_mm3, rel=1e-12)


def test_radii_recovered(measured):
    centres, radii, solid, ds = measured
    # match grains to spheres by centroid
    got = ds.centroid_um.values / VOXEL_UM
    order = [int(np.argmin(np.linalg.norm(got - c, axis=1))) for c in centres]
    assert sorted(order) == list(range(len(radii)))
    r_eq = ds.equivalent_radius_um.values[order] / VOXEL_UM
    r_in = ds.inscribed_radius_um.values[order] / VOXEL_UM
    # volume-equivalent radius of a digitised ball of radius >= 5 voxels: the voxel count error is a surface
    # effect of relative size ~ 1/r^2, measured < 0.05 voxel; bound 0.1 voxel per grain
    np.testing.assert_allclose(r_eq, radii, atol=0.1)
    # distance-transform peak + 1/2 voxel: digitisation scatter of about ±0.4 voxel per grain, bias < 0.15 voxel
    np.testing.assert_allclose(r_in, radii, atol=0.6)
    assert abs(np.mean(r_in - radii)) < 0.15
    # balls: inertia tensor isotropic up to digitisation
    assert ds.elongation.values.max() < 0.1


def test_specific_surface_against_analytic(measured):
    centres, radii, solid, ds = measured
    s_v_exact = np.sum(4 * np.pi * (radii * VOXEL_UM) ** 2) / (N * VOXEL_UM) ** 3 * 1000.0  # mm^-1
    # Minkowski stage (13-direction Crofton on the digitised balls, r = 5..10 voxels): a few per cent; bound 5 %
    assert float(ds.S_V_per_mm) == pytest.approx(s_v_exact, rel=0.05)
    # stereological 2 P_L along each axis, same digitisation: bound 5 %
    np.testing.assert_allclose(ds.S_V_chord_per_mm.values, s_v_exact, rtol=0.05)


def test_two_point_limits(measured):
    centres, radii, solid, ds = measured
    phi = float(ds.porosity)
    np.testing.assert_allclose(ds.two_point.isel(lag=0).values, phi, rtol=1e-12)
    # at r = 24 voxels (~1.6 mean diameters) S_2 is near φ²: hard-core spheres make S_2 oscillate about φ² and the
    # sample holds 36 spheres, together ~1e-2 here; bound 0.02 (S_2(0) - φ² = φ(1 - φ) = 0.12 for scale)
    np.testing.assert_allclose(ds.two_point.isel(lag=-1).values, phi**2, atol=0.02)
    # percolation: a matrix of isolated balls leaves one connected pore cluster spanning every axis
    np.testing.assert_allclose(ds.connected_porosity.values, phi, rtol=1e-12)
