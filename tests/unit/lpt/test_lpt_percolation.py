"""Per-cell percolation against scipy.ndimage.label (a brute-force oracle: label, then look at both faces)."""

import numpy as np
import pytest
from scipy import ndimage

from porepipe.lpt import _api as A
from porepipe.lpt import _kernels as K
from porepipe.lpt._settings import Connectivity, Direction


def oracle_bits(cell, connectivity):
    structure = ndimage.generate_binary_structure(3, 1 if connectivity == 6 else 3)
    labels, _ = ndimage.label(cell, structure)
    bits = 0
    for axis in range(3):
        near, far = np.take(labels, 0, axis=axis), np.take(labels, -1, axis=axis)
        if np.intersect1d(near[near > 0], far[far > 0]).size:
            bits |= 1 << axis
    return bits | (K.BIT_ALL if bits == 7 else 0) | (K.BIT_ANY if bits else 0)


@pytest.mark.parametrize("connectivity", [6, 26])
@pytest.mark.parametrize("size", [1, 2, 6, 11])
@pytest.mark.parametrize("phi", [0.12, 0.25, 0.32, 0.5, 0.8])
def test_percolation_matches_labelling(connectivity, size, phi):
    rng = np.random.default_rng(int(1000 * phi) + size + connectivity)
    pore = (rng.random((18, 17, 16)) < phi).astype(np.uint8)
    origins = A.cell_grid(pore.shape, size, (True, True, True)).origins(3)
    bits = A.percolation_bits(pore, size, origins, connectivity=connectivity)
    ref = np.array([oracle_bits(A._cell(pore, o, size), connectivity) for o in origins])
    assert np.array_equal(bits, ref)


@pytest.mark.parametrize(
    "only,mask", [(["3"], K.BIT_ALL), (["c"], K.BIT_ANY), (["y"], K.BIT_Y), (["x", "z"], K.BIT_X | K.BIT_Z)]
)
def test_early_exit_keeps_the_requested_bits(only, mask):
    rng = np.random.default_rng(3)
    pore = (rng.random((20, 20, 20)) < 0.31).astype(np.uint8)
    origins = A.cell_grid(pore.shape, 8).origins(2)
    full = A.percolation_bits(pore, 8, origins)
    part = A.percolation_bits(pore, 8, origins, directions=only)
    assert np.array_equal(part & mask, full & mask)


def test_counts_from_box_sums_equal_counted_ones():
    rng = np.random.default_rng(4)
    pore = (rng.random((16, 16, 16)) < 0.3).astype(np.uint8)
    h = A.local_porosity_histogram(pore, 7, wrap=(True, True, True), record_stride=3)
    origins = A.cell_grid(pore.shape, 7, (True, True, True)).origins(3)
    assert np.array_equal(
        A.percolation_bits(pore, 7, origins, h.records), A.percolation_bits(pore, 7, origins)
    )


@pytest.mark.parametrize("connectivity,n", [(Connectivity.face, 6), (Connectivity.vertex, 26)])
def test_neighbour_steps_end_with_the_straight_step(connectivity, n):
    steps = A.neighbour_steps(connectivity)
    assert steps.shape == (3, n, 3)
    for axis in range(3):
        assert len({tuple(s) for s in steps[axis]}) == n  # each neighbour once
        assert np.array_equal(steps[axis, -1], np.eye(3, dtype=np.int64)[axis])


def test_direction_bits_cover_table_4_1():
    assert {d.value for d in Direction} == {"x", "y", "z", "3", "c"}
