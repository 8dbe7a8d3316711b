"""The pair gather's prefetch (_prefetch_row): compiled into a real prefetch instruction, and without effect on
what the gather copies, also where the look-ahead runs past the end of the list.
"""

import numpy as np
from numba import njit

from porepipe.packing import _kernels as K


@njit(cache=False)
def _prefetch_every_row(rows):
    for i in range(rows.shape[0]):
        K._prefetch_row(rows, i)
    return rows.shape[0]


def test_prefetch_row_compiles_to_a_prefetch_instruction_and_changes_nothing():
    rows = np.arange(24.0).reshape(3, 8)
    before = rows.copy()
    assert _prefetch_every_row(rows) == 3
    assert np.array_equal(rows, before)
    assert "prefetch" in _prefetch_every_row.inspect_asm(_prefetch_every_row.signatures[0])


def test_gather_with_look_ahead_past_the_list_end_copies_the_pairs():
    # a list far shorter than _PREFETCH_AHEAD: every look-ahead is clamped to the last entry
    rng = np.random.default_rng(3)
    n = 40
    xr = K.work_array(n)
    xr[:, :4] = rng.random((n, 4))
    half_start = np.arange(0, 2 * n + 1, 2, dtype=np.int64)
    half_idx = rng.integers(0, n, 2 * n).astype(np.int64)
    assert half_idx.size < K._PREFETCH_AHEAD
    table = np.ones((1, 1))
    w = np.zeros((K._ROWS, 2 * n))
    k = 0
    for i in range(n):
        k = K._gather_pairs(
            i, half_start, half_idx, xr, np.zeros(n, np.int64), table, table, table, w, k, True
        )
    owner = np.repeat(np.arange(n), 2)
    assert k == 2 * n
    assert np.array_equal(w[K._D0 : K._D0 + 3].T, xr[owner, :3] - xr[half_idx, :3])
    assert np.array_equal(w[K._RI], xr[owner, 3]) and np.array_equal(w[K._RJ], xr[half_idx, 3])
