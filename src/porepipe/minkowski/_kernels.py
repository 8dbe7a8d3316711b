"""Numba kernels of the 2x2x2 configuration histogram (Ohser & Mücklich 2000, ch. 4; Schladitz et al. 2006).

A cell is the 2x2x2 block of voxels with lower corner (i, j, k). Its 8-bit code has bit ``dx + 2*dy + 4*dz`` set when
voxel (i+dx, j+dy, k+dz) is foreground (non-zero). Axis order is (x, y, z) = array axes (0, 1, 2), z contiguous.

The code is built with a rolling scheme that loads every voxel of a plane pair once per row pair:
``p[k] = v(i,j,k) | v(i+1,j,k) << 1`` (x pair), ``q[k] = p_j[k] | p_{j+1}[k] << 2`` (2x2 column), and
``code = q[k] | q[k+1] << 4``, so the x-pair row ``p_{j+1}`` is reused as ``p_j`` of the next row and the column code
``q[k+1]`` is reused along z. Counts go to four interleaved sub-histograms (cell index mod 4) so that runs of the same
code (large pure regions) do not serialise on one counter; all counters are int64.
"""

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH

N_CODES = 256
_LANES = 4


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _xpair(row0, row1, out):
    """``out[k] = (row0[k] != 0) | (row1[k] != 0) << 1`` for one row of two x-adjacent planes."""
    for k in range(out.shape[0]):
        out[k] = np.uint8(row0[k] != 0) | (np.uint8(row1[k] != 0) << np.uint8(1))


@njit(cache=True, fastmath=FASTMATH)
def _count_row(p_lo, p_hi, q, wrap_z, lanes):
    """Add the cells of one row (fixed i, j) to ``lanes``; ``q`` is scratch of the row length."""
    nz = q.shape[0]
    for k in range(nz):
        q[k] = p_lo[k] | (p_hi[k] << np.uint8(2))
    for k in range(nz - 1):
        lanes[k & 3, q[k] | (q[k + 1] << np.uint8(4))] += 1
    if wrap_z:
        lanes[(nz - 1) & 3, q[nz - 1] | (q[0] << np.uint8(4))] += 1


@njit(cache=True, fastmath=FASTMATH)
def _count_plane_pair(plane0, plane1, wrap_y, wrap_z, p_first, p_lo, p_hi, q, lanes):
    """Add all cells between two x-adjacent planes (each (ny, nz)) to ``lanes`` (4, 256)."""
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


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _configuration_histogram(volume, wrap_x, wrap_y, wrap_z, n_blocks, out):
    """Add the configuration histogram of ``volume`` (nx, ny, nz) to ``out`` (256,) int64.

    Cells between consecutive x planes of ``volume`` are counted, plus the pair (last, first) when ``wrap_x``; along
    y and z the last cell wraps to index 0 when ``wrap_y`` / ``wrap_z``. The x-plane pairs are split into ``n_blocks``
    contiguous blocks run in parallel, each with its own (4, 256) counters, reduced after the loop.
    """
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


@njit(cache=True, fastmath=FASTMATH)
def _sort_cell(values, order):
    """Insertion sort of the 8 grey values of a cell; ``order`` receives the vertex (bit) indices."""
    for v in range(8):
        order[v] = v
    for a in range(1, 8):
        key = values[a]
        idx = order[a]
        b = a - 1
        while b >= 0 and values[b] > key:
            values[b + 1] = values[b]
            order[b + 1] = order[b]
            b -= 1
        values[b + 1] = key
        order[b + 1] = idx


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _threshold_histograms(grey, wrap_x, wrap_y, wrap_z, n_blocks, out):
    """Add to ``out`` (n_levels, 256) int64 the change of the configuration histogram at every threshold.

    Foreground at threshold t is ``grey <= t``. For each cell the code grows from 0 (t below every grey value) by
    the vertices in ascending grey order; at each distinct grey value g one count moves from the old code to the new
    one in row g. The histogram at threshold t is then ``N_cells * [code == 0] + cumsum(out, axis=0)[t]``.
    Grey values >= n_levels never become foreground within the table.
    """
    nx, ny, nz = grey.shape
    n_levels = out.shape[0]
    n_pairs = nx - 1 + (1 if wrap_x else 0)
    ncy = ny - 1 + (1 if wrap_y else 0)
    ncz = nz - 1 + (1 if wrap_z else 0)
    partial = np.zeros((n_blocks, n_levels, N_CODES), dtype=np.int64)
    for b in prange(n_blocks):
        values = np.empty(8, dtype=np.int64)
        order = np.empty(8, dtype=np.int64)
        start = (n_pairs * b) // n_blocks
        stop = (n_pairs * (b + 1)) // n_blocks
        table = partial[b]
        for i in range(start, stop):
            i1 = i + 1 if i + 1 < nx else 0
            for j in range(ncy):
                j1 = j + 1 if j + 1 < ny else 0
                for k in range(ncz):
                    k1 = k + 1 if k + 1 < nz else 0
                    values[0] = grey[i, j, k]
                    values[1] = grey[i1, j, k]
                    values[2] = grey[i, j1, k]
                    values[3] = grey[i1, j1, k]
                    values[4] = grey[i, j, k1]
                    values[5] = grey[i1, j, k1]
                    values[6] = grey[i, j1, k1]
                    values[7] = grey[i1, j1, k1]
                    _sort_cell(values, order)
                    code = 0
                    v = 0
                    while v < 8:
                        g = values[v]
                        if g >= n_levels:
                            break
                        old = code
                        while v < 8 and values[v] == g:
                            code |= 1 << order[v]
                            v += 1
                        table[g, old] -= 1
                        table[g, code] += 1
    for b in range(n_blocks):
        out += partial[b]


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _touch_all(volume, n_blocks):
    """Read every byte of ``volume`` once (sum of the bytes): the memory-bandwidth floor of one pass."""
    nx = volume.shape[0]
    sums = np.zeros(n_blocks, dtype=np.int64)
    for b in prange(n_blocks):
        start = (nx * b) // n_blocks
        stop = (nx * (b + 1)) // n_blocks
        s = 0
        for i in range(start, stop):
            plane = volume[i]
            for j in range(plane.shape[0]):
                row = plane[j]
                for k in range(row.shape[0]):
                    s += row[k]
        sums[b] = s
    return sums.sum()
