"""Statistics kernels against slow, obviously-right references written here, and closed forms."""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.acquire import _stats


def _naive_chords(pore, axis):
    """Complete runs (not touching either end) along ``axis``: dict (phase, length) -> count."""
    out = {}
    lines = np.moveaxis(pore, axis, -1).reshape(-1, pore.shape[axis])
    for line in lines:
        runs, start = [], 0
        for k in range(1, len(line) + 1):
            if k == len(line) or line[k] != line[start]:
                runs.append((int(line[start] != 0), start, k))
                start = k
        for phase, a, b in runs:
            if a > 0 and b < len(line):
                out[(phase, b - a)] = out.get((phase, b - a), 0) + 1
    return out


@pytest.fixture
def random_pore():
    return (np.random.default_rng(21).random((9, 11, 13)) < 0.45).astype(np.uint8)


def test_chords_match_naive_run_counting(random_pore):
    ds = _stats.chord_lengths(random_pore, voxel_um=2.0)
    for ax in range(3):
        naive = _naive_chords(random_pore, ax)
        counts = ds.chord_count.isel(axis=ax).values
        got = {(p, int(n)): int(counts[p, n]) for p in (0, 1) for n in np.flatnonzero(counts[p])}
        assert got == naive


def test_chord_surface_density_of_slabs():
    # slabs normal to x of width 4 with period 8: 2 interfaces per 8 voxels along x -> S_V = 2 P_L = 0.5/voxel
    pore = np.zeros((64, 4, 4), np.uint8)
    pore[np.arange(64) % 8 < 4] = 1
    ds = _stats.chord_lengths(pore, voxel_um=1.0)
    # P_L counts changes per voxel pair: 15 changes in 63 pairs of each line
    assert float(ds.S_V_chord_per_mm.sel(axis="x")) == pytest.approx(2 * 15 / 63 * 1000, rel=1e-12)
    assert float(ds.S_V_chord_per_mm.sel(axis="y")) == 0.0
    assert float(ds.mean_chord_um.sel(axis="x", chord_phase="pore")) == 4.0


def test_two_point_matches_direct_products(random_pore):
    tp = _stats.two_point_correlation(random_pore, 1.0, max_lag=6)
    p = random_pore.astype(np.int64)
    for ax in range(3):
        for r in range(7):
            n = p.shape[ax]
            a = np.take(p, np.arange(0, n - r), axis=ax)
            b = np.take(p, np.arange(r, n), axis=ax)
            assert float(tp.isel(axis=ax, lag=r)) == pytest.approx((a * b).mean(), abs=1e-12)


def test_label_moments_match_numpy():
    rng = np.random.default_rng(2)
    labels = rng.integers(0, 4, size=(6, 7, 8)).astype(np.int32)
    shapes = _stats.grain_shapes(labels, 3)
    for lab in (1, 2, 3):
        pts = np.argwhere(labels == lab) + 0.5
        assert shapes["volume_vox"][lab - 1] == len(pts)
        np.testing.assert_allclose(shapes["centroid_vox"][lab - 1], pts.mean(axis=0), rtol=1e-12)
        cov = np.cov(pts.T, bias=True) + np.eye(3) / 12
        np.testing.assert_allclose(shapes["moments"][lab - 1], np.linalg.eigvalsh(cov), rtol=1e-9, atol=1e-12)


def test_box_grain_elongation_and_orientation():
    # a 2 x 2 x 12 voxel bar: continuous second moments (1/3, 1/3, 12) -> elongation 1 - sqrt(1/36); long axis x
    solid = np.zeros((20, 8, 8), bool)
    solid[4:16, 3:5, 3:5] = True
    labels = solid.astype(np.int32)
    shapes = _stats.grain_shapes(labels, 1)
    np.testing.assert_allclose(shapes["moments"][0], [1 / 3, 1 / 3, 12.0], rtol=1e-12)
    np.testing.assert_allclose(np.abs(shapes["axes"][0][:, 2]), [1, 0, 0], atol=1e-12)


def test_percolation_of_a_tube_along_x():
    pore = np.zeros((10, 9, 9), np.uint8)
    pore[:, 4, 4] = 1  # spans x
    pore[2:5, 1:3, 1:3] = 1  # isolated blob
    ds = _stats.percolation(pore)
    np.testing.assert_allclose(ds.connected_porosity.values, [10 / pore.size, 0, 0])
    assert int(ds.n_pore_clusters) == 2
    assert float(ds.largest_cluster) == pytest.approx(12 / pore.size)
    assert float(ds.largest_percolating_cluster) == pytest.approx(10 / pore.size)


def test_3d_statistics_refuse_a_section():
    with pytest.raises(PorepipeError, match="needs a 3-D image"):
        _stats.percolation(np.zeros((5, 5, 1), np.uint8))


def test_central_grain_window():
    from porepipe.acquire._api import central_window

    assert central_window((512, 512, 512), 256**3) == (slice(128, 384),) * 3
    assert central_window((10, 10, 10), 0) == (slice(0, 10),) * 3
    win = central_window((400, 200, 100), 10**6)
    assert np.prod([w.stop - w.start for w in win]) <= 10**6


def test_coarsen_pore_block_rule_against_loops():
    from porepipe.acquire._api import coarsen_pore

    pore = (np.random.default_rng(9).random((9, 8, 7)) < 0.5).astype(np.uint8)
    got = coarsen_pore(pore, 2)
    assert got.shape == (4, 4, 3)
    for i, j, k in np.ndindex(got.shape):
        block = pore[2 * i : 2 * i + 2, 2 * j : 2 * j + 2, 2 * k : 2 * k + 2]
        assert got[i, j, k] == (block.sum() > 4)  # less than half matrix
