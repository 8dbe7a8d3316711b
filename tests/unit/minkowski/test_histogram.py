"""The configuration-histogram kernels against np.roll references (exact integer equality)."""

import itertools

import numba
import numpy as np
import pytest
from naive_minkowski import histogram_naive

from porepipe.minkowski import (
    configuration_histogram,
    configuration_histogram_slabs,
    iter_slabs,
    n_cells,
    threshold_histograms,
)

SHAPES = [(5, 6, 7), (2, 3, 9), (1, 4, 4), (4, 1, 3), (3, 5, 1), (1, 1, 1), (9, 2, 2), (17, 13, 33)]
FLAGS = list(itertools.product((False, True), repeat=3))


def _valid(shape, periodic):
    return all(n >= 2 or w for n, w in zip(shape, periodic))


@pytest.mark.parametrize("shape", SHAPES)
def test_histogram_matches_roll_reference(shape):
    rng = np.random.default_rng(sum(shape))
    volume = (rng.random(shape) < 0.45).astype(np.uint8) * rng.integers(1, 255, shape, dtype=np.uint8)
    for periodic in FLAGS:
        if not _valid(shape, periodic):
            continue
        hist = configuration_histogram(volume, periodic)
        np.testing.assert_array_equal(hist, histogram_naive(volume, periodic), err_msg=f"{shape} {periodic}")
        assert hist.sum() == n_cells(shape, periodic)
        assert hist.dtype == np.int64


@pytest.mark.parametrize("nz", [1, 2, 7, 8, 9, 15, 16, 17, 24, 33])
def test_pure_words_and_row_tails_match_roll_reference(nz):
    # The counter takes 8 codes per 64-bit word and a word of eight pure cells (code 0 or 255) in one addition: long
    # pure runs broken at every offset within a word, rows whose length is and is not a multiple of 8, and
    # foreground values other than 1 must give the np.roll reference's counts exactly.
    rng = np.random.default_rng(nz)
    shape = (6, 5, nz)
    volume = np.zeros(shape, np.uint8)
    volume[:, :3] = rng.choice(np.array([1, 2, 255], np.uint8), size=(6, 3, nz))  # pure foreground blocks
    for j in range(5):  # a short run of the other phase at offset j, length j + 1
        volume[j % 6, j, j % nz : j % nz + 1 + j] = 0
    volume[5, 4, rng.integers(0, nz)] = 7
    for periodic in FLAGS:
        if _valid(shape, periodic):
            hist = configuration_histogram(volume, periodic)
            np.testing.assert_array_equal(
                hist, histogram_naive(volume, periodic), err_msg=f"nz={nz} {periodic}"
            )


@pytest.mark.parametrize("value", [0, 1, 200])
def test_uniform_volume_is_one_code(value):
    # every cell of an all-matrix (all-pore) volume is code 0 (255): the pure-word path alone
    volume = np.full((4, 3, 19), value, np.uint8)
    hist = configuration_histogram(volume, (True, False, True))
    assert hist[255 if value else 0] == n_cells(volume.shape, (True, False, True)) == hist.sum()


def test_bool_input_and_thread_counts_agree():
    rng = np.random.default_rng(3)
    volume = rng.random((23, 19, 40)) < 0.3
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = configuration_histogram(volume, (True, False, True))
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = configuration_histogram(volume, (True, False, True))
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one, many)
    np.testing.assert_array_equal(one, histogram_naive(volume, (True, False, True)))


@pytest.mark.parametrize("thickness", [1, 2, 5, 64])
@pytest.mark.parametrize("periodic", [True, False, (True, False, False)])
def test_slabs_add_up_to_whole_volume(thickness, periodic):
    # Histograms of chunks that share one voxel layer add up exactly (integer equality).
    rng = np.random.default_rng(thickness)
    volume = (rng.random((13, 8, 11)) < 0.5).astype(np.uint8)
    hist, shape = configuration_histogram_slabs(iter_slabs(volume, thickness), periodic)
    assert shape == volume.shape
    np.testing.assert_array_equal(hist, configuration_histogram(volume, periodic))


@pytest.mark.parametrize("periodic", [True, False])
def test_threshold_histograms_match_thresholding(periodic):
    # one pass over a grey volume == the binary histogram of grey <= t for every t
    rng = np.random.default_rng(11)
    grey = rng.integers(0, 217, (7, 9, 10)).astype(np.uint8)
    grey[2:5, 3:7, 1:9] = 216  # runs of equal values inside cells
    grey[0] = 0
    hists = threshold_histograms(grey, periodic, n_levels=217)
    for t in range(217):
        np.testing.assert_array_equal(hists[t], histogram_naive(grey <= t, (periodic,) * 3), err_msg=f"t={t}")
