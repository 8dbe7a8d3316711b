"""Numba kernels of the lpt stage (arrays in, preallocated arrays out; no checks, no I/O).

Two kernels carry the stage:

- :func:`_box_sum_histogram` moves a box (a measurement cell) over every position of a grid and sums one or
  more uint8 fields inside it. It is separable and incremental: each x-slice gets its 2-D (y, z) box sums once
  (sliding windows along z, then y), and the 3-D sum follows by adding the slice that enters the box and
  subtracting the one that leaves it. Cost O(N) per cell size, memory one ring of ``wx + batch`` slices.
- :func:`_percolation_cells` decides for many cells whether pore voxels join two opposite faces: a depth-first
  search from one face that always tries the step towards the far face first, and stops as soon as it gets there.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH, by_threads

#: Λ bits in the output of :func:`_percolation_cells`: x, y, z, all three, at least one.
BIT_X, BIT_Y, BIT_Z, BIT_ALL, BIT_ANY = 1, 2, 4, 8, 16

#: what :func:`_percolation_cells` may skip: nothing, the rest after a failing axis, the rest after a spanning axis
STOP_NEVER, STOP_ON_FAIL, STOP_ON_SUCCESS = 0, 1, 2


@njit(cache=True, fastmath=FASTMATH)
def _bin_of(k, k_max, n_bins):
    """Histogram bin of the box sum k in 0..k_max.

    Exact (bin = k) when ``n_bins == k_max + 1``; otherwise k = 0 and k = k_max keep bins 0 and n_bins-1, and
    k = 1..k_max-1 fall evenly into bins 1..n_bins-2.
    """
    if n_bins == k_max + 1:
        return k
    if k <= 0:
        return 0
    if k >= k_max:
        return n_bins - 1
    return 1 + ((k - 1) * (n_bins - 2)) // (k_max - 1)


@njit(cache=True, fastmath=FASTMATH)
def _fill_slice(field, x, wy, wz, my, mz, tmp, out):
    """2-D box sums of the slice ``field[x]``: out[y0, z0] = sum of field[x, y0:y0+wy, z0:z0+wz] (indices wrap).

    ``tmp`` is scratch of shape (my + wy - 1, mz). Wrapping needs at most one turn because wy, wz <= the edge.
    """
    ny = field.shape[1]
    nz = field.shape[2]
    for yy in range(my + wy - 1):
        y = yy if yy < ny else yy - ny
        row = field[x, y]
        s = np.int64(0)
        for z in range(wz):
            s += np.int64(row[z])
        tmp[yy, 0] = s
        for z0 in range(1, mz):
            za = z0 + wz - 1
            if za >= nz:
                za -= nz
            s += np.int64(row[za]) - np.int64(row[z0 - 1])
            tmp[yy, z0] = s
    for z0 in range(mz):
        s = np.int64(0)
        for yy in range(wy):
            s += tmp[yy, z0]
        out[0, z0] = s
    for y0 in range(1, my):
        for z0 in range(mz):
            out[y0, z0] = np.int64(out[y0 - 1, z0]) + tmp[y0 + wy - 1, z0] - tmp[y0 - 1, z0]


#: the low 32 bits of an int64 (the two-word exact sum of k²)
_LOW32 = np.int64(0xFFFFFFFF)


@by_threads(cache=True, fastmath=FASTMATH)
def _box_sum_histogram(fields, wins, npos, ring, hist_stride, k_max, hist, ksum, ksq, rec_stride, rec):
    """Histogram (and optionally record) the box sums of ``fields`` at all grid positions.

    Parameters
    ----------
    fields : (nf, nx, ny, nz) uint8 ndarray
        Fields to sum; the box sum at a position is the total over all fields.
    wins : (nf, 3) int64 ndarray
        Box edge per field and axis (each 1..n along that axis).
    npos : (3,) int64 ndarray
        Number of box origins per axis, starting at 0; origins beyond ``n - w`` wrap around (periodic).
    ring : (nf, n_ring, my, mz) uint16 or uint32 ndarray
        Scratch for 2-D slice sums. The origins advance along x in batches of ``n_ring - max(wins[:, 0]) - 1``:
        one parallel pass computes the batch's new slices, one more moves the box over the batch (threads own
        rows), so there are two parallel launches per batch rather than per origin.
    hist_stride : int
        Histogram the origins that are multiples of it on every axis; 0 = no histogram.
    k_max : int
        Largest possible box sum (sets the binning, see :func:`_bin_of`).
    hist, ksum : (nt, n_bins) int64 ndarray
        Per-thread-block counts and sums of k per bin (added to).
    ksq : (nt, 2) int64 ndarray
        Per-thread-block sum of k², exact: ``ksq[t, 0] * 2**32 + ksq[t, 1]`` (added to). Integers, so the total is
        the same for any thread count (a float sum was not: its rounding depended on the blocks).
    rec_stride : int
        Record the box sums at origins that are multiples of it into ``rec``; 0 = do not record.
    rec : (ceil(mx/rs), ceil(my/rs), ceil(mz/rs)) int64 ndarray
        Recorded box sums.
    """
    nf = fields.shape[0]
    nx = fields.shape[1]
    mx = npos[0]
    my = npos[1]
    mz = npos[2]
    n_ring = ring.shape[1]
    wx_max = 0
    for f in range(nf):
        wx_max = max(wx_max, wins[f, 0])
    batch = n_ring - wx_max - 1
    nt = hist.shape[0]
    n_bins = hist.shape[1]
    acc = np.zeros((my, mz), np.int64)
    filled = 0
    x0a = 0
    while x0a < mx:
        # origins x0a..x0b-1 need slices up to x0b + wx_max - 2; the ring still holds slice x0a - 1
        x0b = min(x0a + batch, mx)
        hi = x0b + wx_max - 1
        lo = filled
        for task in prange((hi - lo) * nf):
            f = task % nf
            s = lo + task // nf
            x = s if s < nx else s - nx
            tmp = np.empty((my + wins[f, 1] - 1, mz), np.int64)
            _fill_slice(fields[f], x, wins[f, 1], wins[f, 2], my, mz, tmp, ring[f, s % n_ring])
        filled = hi
        for t in prange(nt):
            for y0 in range(t * my // nt, (t + 1) * my // nt):
                row = acc[y0]
                for x0 in range(x0a, x0b):
                    for f in range(nf):
                        wx = wins[f, 0]
                        if x0 == 0:
                            for s in range(wx):
                                slab = ring[f, s % n_ring, y0]
                                for z0 in range(mz):
                                    row[z0] += np.int64(slab[z0])
                        else:
                            add = ring[f, (x0 + wx - 1) % n_ring, y0]
                            sub = ring[f, (x0 - 1) % n_ring, y0]
                            for z0 in range(mz):
                                row[z0] += np.int64(add[z0]) - np.int64(sub[z0])
                    if hist_stride > 0 and x0 % hist_stride == 0 and y0 % hist_stride == 0:
                        for z0 in range(0, mz, hist_stride):
                            k = row[z0]
                            j = _bin_of(k, k_max, n_bins)
                            hist[t, j] += 1
                            ksum[t, j] += k
                            sq = k * k  # k <= k_max < 3·10^9: fits int64
                            low = ksq[t, 1] + (sq & _LOW32)
                            ksq[t, 0] += (sq >> 32) + (low >> 32)
                            ksq[t, 1] = low & _LOW32
                    if rec_stride > 0 and x0 % rec_stride == 0 and y0 % rec_stride == 0:
                        for z0 in range(0, mz, rec_stride):
                            rec[x0 // rec_stride, y0 // rec_stride, z0 // rec_stride] = row[z0]
        x0a = x0b


#: largest cell edge for the percolation search: (size + 2)^3 must stay below 2^31 (int32 parent links)
MAX_PERCOLATION_SIZE = 1288

#: bits of a packed stack entry: (i << 2*_SHIFT) | (j << _SHIFT) | k, for padded cell coordinates < 2**_SHIFT
_SHIFT = 16
_MASK = (1 << _SHIFT) - 1
#: stamp of the padding layer around a cell: larger than any search generation, so always "visited"
_WALL = np.uint32(0xFFFFFFFF)


@njit(cache=True, fastmath=FASTMATH)
def _spans(flat, xoff, yoff, zoff, size, axis, steps, lin, stamp, gen, stack, parent, box):
    """True if pore voxels of the cell join its faces perpendicular to ``axis``.

    Cell coordinates are padded: 1..size inside, 0 and size+1 the padding layer, whose ``stamp`` is _WALL, so no
    bounds checks are needed. The voxel at padded (i, j, k) is ``flat[xoff[i] + yoff[j] + zoff[k]]``. Depth-first
    search from all pore voxels of the face at coordinate 1 to the face at ``size``; ``steps`` (and their linear
    offsets ``lin`` in the padded cell) list the straight step towards the far face last, so it is tried first.
    ``stamp[v] >= gen`` marks visited voxels; ``stack`` holds packed coordinates. On success the path found is
    traced back through ``parent`` and its bounding box in padded coordinates goes to ``box`` (lo x, y, z, hi x, y, z).
    """
    p = size + 2
    far = size
    any_far = False
    for a in range(1, size + 1):
        for b in range(1, size + 1):
            if axis == 0:
                hit = flat[xoff[far] + yoff[a] + zoff[b]]
            elif axis == 1:
                hit = flat[xoff[a] + yoff[far] + zoff[b]]
            else:
                hit = flat[xoff[a] + yoff[b] + zoff[far]]
            if hit != 0:
                any_far = True
                break
        if any_far:
            break
    if not any_far:
        return False
    if size == 1:
        box[:] = 1
        return True
    top = 0
    for a in range(1, size + 1):
        for b in range(1, size + 1):
            if axis == 0:
                i, j, k = 1, a, b
            elif axis == 1:
                i, j, k = a, 1, b
            else:
                i, j, k = a, b, 1
            if flat[xoff[i] + yoff[j] + zoff[k]] != 0:
                stamp[(i * p + j) * p + k] = gen
                parent[(i * p + j) * p + k] = -1
                stack[top] = (i << (2 * _SHIFT)) | (j << _SHIFT) | k
                top += 1
    n_nb = steps.shape[0]
    while top > 0:
        top -= 1
        code = stack[top]
        i = code >> (2 * _SHIFT)
        j = (code >> _SHIFT) & _MASK
        k = code & _MASK
        v = (i * p + j) * p + k
        for n in range(n_nb):
            w = v + lin[n]
            if stamp[w] >= gen:
                continue
            ni = i + steps[n, 0]
            nj = j + steps[n, 1]
            nk = k + steps[n, 2]
            if flat[xoff[ni] + yoff[nj] + zoff[nk]] == 0:
                continue
            if (axis == 0 and ni == far) or (axis == 1 and nj == far) or (axis == 2 and nk == far):
                box[0] = ni
                box[1] = nj
                box[2] = nk
                box[3] = ni
                box[4] = nj
                box[5] = nk
                u = v
                while u >= 0:
                    c0 = u // (p * p)
                    c1 = (u // p) % p
                    c2 = u % p
                    box[0] = min(box[0], c0)
                    box[1] = min(box[1], c1)
                    box[2] = min(box[2], c2)
                    box[3] = max(box[3], c0)
                    box[4] = max(box[4], c1)
                    box[5] = max(box[5], c2)
                    u = np.int64(parent[u])
                return True
            stamp[w] = gen
            parent[w] = np.int32(v)
            stack[top] = (ni << (2 * _SHIFT)) | (nj << _SHIFT) | nk
            top += 1
    return False


@njit(cache=True, fastmath=FASTMATH)
def _path_fits(record, origin, size, axis):
    """True if the spanning path of ``record`` (see _percolation_cells) also spans the cell at ``origin``.

    It must have been found in a cell with the same range along ``axis`` and lie inside this cell on the others.
    """
    if record[0] < 0 or record[0] != origin[axis]:
        return False
    for d in range(3):
        if d != axis and (record[1 + d] < origin[d] or record[4 + d] > origin[d] + size - 1):
            return False
    return True


@by_threads(cache=True, fastmath=FASTMATH)
def _percolation_cells(pore, origins, counts, size, offs_by_axis, lin_by_axis, want, stop, n_chunks, out):
    """Local percolation indicators of many cells.

    Parameters
    ----------
    pore : (nx, ny, nz) uint8 ndarray, C-contiguous
        1 = pore.
    origins : (n, 3) int64 ndarray
        Cell origins; cell voxels are ``(origin + 0..size-1) mod shape`` on each axis.
    counts : (n,) int64 ndarray
        Pore voxels in each cell (from the box sums); settles empty, full and too-sparse cells without a search.
    size : int
        Cell edge L in voxels.
    offs_by_axis : (3, n_nb, 3) int64 ndarray
        Neighbour steps per search axis, the step towards the far face last.
    lin_by_axis : (3, n_nb) int64 ndarray
        The same steps as offsets of the linear index in the padded cell ((size+2)³, x slowest).
    want : int
        Bit mask of the axes to search (BIT_X | BIT_Y | BIT_Z).
    stop : int
        STOP_NEVER, STOP_ON_FAIL (enough for Λ_3 alone) or STOP_ON_SUCCESS (enough for Λ_c alone).
    n_chunks : int
        Work items for the threads, each a contiguous block of cells. Within a block a cell skips the search
        along an axis when a spanning path found earlier (the last one, or the last one at the same z origin)
        came from a cell with the same range along that axis and lies inside this cell: with origins in C order
        (z fastest) the neighbour along z serves x and y, the neighbour along y serves x and z.
    out : (n,) uint8 ndarray
        Λ bits (BIT_X ... BIT_ANY); BIT_ALL and BIT_ANY refer to the searched axes.
    """
    n = origins.shape[0]
    nx, ny, nz = pore.shape
    flat = pore.reshape(nx * ny * nz)
    full = size * size * size
    p = size + 2
    for c in prange(n_chunks):
        stamp = np.zeros(p * p * p, np.uint32)
        for i in range(p):
            for j in range(p):
                for k in range(p):
                    if i == 0 or j == 0 or k == 0 or i == p - 1 or j == p - 1 or k == p - 1:
                        stamp[(i * p + j) * p + k] = _WALL
        stack = np.empty(full, np.int64)
        parent = np.empty(p * p * p, np.int32)  # padded index < 2^31 (size <= MAX_PERCOLATION_SIZE)
        box = np.zeros(6, np.int64)
        origin = np.zeros(3, np.int64)
        # spanning paths kept for reuse, per axis: the last one, and the last one per z origin. A record is the
        # cell origin along the axis and the path's bounding box (volume coordinates, unwrapped)
        last = np.full((3, 7), -1, np.int64)
        by_z = np.full((3, nz, 7), -1, np.int64)
        xoff = np.zeros(p, np.int64)
        yoff = np.zeros(p, np.int64)
        zoff = np.zeros(p, np.int64)
        gen = np.uint32(0)
        for cell in range(c * n // n_chunks, (c + 1) * n // n_chunks):
            k = counts[cell]
            for d in range(3):
                origin[d] = origins[cell, d]
            bits = 0
            if k >= full:
                bits = want & 7
            elif k >= size:  # a path between opposite faces needs at least `size` pore voxels
                for a in range(size):
                    xoff[a + 1] = ((origin[0] + a) % nx) * (ny * nz)
                    yoff[a + 1] = ((origin[1] + a) % ny) * nz
                    zoff[a + 1] = (origin[2] + a) % nz
                for axis in range(3):
                    if (want >> axis) & 1 == 0:
                        continue
                    if _path_fits(last[axis], origin, size, axis):
                        ok = True
                    elif _path_fits(by_z[axis, origin[2]], origin, size, axis):
                        ok = True
                        for q in range(
                            7
                        ):  # element by element: a slice copy compiles numba's shape-error path
                            last[axis, q] = by_z[axis, origin[2], q]
                    else:
                        if gen == _WALL - np.uint32(1):  # generations exhausted: clear the inside marks
                            for v in range(p * p * p):
                                if stamp[v] != _WALL:
                                    stamp[v] = 0
                            gen = np.uint32(0)
                        gen += np.uint32(1)
                        ok = _spans(
                            flat,
                            xoff,
                            yoff,
                            zoff,
                            size,
                            axis,
                            offs_by_axis[axis],
                            lin_by_axis[axis],
                            stamp,
                            gen,
                            stack,
                            parent,
                            box,
                        )
                        if ok:
                            last[axis, 0] = origin[axis]
                            for d in range(3):
                                last[axis, 1 + d] = origin[d] + box[d] - 1
                                last[axis, 4 + d] = origin[d] + box[3 + d] - 1
                            for q in range(7):
                                by_z[axis, origin[2], q] = last[axis, q]
                    if ok:
                        bits |= 1 << axis
                    if (stop == STOP_ON_FAIL and not ok) or (stop == STOP_ON_SUCCESS and ok):
                        break
            if bits != 0 and bits == (want & 7):
                bits |= BIT_ALL
            if bits & 7 != 0:
                bits |= BIT_ANY
            out[cell] = bits
