"""Identities and limits of local porosity theory (thesis §4.6, eqs. 4.6.1-4.6.6) on the computed Datasets."""

import numpy as np
import pytest

from porepipe.lpt import Settings, characteristic_length, local_porosity_analysis

PERIODIC = (True, True, True)


def random_pore(shape, phi, seed):
    return (np.random.default_rng(seed).random(shape) < phi).astype(np.uint8)


@pytest.fixture(scope="module")
def random_ds():
    pore = random_pore((24, 24, 24), 0.33, 1)
    settings = Settings(cell_voxels=[1, 2, 3, 5, 8, 24], lambda_stride=1, max_bins=60)
    return pore, local_porosity_analysis(pore, voxel_um=1.5, periodic=PERIODIC, settings=settings)


def test_mu_is_a_probability_and_its_mean_is_the_porosity(random_ds):
    pore, ds = random_ds
    n_pore = int(pore.sum())
    # Σ μ = 1 up to float rounding of a sum of <= 1001 terms
    np.testing.assert_allclose(ds.mu.sum("bin"), 1.0, rtol=0, atol=1e-12)
    # all-position periodic placement: every voxel lies in exactly L³ cells, so Σ_cells k = L³ N_pore exactly
    # (integers, exact and binned L alike: L = 5, 8, 24 have L³+1 > 60 bins)
    assert ds.exact.values.tolist() == [1, 1, 1, 0, 0, 0]
    expected = ds.L.values**3 * n_pore
    assert np.array_equal(ds.pore_voxels.sum("bin").values, expected)
    np.testing.assert_allclose(ds.phi_mean, n_pore / pore.size, rtol=1e-14)
    # the same through Σ φ μ on exact bins (φ = k/L³ there)
    exact = ds.isel(L=ds.exact.values == 1)
    np.testing.assert_allclose((exact.phi.fillna(0) * exact.mu).sum("bin"), n_pore / pore.size, rtol=1e-12)


def test_small_cell_limit_eq_4_6_2(random_ds):
    pore, ds = random_ds
    one = ds.sel(L=1)
    phi_bar = pore.mean()
    # L = 1: μ = (1-φ̄) δ(φ) + φ̄ δ(φ-1), exactly
    assert one.cells.values[:2].tolist() == [pore.size - int(pore.sum()), int(pore.sum())]
    np.testing.assert_allclose(one.mu.values[:2], [1 - phi_bar, phi_bar], rtol=1e-15)
    # a single pore voxel joins all its faces: λ(φ=1, 1) = 1, λ(φ=0, 1) = 0, p_α(1) = φ̄ for every α
    np.testing.assert_array_equal(one["lambda"].values[:2], np.array([[0.0] * 5, [1.0] * 5]))
    np.testing.assert_allclose(one.p, phi_bar, rtol=1e-15)


def test_whole_sample_cell_limit_eq_4_6_3(random_ds):
    pore, ds = random_ds
    whole = ds.sel(L=24)
    # L = sample edge with wrapping: every cell holds the whole sample, so μ = δ(φ - φ̄)
    assert whole.cells.max() == whole.cells_total == pore.size
    np.testing.assert_allclose(whole.phi_var, 0.0, atol=1e-15)
    np.testing.assert_allclose(whole.phi_mean, pore.mean(), rtol=1e-14)


@pytest.mark.parametrize("size", [2, 4, 8])
def test_variance_of_uncorrelated_voxels(size):
    phi = 0.3
    n = 96
    pore = random_pore((n, n, n), phi, 10 + size)
    ds = local_porosity_analysis(
        pore, periodic=PERIODIC, settings=Settings(cell_voxels=[size], surface=False, lambda_max_cells=1)
    )
    # Var φ(L) = φ(1-φ)/L³ for independent voxels. The sample variance of ~ (n/L)³ independent cells has a relative
    # standard error sqrt(2/(n/L)³); allow 4 of them (plus the sample's own φ̄ fluctuation, far smaller).
    rtol = 4 * np.sqrt(2 / (n / size) ** 3)
    np.testing.assert_allclose(ds.phi_var.item(), phi * (1 - phi) / size**3, rtol=rtol)


def test_direction_ordering(random_ds):
    _, ds = random_ds
    lam = ds["lambda"]
    defined = ds.lambda_cells > 0
    for axis in ("x", "y", "z"):
        # λ_c >= λ_axis >= λ_3 bin by bin (as counts, which is the same and avoids NaN), and for p
        assert (ds.percolating.sel(alpha="c") >= ds.percolating.sel(alpha=axis)).all()
        assert (ds.percolating.sel(alpha=axis) >= ds.percolating.sel(alpha="3")).all()
        assert (ds.p.sel(alpha="c") >= ds.p.sel(alpha=axis)).all()
        assert (ds.p.sel(alpha=axis) >= ds.p.sel(alpha="3")).all()
    assert np.isfinite(lam.where(defined)).sum() == 5 * int(
        defined.sum()
    )  # λ defined exactly where cells exist
    assert np.isnan(lam.where(~defined, 0.0)).sum() == 5 * int((~defined).sum())


def test_p_is_lambda_weighted_by_mu_eq_4_6_6(random_ds):
    _, ds = random_ds
    # with lambda_stride = 1 the percolation cells are the μ cells, so p = Σ_φ λ(φ, L) μ(φ, L)
    assert np.array_equal(ds.lambda_cells.values, ds.cells.values)
    np.testing.assert_allclose((ds["lambda"].fillna(0.0) * ds.mu).sum("bin"), ds.p, rtol=1e-12)


def test_characteristic_length_eq_4_6_4(random_ds):
    pore, ds = random_ds

    def has_pure_cell(size):  # brute force with numpy windows on the wrapped volume
        padded = np.pad(pore, (0, size - 1), mode="wrap")
        k = np.lib.stride_tricks.sliding_window_view(padded, (size,) * 3).sum(axis=(3, 4, 5))
        return bool((k == 0).any() or (k == size**3).any())

    assert ds.attrs["L_star"] == min(int(L) for L in ds.L.values if not has_pure_cell(int(L)))
    assert characteristic_length([4, 2, 8], [0, 3, 0], [1, 0, 0]) == 8
    assert characteristic_length([2], [1], [0]) == 0


@pytest.mark.parametrize("size", [2, 5, 12])
def test_mean_local_surface_is_the_global_face_estimate(size):
    pore = random_pore((12, 14, 16), 0.4, 3)
    voxel_um = 2.5
    ds = local_porosity_analysis(
        pore, voxel_um=voxel_um, periodic=PERIODIC, settings=Settings(cell_voxels=[size], lambda_max_cells=1)
    )
    # periodic, all positions: a face lies inside L²(L-1) of the N cells, so the mean face count per cell is
    # F L²(L-1)/N and mean S_V = (2/3) F L²(L-1) / (N L³ a) = (1 - 1/L) * (2/3) F / (N a)  (counted here by np.roll)
    faces = sum(int(np.count_nonzero(pore != np.roll(pore, 1, axis=a))) for a in range(3))
    global_sv = (2 / 3) * faces / (pore.size * voxel_um)
    np.testing.assert_allclose(ds.sv_mean_per_um.item(), (1 - 1 / size) * global_sv, rtol=1e-12)


def test_local_surface_of_a_plane():
    pore = np.zeros((16, 8, 8), np.uint8)
    pore[:8] = 1  # pore half-space; with wrapping the interfaces are the planes x = 8 and x = 0
    ds = local_porosity_analysis(
        pore, voxel_um=0.5, periodic=PERIODIC, settings=Settings(cell_voxels=[4], lambda_max_cells=1)
    )
    # a cell of L = 4 holds one whole plane (16 faces) for 2 * 3 of the 16 x origins, else none:
    # S_V = (2/3) * 16 / (4³ * 0.5 µm) = 1/3 µm⁻¹ on 6/16 of the cells
    sv = ds.sv_per_um.values[0]
    mu = ds.mu_sv.values[0]
    np.testing.assert_allclose(mu[np.isclose(sv, 1 / 3, rtol=1e-12)].sum(), 6 / 16, rtol=1e-12)
    np.testing.assert_allclose(mu[sv == 0].sum(), 10 / 16, rtol=1e-12)
