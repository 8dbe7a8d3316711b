"""Numba kernels of the grey-value voxelisation (§4.7.2): 6x6x6 sample points per voxel, counted in the matrix.

Sample point k (0..5) of voxel i along an axis sits at ``(6*i + k + 0.5) * (a/6)``: every kernel computes it with
:func:`_sample_coord`, and a point is in the matrix when ``dx*dx + dy*dy + dz*dz <= r*r`` for some sphere image, in
exactly this order of operations — that is what makes the boundary-only method bit-identical to brute force.
"""

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH

SUB = 6                  # sample points per voxel edge
N_SAMPLES = SUB ** 3     # 216
_ROWS_PER_WORD = 10      # 36 rows of 6 sample points, 10 rows (60 bits) per uint64 word
_WORDS = 4               # ceil(36 / 10) words per voxel
_FULL_ROW = (1 << SUB) - 1
#: relative margin on squared distances for the whole-voxel shortcuts; far above rounding (1e-16), far below
#: any geometric scale, so a voxel whose sample hull is within it of the sphere surface is sampled point by point.
_MARGIN = 1e-9

UNTOUCHED, PARTIAL, FULL = 0, 1, 2


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _sample_coord(voxel, k, h):
    return (SUB * voxel + k + 0.5) * h


@njit(cache=True, fastmath=FASTMATH)
def _axis_range(c, r, h, n):
    """Voxels [lo, hi) whose sample-point hull can meet the interval [c - r, c + r] (hull = (6i+0.5..6i+5.5)·h)."""
    lo = int(np.floor((c - r) / (SUB * h))) - 1
    hi = int(np.floor((c + r) / (SUB * h))) + 2
    return max(lo, 0), min(hi, n)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _hull_gap(c, voxel, h):
    """Smallest and largest |p - c| over the sample hull of ``voxel`` along one axis."""
    p0 = _sample_coord(voxel, 0, h)
    p1 = _sample_coord(voxel, SUB - 1, h)
    near = 0.0
    if c < p0:
        near = p0 - c
    elif c > p1:
        near = c - p1
    far = max(abs(c - p0), abs(c - p1))
    return near, far


@njit(cache=True, fastmath=FASTMATH)
def _mark_points(mask, j, k, i, cx, cy, cz, r2, h, dx2, dy2, dz2, words, skip_rows):
    """OR into ``mask[j, k]`` the sample points of voxel (i, j, k) inside the ball (cx, cy, cz, r2).

    Bit layout: row q = 6·sx + sy (6 points along z) occupies bits 6·(q mod 10) .. +5 of word q // 10, so a row
    never straddles two words. ``dx2``/``dy2``/``dz2`` (length 6) and ``words`` (uint64, length 4) are scratch. With ``skip_rows`` a row
    whose (x, y) distance alone exceeds r is skipped; without it (brute force) all 216 points are tested.
    """
    for s in range(SUB):
        dx = _sample_coord(i, s, h) - cx
        dy = _sample_coord(j, s, h) - cy
        dz = _sample_coord(k, s, h) - cz
        dx2[s] = dx * dx
        dy2[s] = dy * dy
        dz2[s] = dz * dz
    for w in range(_WORDS):
        words[w] = 0
    dz2_min = dz2[0]
    dz2_max = dz2[0]
    for s in range(1, SUB):
        dz2_min = min(dz2_min, dz2[s])
        dz2_max = max(dz2_max, dz2[s])
    for sx in range(SUB):
        for sy in range(SUB):
            dxy = dx2[sx] + dy2[sy]
            if skip_rows:
                # rounding is monotone, so dxy + dz2_min/max bound dxy + dz2[sz] exactly: whole rows are decided
                # without a per-point test and without changing any decision
                if dxy + dz2_min > r2:
                    continue
                if dxy + dz2_max <= r2:
                    q = SUB * sx + sy
                    words[q // _ROWS_PER_WORD] |= np.uint64(_FULL_ROW) << np.uint64(SUB * (q % _ROWS_PER_WORD))
                    continue
            row = 0
            for sz in range(SUB):
                row |= int(dxy + dz2[sz] <= r2) << sz  # branch-free
            if row:
                q = SUB * sx + sy
                words[q // _ROWS_PER_WORD] |= np.uint64(row) << np.uint64(SUB * (q % _ROWS_PER_WORD))
    for w in range(_WORDS):
        mask[j, k, w] |= words[w]


@njit(cache=True, fastmath=FASTMATH)
def _popcount64(x):
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (x * np.uint64(0x0101010101010101)) >> np.uint64(56)


@njit(cache=True, fastmath=FASTMATH)
def _grey_from_status(status, mask, out):
    """Grey values of a plane: 216 for FULL voxels, the popcount of the sample mask for PARTIAL ones, else 0."""
    for j in range(status.shape[0]):
        for k in range(status.shape[1]):
            st = status[j, k]
            if st == FULL:
                out[j, k] = N_SAMPLES
            elif st == PARTIAL:
                count = 0
                for w in range(_WORDS):
                    count += _popcount64(mask[j, k, w])
                out[j, k] = count
            else:
                out[j, k] = 0


@njit(cache=True, fastmath=FASTMATH)
def _plane_candidates(i, h, xmin_sorted, half_extent_max):
    """Sample-hull start of plane x = i and the range [first, last) of bodies (sorted by x-min = cx − half extent)
    whose x-extent can meet the plane's sample hull."""
    plane_lo = _sample_coord(i, 0, h)
    plane_hi = _sample_coord(i, SUB - 1, h)
    first = np.searchsorted(xmin_sorted, plane_lo - 2.0 * half_extent_max, side="left")
    last = np.searchsorted(xmin_sorted, plane_hi, side="right")
    return plane_lo, first, last


@njit(cache=True, fastmath=FASTMATH)
def _voxelize_plane(i, images, order, xmin_sorted, r_max, h, ny, nz, boundary_only, status, mask, scratch, words,
                    out):
    """Grey values of voxel plane x = i into ``out`` (ny, nz); ``status``/``mask``/``scratch`` are this thread's."""
    status[:, :] = UNTOUCHED
    plane_lo, first, last = _plane_candidates(i, h, xmin_sorted, r_max)
    for q in range(first, last):
        s = order[q]
        cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
        if cx + r < plane_lo:
            continue
        r2 = r * r
        nx_, fx_ = _hull_gap(cx, i, h)
        j0, j1 = _axis_range(cy, r, h, ny)
        k0, k1 = _axis_range(cz, r, h, nz)
        for j in range(j0, j1):
            ny_, fy_ = _hull_gap(cy, j, h)
            for k in range(k0, k1):
                if status[j, k] == FULL:
                    continue
                nz_, fz_ = _hull_gap(cz, k, h)
                near2 = nx_ * nx_ + ny_ * ny_ + nz_ * nz_
                if near2 > r2 * (1.0 + _MARGIN):
                    continue
                if boundary_only and fx_ * fx_ + fy_ * fy_ + fz_ * fz_ <= r2 * (1.0 - _MARGIN):
                    status[j, k] = FULL
                    continue
                if status[j, k] == UNTOUCHED:
                    for w in range(_WORDS):
                        mask[j, k, w] = 0
                    status[j, k] = PARTIAL
                _mark_points(mask, j, k, i, cx, cy, cz, r2, h, scratch[0], scratch[1], scratch[2], words,
                             boundary_only)
    _grey_from_status(status, mask, out)


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _voxelize_slab(i0, i1, images, order, xmin_sorted, r_max, h, ny, nz, boundary_only, out):
    """Grey values of planes i0..i1-1 into ``out`` (i1 - i0, ny, nz), parallel over planes."""
    nplanes = i1 - i0
    nthreads = min(nplanes, 64)
    per = (nplanes + nthreads - 1) // nthreads
    for t in prange(nthreads):
        status = np.empty((ny, nz), dtype=np.uint8)
        mask = np.empty((ny, nz, _WORDS), dtype=np.uint64)
        scratch = np.empty((3, SUB))
        words = np.empty(_WORDS, dtype=np.uint64)
        for p in range(t * per, min((t + 1) * per, nplanes)):
            _voxelize_plane(i0 + p, images, order, xmin_sorted, r_max, h, ny, nz, boundary_only,
                            status, mask, scratch, words, out[p])
