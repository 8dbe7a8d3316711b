"""Numba kernels of the grey-value voxelisation (§4.7.2): 6x6x6 sample points per voxel, counted in the matrix.

Sample point k (0..5) of voxel i along an axis sits at ``(6*i + k + 0.5) * (a/6)``: every kernel computes it with
:func:`porepipe._shared.sample_points.sample_coord`, and a point is in the matrix when
``dx*dx + dy*dy + dz*dz <= r*r`` for some sphere image, in exactly this order of operations — that is what makes the
chord method bit-identical to brute force.

Brute force (:func:`_voxelize_plane`) tests all 216 points of every voxel near a sphere. The chord method
(:func:`_chord_plane`) works in sample-row space: along a row of samples in z the points inside a ball form one
interval (the chord), whose two ends are found from a square root and proven by the exact predicate; the chords are
counted per voxel in O(1) each, and ORed as bit masks only into voxels that two or more balls reach.
"""

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH
from porepipe._shared.sample_points import (
    FULL,
    MARGIN,
    N_SAMPLES,
    PARTIAL,
    SUB,
    UNTOUCHED,
    WORDS,
    axis_range,
    grey_from_status,
    hull_gap,
    or_row,
    plane_candidates,
    popcount64,
    sample_coord,
)


@njit(cache=True, fastmath=FASTMATH)
def _mark_points(mask, j, k, i, cx, cy, cz, r2, h, dx2, dy2, dz2, words):
    """OR into ``mask[j, k]`` the sample points of voxel (i, j, k) inside the ball (cx, cy, cz, r2): all 216 tested.

    Bit layout as in :func:`porepipe._shared.sample_points.or_row`. ``dx2``/``dy2``/``dz2`` (length 6) and
    ``words`` (uint64, length 4) are scratch.
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
    for sx in range(SUB):
        for sy in range(SUB):
            dxy = dx2[sx] + dy2[sy]
            row = 0
            for sz in range(SUB):
                row |= int(dxy + dz2[sz] <= r2) << sz  # branch-free
            or_row(words, sx, sy, row)
    for w in range(WORDS):
        mask[j, k, w] |= words[w]


@njit(cache=True, fastmath=FASTMATH)
def _voxelize_plane(i, images, order, xmin_sorted, r_max, h, ny, nz, status, mask, scratch, words, out):
    """Brute-force grey values of voxel plane x = i into ``out`` (ny, nz); ``status``/``mask``/``scratch`` are scratch.

    Every voxel whose sample hull comes within r of a ball gets all 216 points tested (:func:`_mark_points`).
    """
    status[:, :] = UNTOUCHED
    plane_lo, first, last = plane_candidates(i, h, xmin_sorted, r_max)
    for q in range(first, last):
        s = order[q]
        cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
        if cx + r < plane_lo:
            continue
        r2 = r * r
        nx_, _ = hull_gap(cx, i, h)
        j0, j1 = axis_range(cy, r, h, ny)
        k0, k1 = axis_range(cz, r, h, nz)
        for j in range(j0, j1):
            ny_, _ = hull_gap(cy, j, h)
            for k in range(k0, k1):
                nz_, _ = hull_gap(cz, k, h)
                if nx_ * nx_ + ny_ * ny_ + nz_ * nz_ > r2 * (1.0 + MARGIN):
                    continue
                if status[j, k] == UNTOUCHED:
                    for w in range(WORDS):
                        mask[j, k, w] = 0
                    status[j, k] = PARTIAL
                _mark_points(mask, j, k, i, cx, cy, cz, r2, h, scratch[0], scratch[1], scratch[2], words)
    grey_from_status(status, mask, out)


#: voxel state of the chord method beyond those of :mod:`porepipe._shared.sample_points`: two or more spheres reach
#: into the voxel (its grey value is the popcount of the union mask, not the chord count)
MULTI = 3


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _add_chord(counts, j, lo, hi):
    """Add the samples ``lo .. hi`` (global z indices) of one row to the per-voxel counts of voxel row ``j``.

    ``counts[j]`` is a difference array along z (its prefix sum is the count per voxel): the two end voxels get their
    part of the chord, every voxel between them all SUB samples, in four updates whatever the chord's length.
    """
    k_lo = lo // SUB
    k_hi = hi // SUB
    if k_lo == k_hi:
        n = hi - lo + 1
        counts[j, k_lo] += n
        counts[j, k_lo + 1] -= n
        return
    first = SUB * (k_lo + 1) - lo
    last = hi - SUB * k_hi + 1
    counts[j, k_lo] += first
    counts[j, k_lo + 1] += SUB - first
    counts[j, k_hi] += last - SUB
    counts[j, k_hi + 1] -= last


@njit(cache=True, fastmath=FASTMATH)
def _classify(i, cx, cy, cz, r, h, ny, nz, status, mask):
    """Mark the voxels of plane ``i`` that one ball reaches: FULL (whole sample hull inside), else one more sphere.

    A voxel's first reaching sphere makes it PARTIAL, a second one MULTI (its union mask is then cleared for
    :func:`_or_chords`); FULL wins over both. The reach test is the brute-force one (hull distance with a margin).
    """
    r2 = r * r
    nx_, fx_ = hull_gap(cx, i, h)
    j0, j1 = axis_range(cy, r, h, ny)
    k0, k1 = axis_range(cz, r, h, nz)
    for j in range(j0, j1):
        ny_, fy_ = hull_gap(cy, j, h)
        for k in range(k0, k1):
            st = status[j, k]
            if st == FULL:
                continue
            nz_, fz_ = hull_gap(cz, k, h)
            if nx_ * nx_ + ny_ * ny_ + nz_ * nz_ > r2 * (1.0 + MARGIN):
                continue
            if fx_ * fx_ + fy_ * fy_ + fz_ * fz_ <= r2 * (1.0 - MARGIN):
                status[j, k] = FULL
            elif st == UNTOUCHED:
                status[j, k] = PARTIAL
            elif st == PARTIAL:
                status[j, k] = MULTI
                for w in range(WORDS):
                    mask[j, k, w] = 0


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _inside(dxy, zs, h, cz, r2):
    """Whether sample ``zs`` (global index along z) of a row with squared (x, y) distance ``dxy`` is in the ball.

    The exact predicate of :func:`_mark_points`, ``(dx*dx + dy*dy) + dz*dz <= r*r``, with ``dz`` from the same
    sample coordinate (:func:`porepipe._shared.sample_points.sample_coord` of global sample ``zs``).
    """
    dz = (zs + 0.5) * h - cz
    return dxy + dz * dz <= r2


@njit(cache=True, fastmath=FASTMATH)
def _chord_walk(dxy, h, cz, r2, lo, hi):
    """Samples ``lo .. hi`` (global z indices; empty when lo > hi) of a row inside the ball, by walking.

    Along a row ``dz*dz`` falls then rises with the sample index (rounding is monotone), so the samples that pass
    the exact predicate form one interval, which holds the sample nearest the centre if it is not empty. Its ends
    are walked from the guesses ``lo``/``hi`` until the predicate says each is the last sample inside.
    """
    m = int(np.floor(cz / h))  # the sample nearest the centre, or one of its neighbours
    best = m
    for t in (m - 1, m + 1):
        dt = (t + 0.5) * h - cz
        db = (best + 0.5) * h - cz
        if dt * dt < db * db:
            best = t
    if not _inside(dxy, best, h, cz, r2):
        return 1, 0
    lo = min(lo, best)
    while not _inside(dxy, lo, h, cz, r2):
        lo += 1
    while _inside(dxy, lo - 1, h, cz, r2):
        lo -= 1
    hi = max(hi, best)
    while not _inside(dxy, hi, h, cz, r2):
        hi -= 1
    while _inside(dxy, hi + 1, h, cz, r2):
        hi += 1
    return lo, hi


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _chord_end(dxy, g, step, h, cz, r2):
    """The last sample inside the ball going from the centre in direction ``step`` (±1), near the guess ``g``.

    Accepted only where the exact predicate proves it (the sample is inside, its outer neighbour is not); returns
    (end, proven). Rounding leaves the true end at ``g`` nearly always, else one sample off.
    """
    in_g = _inside(dxy, g, h, cz, r2)
    in_out = _inside(dxy, g + step, h, cz, r2)
    if in_g and not in_out:
        return g, True
    if in_out:
        return g + step, not _inside(dxy, g + 2 * step, h, cz, r2)
    return g - step, _inside(dxy, g - step, h, cz, r2)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _chord(dxy, h, cz, r2, zc, inv_h):
    """Samples ``lo .. hi`` (global z indices; empty when lo > hi) of a row inside the ball, decided exactly.

    ``zc = cz/h - 0.5`` and ``inv_h = 1/h`` only shape the square-root guess of each end; each end is accepted only
    where the exact predicate proves it (:func:`_chord_end`), else :func:`_chord_walk` decides the row.
    """
    half = np.sqrt(r2 - dxy) * inv_h
    lo, ok_lo = _chord_end(dxy, int(np.ceil(zc - half)), -1, h, cz, r2)
    hi, ok_hi = _chord_end(dxy, int(np.floor(zc + half)), 1, h, cz, r2)
    if ok_lo and ok_hi and lo <= hi:
        return lo, hi
    return _chord_walk(dxy, h, cz, r2, lo, hi)


@njit(cache=True, fastmath=FASTMATH)
def _guess_rows(dxy, n, h, cz, r2, ends, proven):
    """Square-root guesses of the chord ends of rows ``dxy[:n]`` into ``ends`` (2, n), and whether both are proven.

    Branch-free, so the loop vectorises: the guessed low end is proven when its sample is inside and the one below
    is not, the high end likewise, by the exact predicate (the same arithmetic as :func:`_inside`, with integral
    float sample indices). Rows not proven (a guess one sample off, rare; or no sample inside) are left to callers.
    """
    zc = cz / h - 0.5
    inv_h = 1.0 / h
    for t in range(n):
        d = dxy[t]
        half = np.sqrt(max(r2 - d, 0.0)) * inv_h
        lo = np.ceil(zc - half)
        hi = np.floor(zc + half)
        dz_lo = (lo + 0.5) * h - cz
        dz_below = (lo - 0.5) * h - cz
        dz_hi = (hi + 0.5) * h - cz
        dz_above = (hi + 1.5) * h - cz
        ends[0, t] = lo
        ends[1, t] = hi
        proven[t] = (
            (d + dz_lo * dz_lo <= r2)
            & (d + dz_below * dz_below > r2)
            & (d + dz_hi * dz_hi <= r2)
            & (d + dz_above * dz_above > r2)
        )


@njit(cache=True, fastmath=FASTMATH)
def _sphere_chords(i, cx, cy, cz, r, h, ny, nz, counts, chords, rowbuf, proven):
    """Chords of one ball through the sample rows of plane ``i``: counted into ``counts``, kept in ``chords``.

    ``chords[sx, ys]`` = (lo, hi): the global z samples of row (sx, ys) inside the ball and the grid (empty when
    lo > hi), for the rows of the ball's y range, each decided by the exact predicate: proven square-root guesses
    (:func:`_guess_rows`), else :func:`_chord`. ``rowbuf`` (4, SUB * ny) and ``proven`` (SUB * ny) are scratch.
    """
    dy2, rows, ends = rowbuf[0], rowbuf[1], rowbuf[2:4]
    r2 = r * r
    j0, j1 = axis_range(cy, r, h, ny)
    z_last = SUB * nz - 1
    zc = cz / h - 0.5
    inv_h = 1.0 / h
    for ys in range(SUB * j0, SUB * j1):
        dy = (ys + 0.5) * h - cy  # = sample_coord of global sample ys
        dy2[ys] = dy * dy
    for sx in range(SUB):
        dx = sample_coord(i, sx, h) - cx
        dx2 = dx * dx
        chords[sx, SUB * j0 : SUB * j1, 0] = 1  # empty unless a chord is found below
        chords[sx, SUB * j0 : SUB * j1, 1] = 0
        if dx2 > r2:
            continue
        # rows whose y distance alone is over r (with one sample to spare for rounding) hold no sample inside
        half = np.sqrt(r2 - dx2) / h
        ys_lo = max(int(np.floor(cy / h - 0.5 - half)) - 1, SUB * j0)
        ys_hi = min(int(np.floor(cy / h - 0.5 + half)) + 2, SUB * j1)
        n = max(ys_hi - ys_lo, 0)
        for t in range(n):
            rows[t] = dx2 + dy2[ys_lo + t]
        _guess_rows(rows, n, h, cz, r2, ends, proven)
        for t in range(n):
            dxy = rows[t]
            if dxy > r2:
                continue  # rounding is monotone: dxy + dz*dz >= dxy > r*r for every sample of the row
            if proven[t]:
                lo = int(ends[0, t])
                hi = int(ends[1, t])
            else:
                lo, hi = _chord(dxy, h, cz, r2, zc, inv_h)
            lo = max(lo, 0)
            hi = min(hi, z_last)
            if lo <= hi:
                ys = ys_lo + t
                chords[sx, ys, 0] = lo
                chords[sx, ys, 1] = hi
                _add_chord(counts, ys // SUB, lo, hi)


@njit(cache=True, fastmath=FASTMATH)
def _or_chords(cy, cz, r, h, ny, nz, status, mask, chords, words):
    """OR one ball's chords (from :func:`_sphere_chords`) into the masks of the MULTI voxels it can reach."""
    j0, j1 = axis_range(cy, r, h, ny)
    k0, k1 = axis_range(cz, r, h, nz)
    for j in range(j0, j1):
        for k in range(k0, k1):
            if status[j, k] != MULTI:
                continue
            for w in range(WORDS):
                words[w] = 0
            z0 = SUB * k
            for sx in range(SUB):
                for sy in range(SUB):
                    lo = max(chords[sx, SUB * j + sy, 0] - z0, 0)
                    hi = min(chords[sx, SUB * j + sy, 1] - z0, SUB - 1)
                    if lo <= hi:
                        or_row(words, sx, sy, ((1 << (hi + 1)) - 1) ^ ((1 << lo) - 1))
            for w in range(WORDS):
                mask[j, k, w] |= words[w]


@njit(cache=True, fastmath=FASTMATH)
def _grey_from_chords(status, mask, counts, out):
    """Grey values of a plane: 216 (FULL), the chord count (one sphere), the union mask's popcount (MULTI), 0."""
    for j in range(status.shape[0]):
        count = 0
        for k in range(status.shape[1]):
            count += counts[j, k]
            st = status[j, k]
            if st == FULL:
                out[j, k] = N_SAMPLES
            elif st == PARTIAL:
                out[j, k] = count
            elif st == MULTI:
                bits = 0
                for w in range(WORDS):
                    bits += popcount64(mask[j, k, w])
                out[j, k] = bits
            else:
                out[j, k] = 0


@njit(cache=True, fastmath=FASTMATH)
def _chord_plane(
    i, images, order, xmin_sorted, r_max, h, ny, nz, status, mask, counts, chords, rowbuf, proven, words, out
):
    """Grey values of plane x = i by chords in sample-row space (bit-identical to :func:`_voxelize_plane`).

    First every ball marks the voxels it reaches (:func:`_classify`); then each ball's chords are counted into the
    per-voxel counts (right wherever one ball alone reaches a voxel) and ORed into the masks of voxels two or more
    balls reach, so a sample counts once if it is in any ball.
    """
    status[:, :] = UNTOUCHED
    counts[:, :] = 0
    plane_lo, first, last = plane_candidates(i, h, xmin_sorted, r_max)
    for q in range(first, last):
        s = order[q]
        if images[s, 0] + images[s, 3] >= plane_lo:
            _classify(i, images[s, 0], images[s, 1], images[s, 2], images[s, 3], h, ny, nz, status, mask)
    for q in range(first, last):
        s = order[q]
        cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
        if cx + r < plane_lo:
            continue
        _sphere_chords(i, cx, cy, cz, r, h, ny, nz, counts, chords, rowbuf, proven)
        _or_chords(cy, cz, r, h, ny, nz, status, mask, chords, words)
    _grey_from_chords(status, mask, counts, out)


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _voxelize_slab(i0, i1, images, order, xmin_sorted, r_max, h, ny, nz, boundary_only, out):
    """Grey values of planes i0..i1-1 into ``out`` (i1 - i0, ny, nz), parallel over planes.

    ``boundary_only`` selects the chord method (:func:`_chord_plane`), else brute force (216 tests per voxel).
    """
    nplanes = i1 - i0
    nthreads = min(nplanes, 64)
    per = (nplanes + nthreads - 1) // nthreads
    for t in prange(nthreads):
        status = np.empty((ny, nz), dtype=np.uint8)
        mask = np.empty((ny, nz, WORDS), dtype=np.uint64)
        counts = np.empty((ny, nz + 1), dtype=np.int32)
        chords = np.empty((SUB, SUB * ny, 2), dtype=np.int64)
        rowbuf = np.empty((4, SUB * ny))
        proven = np.empty(SUB * ny, dtype=np.bool_)
        scratch = np.empty((3, SUB))
        words = np.empty(WORDS, dtype=np.uint64)
        for p in range(t * per, min((t + 1) * per, nplanes)):
            i = i0 + p
            if boundary_only:
                _chord_plane(
                    i,
                    images,
                    order,
                    xmin_sorted,
                    r_max,
                    h,
                    ny,
                    nz,
                    status,
                    mask,
                    counts,
                    chords,
                    rowbuf,
                    proven,
                    words,
                    out[p],
                )
            else:
                _voxelize_plane(
                    i, images, order, xmin_sorted, r_max, h, ny, nz, status, mask, scratch, words, out[p]
                )
