"""Numba kernels of the 2x2x2 configuration histogram (Ohser & Mücklich 2000, ch. 4; Schladitz et al. 2006).

A cell is the 2x2x2 block of voxels with lower corner (i, j, k). Its 8-bit code has bit ``dx + 2*dy + 4*dz`` set when
voxel (i+dx, j+dy, k+dz) is foreground (non-zero). Axis order is (x, y, z) = array axes (0, 1, 2), z contiguous.

Per cell row (fixed i, j) the codes are first written to a byte buffer in one branch-free loop that vectorises:
``q[k] = v(i,j,k) | v(i+1,j,k) << 1 | v(i,j+1,k) << 2 | v(i+1,j+1,k) << 3`` (the 2x2 column) and
``code = q[k] | q[k+1] << 4``. The buffer is then counted 8 codes per 64-bit word into eight interleaved
sub-histograms (byte b of the word into sub-histogram b), so that runs of one code do not serialise on one counter;
a word of eight pure cells (code 0 or 255 throughout, the bulk of a porous medium) is counted with one addition.
All counters are int64.
"""

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH

N_CODES = 256
_LANES = 8
_ALL_FULL = 0xFFFFFFFFFFFFFFFF  # eight cells of code 255


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _column(a0, a1, b0, b1, k):
    """2x2 column code of index ``k``: bit 0/1 = rows ``a0``/``a1`` (x pair at y), bit 2/3 = ``b0``/``b1`` (at y+1)."""
    return (
        np.uint8(a0[k] != 0)
        | (np.uint8(a1[k] != 0) << np.uint8(1))
        | (np.uint8(b0[k] != 0) << np.uint8(2))
        | (np.uint8(b1[k] != 0) << np.uint8(3))
    )


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _row_codes(a0, a1, b0, b1, wrap_z, code):
    """Cell codes of one row into ``code[:n]``; returns n (nz with ``wrap_z``, else nz - 1).

    ``a0, a1`` are row y of planes x and x+1, ``b0, b1`` row y+1 of the same planes (each length nz).
    """
    nz = a0.shape[0]
    for k in range(nz - 1):
        code[k] = _column(a0, a1, b0, b1, k) | (_column(a0, a1, b0, b1, k + 1) << np.uint8(4))
    if not wrap_z:
        return nz - 1
    code[nz - 1] = _column(a0, a1, b0, b1, nz - 1) | (_column(a0, a1, b0, b1, 0) << np.uint8(4))
    return nz


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _count_codes(code, n, lanes):
    """Add ``code[:n]`` to ``lanes`` (8, 256): byte b of each 64-bit word to lane b, a pure word in one addition.

    ``code`` is padded to a multiple of 8 bytes; the ``n % 8`` codes after the last whole word go to lane 0.
    """
    words = code.view(np.uint64)
    n_words = n >> 3
    for t in range(n_words):
        w = words[t]
        if w == 0 or w == _ALL_FULL:
            lanes[0, w & np.uint64(255)] += 8
            continue
        for b in range(_LANES):
            lanes[b, (w >> np.uint64(8 * b)) & np.uint64(255)] += 1
    for k in range(n_words << 3, n):
        lanes[0, code[k]] += 1


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _configuration_histogram(volume, wrap_x, wrap_y, wrap_z, n_blocks, out):
    """Add the configuration histogram of ``volume`` (nx, ny, nz) to ``out`` (256,) int64.

    Cells between consecutive x planes of ``volume`` are counted, plus the pair (last, first) when ``wrap_x``; along
    y and z the last cell wraps to index 0 when ``wrap_y`` / ``wrap_z``. The x-plane pairs are split into ``n_blocks``
    contiguous blocks run in parallel, each with its own (8, 256) counters, reduced after the loop.
    """
    nx, ny, nz = volume.shape
    n_pairs = nx - 1 + (1 if wrap_x else 0)
    n_rows = ny - 1 + (1 if wrap_y else 0)
    partial = np.zeros((n_blocks, _LANES, N_CODES), dtype=np.int64)
    for b in prange(n_blocks):
        code = np.empty(((nz + 7) // 8) * 8, dtype=np.uint8)
        start = (n_pairs * b) // n_blocks
        stop = (n_pairs * (b + 1)) // n_blocks
        for i in range(start, stop):
            plane0 = volume[i]
            plane1 = volume[i + 1 if i + 1 < nx else 0]
            for j in range(n_rows):
                j1 = j + 1 if j + 1 < ny else 0
                n = _row_codes(plane0[j], plane1[j], plane0[j1], plane1[j1], wrap_z, code)
                _count_codes(code, n, partial[b])
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
