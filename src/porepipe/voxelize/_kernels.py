"""Numba kernels of the grey-value voxelisation (§4.7.2): 6x6x6 sample points per voxel, counted in the matrix.

Sample point k (0..5) of voxel i along an axis sits at ``(6*i + k + 0.5) * (a/6)``: every kernel computes it with
:func:`porepipe._shared.sample_points.sample_coord`, and a point is in the matrix when
``dx*dx + dy*dy + dz*dz <= r*r`` for some sphere image, in exactly this order of operations — that is what makes the
chord method bit-identical to brute force.

Brute force (:func:`_voxelize_plane`) tests all 216 points of every voxel near a sphere. The chord method
(:func:`_chord_plane`) works in sample-row space: along a row of samples in z the points inside a ball form one
interval (the chord), whose two ends are found from a square root and proven by the exact predicate. Per voxel row
(fixed x, y) and ball, square roots give the run of voxels wholly inside (set to 216 without a test) and the shell
around it; only shell voxels get the row's 36 chords: counted straight into a voxel one ball alone reaches, ORed as
bit masks into voxels that two or more balls reach.
"""

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH
from porepipe._shared.sample_points import (
    FULL,
    MARGIN,
    N_SAMPLES,
    PARTIAL,
    ROWS_PER_WORD,
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
assert (UNTOUCHED, PARTIAL, FULL, MULTI) == (0, 1, 2, 3)  # the branch-free step of _reach_shell relies on it


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


#: relative slack (of r + |cz|, µm) on the z extent of a ball in one voxel row: far above the rounding of the square
#: root and divisions of :func:`_row_ranges` (~1e-8 r at worst), far below any voxel
SLACK = 1e-7


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _row_ranges(cz, r2, eps, near_xy, far_xy, inv_h, k0, k1):
    """Voxel ranges of one voxel row (fixed x, y) for one ball: ``lo, hi, f_lo, f_hi``.

    ``[lo, hi)`` (within ``[k0, k1)``) holds every voxel that the brute-force reach test (squared hull distance
    within ``r*r*(1 + MARGIN)``) accepts, widened by ``eps`` µm against rounding (of the square roots and of the
    products with ``inv_h`` = 1/h); ``[f_lo, f_hi)`` inside it the
    voxels whose whole sample hull is within ``r*r*(1 - MARGIN)``, narrowed by ``eps`` (empty as ``f_lo == f_hi ==
    lo``). ``near_xy``/``far_xy``: the squared near/far hull distances in x and y.
    """
    reach = r2 * (1.0 + MARGIN) - near_xy
    if reach < 0.0:
        return k0, k0, k0, k0
    w = np.sqrt(reach) + eps
    lo = max(int(np.ceil(((cz - w) * inv_h - (SUB - 0.5)) * (1.0 / SUB))), k0)
    hi = min(int(np.floor(((cz + w) * inv_h - 0.5) * (1.0 / SUB))) + 1, k1)
    if lo >= hi:
        return k0, k0, k0, k0
    inner = r2 * (1.0 - MARGIN) - far_xy
    if inner <= 0.0:
        return lo, hi, lo, lo
    wf = np.sqrt(inner) - eps
    f_lo = max(int(np.ceil(((cz - wf) * inv_h - 0.5) * (1.0 / SUB))), lo)
    f_hi = min(int(np.floor(((cz + wf) * inv_h - (SUB - 0.5)) * (1.0 / SUB))) + 1, hi)
    if wf <= 0.0 or f_lo >= f_hi:
        return lo, hi, lo, lo
    return lo, hi, f_lo, f_hi


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _reach_shell(status, mask, j, lo, hi):
    """One more ball reaches voxels ``lo .. hi - 1`` of row ``j``: the first makes a voxel PARTIAL, a second MULTI.

    Branch-free: UNTOUCHED (0) -> PARTIAL (1) -> MULTI (3), FULL (2) stays, as ``st + (st < FULL) * (st + 1)``. The
    union masks are cleared for :func:`_shell_grey` (no mask is ORed before every ball is classified).
    """
    for k in range(lo, hi):
        st = status[j, k]
        status[j, k] = st + (st < FULL) * (st + 1)
        for w in range(WORDS):
            mask[j, k, w] = 0


@njit(cache=True, fastmath=FASTMATH)
def _classify(i, cx, cy, cz, r, h, ny, nz, status, mask, ranges):
    """Mark the voxels of plane ``i`` that one ball reaches, by whole runs per voxel row (:func:`_row_ranges`).

    The run inside the ball becomes FULL, the shell on either side one more reaching sphere (:func:`_reach_shell`).
    Row ``j`` of the ball's y range ``[j0, j1)`` (:func:`porepipe._shared.sample_points.axis_range`) keeps its
    ranges in ``ranges[j - j0]`` for :func:`_shell_grey`.
    """
    r2 = r * r
    eps = SLACK * (r + abs(cz))
    nx_, fx_ = hull_gap(cx, i, h)
    j0, j1 = axis_range(cy, r, h, ny)
    k0, k1 = axis_range(cz, r, h, nz)
    for j in range(j0, j1):
        ny_, fy_ = hull_gap(cy, j, h)
        lo, hi, f_lo, f_hi = _row_ranges(
            cz, r2, eps, nx_ * nx_ + ny_ * ny_, fx_ * fx_ + fy_ * fy_, 1.0 / h, k0, k1
        )
        ranges[j - j0, 0] = lo
        ranges[j - j0, 1] = hi
        ranges[j - j0, 2] = f_lo
        ranges[j - j0, 3] = f_hi
        _reach_shell(status, mask, j, lo, f_lo)
        for k in range(f_lo, f_hi):
            status[j, k] = FULL
        _reach_shell(status, mask, j, f_hi, hi)


@njit(cache=True, fastmath=FASTMATH)
def _row_chords(j, dx2, cy, cz, r2, h, z_last, dxy, proven, chords):
    """The 36 chords of voxel row ``j`` (sample rows q = 6·sx + sy) into ``chords`` (2, 36): global z samples lo..hi.

    Each decided by the exact predicate: the square-root guesses of both ends, in one branch-free loop that
    vectorises, where the guessed low end is proven when its sample is inside and the one below is not, the high end
    likewise (the same arithmetic as :func:`_inside`, with integral float sample indices); rows not proven (a guess
    one sample off, rare; or no sample inside) by :func:`_chord`; clipped to the grid; empty when lo > hi.
    """
    for sx in range(SUB):
        for sy in range(SUB):
            dy = sample_coord(j, sy, h) - cy
            dxy[SUB * sx + sy] = dx2[sx] + dy * dy
    zc = cz / h - 0.5
    inv_h = 1.0 / h
    for q in range(SUB * SUB):
        d = dxy[q]
        half = np.sqrt(max(r2 - d, 0.0)) * inv_h
        lo = np.ceil(zc - half)
        hi = np.floor(zc + half)
        dz_lo = (lo + 0.5) * h - cz
        dz_below = (lo - 0.5) * h - cz
        dz_hi = (hi + 0.5) * h - cz
        dz_above = (hi + 1.5) * h - cz
        proven[q] = (
            (d + dz_lo * dz_lo <= r2)
            & (d + dz_below * dz_below > r2)
            & (d + dz_hi * dz_hi <= r2)
            & (d + dz_above * dz_above > r2)
        )
        chords[0, q] = max(int(lo), 0)
        chords[1, q] = min(int(hi), z_last)
    for q in range(SUB * SUB):
        if proven[q]:
            continue
        if dxy[q] > r2:
            lo_, hi_ = 1, 0  # rounding is monotone: dxy + dz*dz >= dxy > r*r for every sample of the row
        else:
            lo_, hi_ = _chord(dxy[q], h, cz, r2, zc, inv_h)
        chords[0, q] = max(lo_, 0)
        chords[1, q] = min(hi_, z_last)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _voxel_count(chords, k):
    """Samples of voxel ``k`` (along z) inside the 36 chords of its voxel row (branch-free, vectorises)."""
    z0 = SUB * k
    total = 0
    for q in range(SUB * SUB):
        total += max(min(chords[1, q], z0 + SUB - 1) - max(chords[0, q], z0) + 1, 0)
    return total


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _or_voxel(mask, j, k, chords):
    """OR the samples of voxel ``k`` inside the 36 chords of its voxel row into its union mask.

    Row q = 6·sx + sy of the voxel gets the bits ``max(lo - 6k, 0) .. min(hi - 6k, 5)`` (none when that is empty),
    in the layout of :func:`porepipe._shared.sample_points.or_row`, branch-free (both ends clamped to 0..6 so that
    every shift is defined).
    """
    z0 = SUB * k
    for w in range(WORDS):
        acc = np.uint64(0)
        for q in range(ROWS_PER_WORD * w, min(ROWS_PER_WORD * (w + 1), SUB * SUB)):
            lo = min(max(chords[0, q] - z0, 0), SUB)
            hi = max(min(chords[1, q] - z0, SUB - 1), lo - 1)  # hi = lo - 1: no bits
            bits = (1 << (hi + 1)) - (1 << lo)
            acc |= np.uint64(bits) << np.uint64(SUB * (q - ROWS_PER_WORD * w))
        mask[j, k, w] |= acc


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _needs_chords(status, j, lo, hi):
    """Whether voxels ``lo .. hi - 1`` of row ``j`` hold a PARTIAL or MULTI voxel (one that a chord count feeds)."""
    n = 0
    for k in range(lo, hi):
        st = status[j, k]
        n += (st == PARTIAL) | (st == MULTI)
    return n > 0


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _add_shell(status, mask, j, lo, hi, chords, out):
    """Voxels ``lo .. hi - 1`` of row ``j``: add the chord count to PARTIAL ones, OR the chord bits into MULTI ones."""
    for k in range(lo, hi):
        st = status[j, k]
        if st == PARTIAL:
            out[j, k] += _voxel_count(chords, k)
        elif st == MULTI:
            _or_voxel(mask, j, k, chords)


@njit(cache=True, fastmath=FASTMATH)
def _shell_grey(i, cx, cy, cz, r, h, ny, status, mask, ranges, scratch, proven, chords, out):
    """Add one ball's samples to the shell voxels of plane ``i``: counts into ``out`` (PARTIAL), bits into masks (MULTI).

    Per voxel row, the 36 chords are found only if a shell voxel (outside the untested FULL run of
    :func:`_row_ranges`) is PARTIAL or MULTI. A ball that does not reach a PARTIAL voxel adds 0 to it (the reach test
    is conservative), so summing into ``out`` leaves the count of the one ball that does. ``ranges``: the rows'
    ranges from :func:`_classify`; ``scratch`` (4, 36), ``proven`` (36) and ``chords`` (2, 36) are scratch.
    """
    r2 = r * r
    z_last = SUB * status.shape[1] - 1
    j0, j1 = axis_range(cy, r, h, ny)
    dx2 = scratch[0, :SUB]
    for sx in range(SUB):
        dx = sample_coord(i, sx, h) - cx
        dx2[sx] = dx * dx
    for j in range(j0, j1):
        lo, hi, f_lo, f_hi = ranges[j - j0, 0], ranges[j - j0, 1], ranges[j - j0, 2], ranges[j - j0, 3]
        if not (_needs_chords(status, j, lo, f_lo) or _needs_chords(status, j, f_hi, hi)):
            continue
        _row_chords(j, dx2, cy, cz, r2, h, z_last, scratch[1], proven, chords)
        _add_shell(status, mask, j, lo, f_lo, chords, out)
        _add_shell(status, mask, j, f_hi, hi, chords, out)


@njit(cache=True, fastmath=FASTMATH)
def _grey_full_multi(status, mask, out):
    """Finish a plane's grey values: 216 for FULL voxels, the union mask's popcount for MULTI ones; others stay."""
    for j in range(status.shape[0]):
        for k in range(status.shape[1]):
            st = status[j, k]
            if st == FULL:
                out[j, k] = N_SAMPLES
            elif st == MULTI:
                bits = 0
                for w in range(WORDS):
                    bits += popcount64(mask[j, k, w])
                out[j, k] = bits


@njit(cache=True, fastmath=FASTMATH)
def _chord_plane(i, images, order, xmin_sorted, r_max, h, ny, nz, status, mask, scratch, proven, chords, out):
    """Grey values of plane x = i by chords in sample-row space (bit-identical to :func:`_voxelize_plane`).

    First every ball marks the voxels it reaches (:func:`_classify`: runs of FULL voxels in bulk, the shell one by
    one); then each ball's chords are counted into the voxels that it alone reaches and ORed into the masks of
    voxels two or more balls reach (:func:`_shell_grey`), so a sample counts once if it is in any ball.
    """
    status[:, :] = UNTOUCHED
    out[:, :] = 0
    plane_lo, first, last = plane_candidates(i, h, xmin_sorted, r_max)
    n_rows = 0
    for q in range(first, last):
        s = order[q]
        if images[s, 0] + images[s, 3] >= plane_lo:
            j0, j1 = axis_range(images[s, 1], images[s, 3], h, ny)
            n_rows += j1 - j0
    ranges = np.empty((n_rows, 4), dtype=np.int64)  # per ball, its voxel rows' ranges (_row_ranges)
    row = 0
    for q in range(first, last):
        s = order[q]
        cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
        if cx + r >= plane_lo:
            j0, j1 = axis_range(cy, r, h, ny)
            _classify(i, cx, cy, cz, r, h, ny, nz, status, mask, ranges[row : row + j1 - j0])
            row += j1 - j0
    row = 0
    for q in range(first, last):
        s = order[q]
        cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
        if cx + r >= plane_lo:
            j0, j1 = axis_range(cy, r, h, ny)
            rows = ranges[row : row + j1 - j0]
            _shell_grey(i, cx, cy, cz, r, h, ny, status, mask, rows, scratch, proven, chords, out)
            row += j1 - j0
    _grey_full_multi(status, mask, out)


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
        rows = np.empty((4, SUB * SUB))
        proven = np.empty(SUB * SUB, dtype=np.bool_)
        chords = np.empty((2, SUB * SUB), dtype=np.int32)
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
                    rows,
                    proven,
                    chords,
                    out[p],
                )
            else:
                _voxelize_plane(
                    i, images, order, xmin_sorted, r_max, h, ny, nz, status, mask, scratch, words, out[p]
                )
