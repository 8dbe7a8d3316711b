"""Box-sum histograms of the lpt stage against a slow, obviously-right cell-by-cell count."""

import numpy as np
import pytest

from porepipe.lpt import _api as A


def naive_cells(pore, size, wrap, stride):
    """Every cell cut out with np.ix_ (wrapping by modulo), in C order of the origins."""
    npos = [n if w else n - size + 1 for n, w in zip(pore.shape, wrap)]
    out = []
    for x in range(0, npos[0], stride):
        for y in range(0, npos[1], stride):
            for z in range(0, npos[2], stride):
                idx = [(o + np.arange(size)) % n for o, n in zip((x, y, z), pore.shape)]
                out.append(pore[np.ix_(*idx)])
    return out


def naive_faces(cell):
    """Faces between a pore and a matrix voxel with both voxels in the cell."""
    return sum(int(np.count_nonzero(np.diff(cell.astype(np.int8), axis=a))) for a in range(3))


@pytest.fixture(scope="module")
def pore():
    rng = np.random.default_rng(11)
    return (rng.random((13, 11, 9)) < 0.4).astype(np.uint8)


WRAPS = [(False, False, False), (True, True, True), (True, False, True)]


@pytest.mark.parametrize("wrap", WRAPS)
@pytest.mark.parametrize("size", [1, 2, 4, 9])
@pytest.mark.parametrize("stride", [1, 3])
def test_porosity_histogram_is_exact_count(pore, wrap, size, stride):
    cells = naive_cells(pore, size, wrap, stride)
    k = np.array([c.sum() for c in cells])
    h = A.local_porosity_histogram(pore, size, wrap=wrap, stride=stride, record_stride=stride)
    # integer counts: exact equality is the only right answer
    assert np.array_equal(h.counts, np.bincount(k, minlength=size**3 + 1))
    assert np.array_equal(h.records, k)
    assert h.exact and h.n_cells == len(cells)
    assert h.k_sq_sum == pytest.approx(float((k.astype(float) ** 2).sum()), rel=1e-15)  # integers < 2^53


@pytest.mark.parametrize("wrap", WRAPS[:2])
@pytest.mark.parametrize("size", [2, 5])
def test_surface_histogram_counts_inner_faces(pore, wrap, size):
    cells = naive_cells(pore, size, wrap, 1)
    f = np.array([naive_faces(c) for c in cells])
    h = A.local_surface_histogram(pore, size, wrap=wrap)
    assert np.array_equal(h.counts, np.bincount(f, minlength=3 * size**2 * (size - 1) + 1))
    assert int(h.k_sum.sum()) == int(f.sum())


@pytest.mark.parametrize("k_max,n_bins", [(64, 10), (729, 101), (10, 3), (1000, 1001), (8, 9)])
def test_bins_partition_the_counts(k_max, n_bins):
    lo, hi = A.bin_ranges(k_max, n_bins)
    # bins are contiguous, non-empty, cover 0..k_max, and 0 and k_max are alone in theirs
    assert lo[0] == hi[0] == 0 and lo[-1] == hi[-1] == k_max
    assert np.all(hi >= lo) and np.array_equal(lo[1:], hi[:-1] + 1)
    k = np.arange(k_max + 1)
    assert np.array_equal(A.bins_of(k, k_max, n_bins), np.repeat(np.arange(n_bins), hi - lo + 1))


def test_binned_histogram_is_the_exact_one_summed(pore):
    exact = A.local_porosity_histogram(pore, 4, wrap=(True, True, True))
    binned = A.local_porosity_histogram(pore, 4, wrap=(True, True, True), max_bins=10)
    assert not binned.exact and binned.counts.size == 10
    bins = A.bins_of(np.arange(65), 64, 10)
    assert np.array_equal(binned.counts, np.bincount(bins, weights=exact.counts).astype(np.int64))
    assert np.array_equal(binned.k_sum, np.bincount(bins, weights=exact.k_sum).astype(np.int64))


def test_large_window_uses_wide_ring():
    # a 256 x 256 slice sum (65536) overflows uint16; the kernel must switch to uint32 slice sums
    pore = np.ones((1, 256, 256), np.uint8)
    h = A._box_histogram(
        pore[None], np.array([[1, 256, 256]]), A.CellGrid(1, (1, 256, 256), (False, True, True)), 1, None
    )
    assert h.k_max == 256 * 256 and h.counts[-1] == 256 * 256 and h.counts[:-1].sum() == 0
