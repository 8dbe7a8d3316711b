"""Numba kernels of the grey-value voxelisation (§4.7.2): 6x6x6 sample points per voxel, counted in the matrix.

Sample point k (0..5) of voxel i along an axis sits at ``(6*i + k + 0.5) * (a/6)``: every kernel computes it with
:func:`porepipe._shared.sample_points.sample_coord`, and a point is in the matrix when ``dx*dx + dy*dy + dz*dz <= r*r`` for some sphere image, in
exactly this order of operations — that is what makes the boundary-only method bit-identical to brute force.
"""

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH
from porepipe._shared.sample_points import (
    FULL,
    FULL_ROW,
    MARGIN,
    PARTIAL,
    SUB,
    UNTOUCHED,
    WORDS,
    axis_range,
    grey_from_status,
    hull_gap,
    or_row,
    plane_candidates,
    sample_coord,
)


@njit(cache=True, fastmath=FASTMATH)
def _mark_points(mask, j, k, i, cx, cy, cz, r2, h, dx2, dy2, dz2, words, skip_rows):
    """OR into ``mask[j, k]`` the sample points of voxel (i, j, k) inside the ball (cx, cy, cz, r2).

    Bit layout as in :func:`porepipe._shared.sample_points.or_row`. ``dx2``/``dy2``/``dz2`` (length 6) and
    ``words`` (uint64, length 4) are scratch. With ``skip_rows`` a row whose (x, y) distance alone exceeds r is
    skipped; without it (brute force) all 216 points are tested.
    """
    for s in range(SUB):
        dx = sample_coord(i, s, h) - cx
        dy = sample_coord(j, s, h) - cy
        dz = sample_coord(k, s, h) - cz
        dx2[s] = dx * dx
        dy2[s] = dy * dy
        dz2[s] = dz * dz
    for w in range(WORDS):
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
                    or_row(words, sx, sy, FULL_ROW)
                    continue
            row = 0
            for sz in range(SUB):
                row |= int(dxy + dz2[sz] <= r2) << sz  # branch-free
            or_row(words, sx, sy, row)
    for w in range(WORDS):
        mask[j, k, w] |= words[w]


@njit(cache=True, fastmath=FASTMATH)
def _voxelize_plane(
    i, images, order, xmin_sorted, r_max, h, ny, nz, boundary_only, status, mask, scratch, words, out
):
    """Grey values of voxel plane x = i into ``out`` (ny, nz); ``status``/``mask``/``scratch`` are this thread's."""
    status[:, :] = UNTOUCHED
    plane_lo, first, last = plane_candidates(i, h, xmin_sorted, r_max)
    for q in range(first, last):
        s = order[q]
        cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
        if cx + r < plane_lo:
            continue
        r2 = r * r
        nx_, fx_ = hull_gap(cx, i, h)
        j0, j1 = axis_range(cy, r, h, ny)
        k0, k1 = axis_range(cz, r, h, nz)
        for j in range(j0, j1):
            ny_, fy_ = hull_gap(cy, j, h)
            for k in range(k0, k1):
                if status[j, k] == FULL:
                    continue
                nz_, fz_ = hull_gap(cz, k, h)
                near2 = nx_ * nx_ + ny_ * ny_ + nz_ * nz_
                if near2 > r2 * (1.0 + MARGIN):
                    continue
                if boundary_only and fx_ * fx_ + fy_ * fy_ + fz_ * fz_ <= r2 * (1.0 - MARGIN):
                    status[j, k] = FULL
                    continue
                if status[j, k] == UNTOUCHED:
                    for w in range(WORDS):
                        mask[j, k, w] = 0
                    status[j, k] = PARTIAL
                _mark_points(
                    mask, j, k, i, cx, cy, cz, r2, h, scratch[0], scratch[1], scratch[2], words, boundary_only
                )
    grey_from_status(status, mask, out)


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _voxelize_slab(i0, i1, images, order, xmin_sorted, r_max, h, ny, nz, boundary_only, out):
    """Grey values of planes i0..i1-1 into ``out`` (i1 - i0, ny, nz), parallel over planes."""
    nplanes = i1 - i0
    nthreads = min(nplanes, 64)
    per = (nplanes + nthreads - 1) // nthreads
    for t in prange(nthreads):
        status = np.empty((ny, nz), dtype=np.uint8)
        mask = np.empty((ny, nz, WORDS), dtype=np.uint64)
        scratch = np.empty((3, SUB))
        words = np.empty(WORDS, dtype=np.uint64)
        for p in range(t * per, min((t + 1) * per, nplanes)):
            _voxelize_plane(
                i0 + p,
                images,
                order,
                xmin_sorted,
                r_max,
                h,
                ny,
                nz,
                boundary_only,
                status,
                mask,
                scratch,
                words,
                out[p],
            )
