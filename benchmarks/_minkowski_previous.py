"""The configuration-histogram kernel before issue 22 (commit 19bb866), kept only as the benchmark's baseline.

``benchmarks/minkowski.py`` times it beside the current kernel in the same process (and asserts equal counts), so
the speed-up is measured under one machine load. Rolling x-pair rows, a 4-bit column per z index and one int64
increment per cell into four interleaved sub-histograms (cell index mod 4).
"""

import numpy as np
from numba import njit, prange

N_CODES = 256
_LANES = 4


@njit(cache=True, inline="always")
def _xpair(row0, row1, out):
    for k in range(out.shape[0]):
        out[k] = np.uint8(row0[k] != 0) | (np.uint8(row1[k] != 0) << np.uint8(1))


@njit(cache=True)
def _count_row(p_lo, p_hi, q, wrap_z, lanes):
    nz = q.shape[0]
    for k in range(nz):
        q[k] = p_lo[k] | (p_hi[k] << np.uint8(2))
    for k in range(nz - 1):
        lanes[k & 3, q[k] | (q[k + 1] << np.uint8(4))] += 1
    if wrap_z:
        lanes[(nz - 1) & 3, q[nz - 1] | (q[0] << np.uint8(4))] += 1


@njit(cache=True)
def _count_plane_pair(plane0, plane1, wrap_y, wrap_z, p_first, p_lo, p_hi, q, lanes):
    ny = plane0.shape[0]
    _xpair(plane0[0], plane1[0], p_lo)
    if wrap_y:
        p_first[:] = p_lo
    for j in range(ny - 1):
        _xpair(plane0[j + 1], plane1[j + 1], p_hi)
        _count_row(p_lo, p_hi, q, wrap_z, lanes)
        p_lo, p_hi = p_hi, p_lo
    if wrap_y:
        _count_row(p_lo, p_first, q, wrap_z, lanes)


@njit(cache=True, parallel=True)
def previous_histogram(volume, wrap_x, wrap_y, wrap_z, n_blocks, out):
    """Add the configuration histogram of ``volume`` to ``out`` (256,) int64, as porepipe did before issue 22."""
    nx, ny, nz = volume.shape
    n_pairs = nx - 1 + (1 if wrap_x else 0)
    partial = np.zeros((n_blocks, _LANES, N_CODES), dtype=np.int64)
    for b in prange(n_blocks):
        p_first = np.empty(nz, dtype=np.uint8)
        p_lo = np.empty(nz, dtype=np.uint8)
        p_hi = np.empty(nz, dtype=np.uint8)
        q = np.empty(nz, dtype=np.uint8)
        start = (n_pairs * b) // n_blocks
        stop = (n_pairs * (b + 1)) // n_blocks
        for i in range(start, stop):
            i1 = i + 1 if i + 1 < nx else 0
            _count_plane_pair(volume[i], volume[i1], wrap_y, wrap_z, p_first, p_lo, p_hi, q, partial[b])
    for b in range(n_blocks):
        for lane in range(_LANES):
            for c in range(N_CODES):
                out[c] += partial[b, lane, c]
