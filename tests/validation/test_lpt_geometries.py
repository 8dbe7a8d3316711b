"""Geometries whose local percolation is known: channels, closed pockets, random site percolation."""

import numpy as np
import pytest

from porepipe.lpt import Settings, local_porosity_analysis

PERIODIC = (True, True, True)


def analyse(pore, sizes, **kw):
    settings = Settings(cell_voxels=sizes, surface=False, **kw)
    return local_porosity_analysis(pore, periodic=PERIODIC, settings=settings)


@pytest.mark.parametrize("connectivity", [6, 26])
def test_straight_channels_along_x(connectivity):
    pore = np.zeros((18, 18, 18), np.uint8)
    pore[:, 2::6, 3::6] = 1  # straight lines of pore along x, 5 matrix voxels apart in y and z
    ds = analyse(pore, [6, 12, 18], lambda_stride=1, connectivity=connectivity)
    # every cell of L >= 6 contains a whole channel: spans x; nothing joins the y or z faces
    np.testing.assert_array_equal(ds.p.sel(alpha="x"), 1.0)
    np.testing.assert_array_equal(ds.p.sel(alpha="c"), 1.0)
    for alpha in ("y", "z", "3"):
        np.testing.assert_array_equal(ds.p.sel(alpha=alpha), 0.0)


@pytest.mark.parametrize("connectivity", [6, 26])
def test_closed_pockets_never_percolate(connectivity):
    pore = np.zeros((20, 20, 20), np.uint8)
    for i in range(2):
        for j in range(2):
            for k in range(2):
                pore[i::5, j::5, k::5] = 1  # 2x2x2 pockets, 3 matrix voxels apart (not even corner contact)
    ds = analyse(pore, [2, 3, 4, 7, 10, 20], lambda_stride=1, connectivity=connectivity)
    # a pocket is 2 voxels wide, so no cell of L >= 3 can be crossed
    np.testing.assert_array_equal(ds.p.sel(L=[3, 4, 7, 10, 20]), 0.0)
    # L = 2, counted by hand over the 5^3 origins of one period: along an axis the cell either matches the pocket
    # (1 origin) or overlaps it by one voxel (2 origins). A cell spans axis a iff it matches along a and overlaps
    # along the other two: x, y, z each 1*3*3 = 9; all three 1; at least one 3^3 - 2^3 = 19.
    expected = {"x": 9, "y": 9, "z": 9, "3": 1, "c": 19}
    for alpha, count in expected.items():
        np.testing.assert_allclose(ds.p.sel(L=2, alpha=alpha), count / 125, rtol=1e-14)


SITE_PC_6 = (
    0.3116  # site percolation threshold, simple cubic lattice, 6 neighbours (e.g. Wang et al. 2013: 0.311608)
)


@pytest.mark.slow
def test_random_voxels_step_at_site_percolation_threshold():
    sizes = [8, 16, 32]
    p = {}
    for phi in (SITE_PC_6 - 0.04, SITE_PC_6 + 0.04):
        pore = (np.random.default_rng(7).random((64, 64, 64)) < phi).astype(np.uint8)
        ds = analyse(pore, sizes, lambda_stride=8, directions=["x", "3"], max_bins=3)
        p[phi] = ds.p
    below, above = p[SITE_PC_6 - 0.04], p[SITE_PC_6 + 0.04]
    for alpha in ("x", "3"):
        # the crossover sharpens with L: below p_c the fraction falls towards 0, above it rises towards 1
        lo, hi = below.sel(alpha=alpha).values, above.sel(alpha=alpha).values
        assert np.all(np.diff(lo) <= 0) and lo[0] > lo[-1]
        assert np.all(np.diff(hi) >= 0) and hi[0] < hi[-1]
    # at L = 32 the curve is nearly a step (finite-size width ~ L^(-1/nu) = 32^(-1.14) ~ 0.02 < 0.04);
    # 0.1 / 0.9 margins leave room for the ~64-cell sampling noise (independent cells: (64/32)^3 = 8 per sample)
    assert below.sel(L=32, alpha="x") < 0.1 and below.sel(L=32, alpha="3") < 0.1
    assert above.sel(L=32, alpha="x") > 0.9 and above.sel(L=32, alpha="3") > 0.7


def test_26_connectivity_percolates_far_below_the_6_threshold():
    # site threshold with 26 neighbours is ~0.0976 (simple cubic, NN+2NN+3NN); at φ = 0.2 cells of L = 16 span
    # with 26-connected paths but essentially never with 6-connected ones (0.2 << 0.3116)
    pore = (np.random.default_rng(8).random((48, 48, 48)) < 0.2).astype(np.uint8)
    p6 = analyse(pore, [16], lambda_stride=8, directions=["x"]).p.item()
    p26 = analyse(pore, [16], lambda_stride=8, directions=["x"], connectivity=26).p.item()
    assert p6 < 0.05 and p26 > 0.95
