"""Numba kernels of the grey-value voxelisation (§4.7.2): 6x6x6 sample points per voxel, counted in the matrix.

Sample point k (0..5) of voxel i along an axis sits at ``(6*i + k + 0.5) * (a/6)``: every kernel computes it with
:func:`porepipe._shared.sample_points.sample_coord`, and a point is in the matrix when
``dx*dx + dy*dy + dz*dz <= r*r`` for some sphere image, in exactly this order of operations — that is what makes the
shell method bit-identical to brute force.

Brute force (:func:`_voxelize_plane`) tests all 216 points of every voxel near a sphere. The shell method
(:func:`_shell_plane`) classifies whole voxel rows first: per voxel row (fixed x, y) and ball, square roots give the
run of voxels wholly inside (set to 216 without a test) and the shell around it (:func:`_classify`). Only shell
voxels are tested, with the exact predicate: the smallest and largest squared distance of a voxel's samples decide an
empty or full voxel in one test each (rounding is monotone), the others get all 216 tests in one branch-free loop
that vectorises over the 36 sample rows (:func:`_voxel_count`): counted straight into a voxel one ball alone
reaches, ORed as bit masks into voxels that two or more balls reach.
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


#: voxel state of the shell method beyond those of :mod:`porepipe._shared.sample_points`: two or more spheres reach
#: into the voxel (its grey value is the popcount of the union mask, not the count of one ball)
MULTI = 3
assert (UNTOUCHED, PARTIAL, FULL, MULTI) == (0, 1, 2, 3)  # the branch-free step of _reach_shell relies on it


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
def _classify(i, cx, cy, cz, r, h, ny, nz, status, mask, ranges, out):
    """Mark the voxels of plane ``i`` that one ball reaches, by whole runs per voxel row (:func:`_row_ranges`).

    The run inside the ball becomes FULL (grey value 216 in ``out``), the shell on either side one more reaching
    sphere (:func:`_reach_shell`).
    Row ``j`` of the ball's y range ``[j0, j1)`` (:func:`porepipe._shared.sample_points.axis_range`) keeps its
    ranges and ``j`` in ``ranges[j - j0]`` (lo, hi, f_lo, f_hi, j) for :func:`_shell_grey`.
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
        ranges[j - j0, 4] = j
        _reach_shell(status, mask, j, lo, f_lo)
        for k in range(f_lo, f_hi):
            status[j, k] = FULL
            out[j, k] = N_SAMPLES
        _reach_shell(status, mask, j, f_hi, hi)


#: sample rows per voxel row: the 36 (x, y) rows q = 6·sx + sy, padded to a multiple of the vector width with rows at
#: squared distance FAR, none of whose samples is ever inside (r*r < FAR for every finite radius below 1e150 µm)
N_ROWS = 40
FAR = 1e300


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _row_distances(dx2, dx2_min, dx2_max, j, cy, h, dxy):
    """Squared (x, y) distances ``dx2[sx] + dy*dy`` of the 36 sample rows of voxel row ``j`` into ``dxy``; (min, max).

    The same operations as :func:`_mark_points` (``dy`` from :func:`porepipe._shared.sample_points.sample_coord`).
    Rounding is monotone in each term, so the smallest (largest) sum is the sum of the smallest (largest) terms.
    """
    dy2_min = np.inf
    dy2_max = 0.0
    for sy in range(SUB):
        dy = sample_coord(j, sy, h) - cy
        dy2 = dy * dy
        dy2_min = min(dy2_min, dy2)
        dy2_max = max(dy2_max, dy2)
        for sx in range(SUB):
            dxy[SUB * sx + sy] = dx2[sx] + dy2
    return dx2_min + dy2_min, dx2_max + dy2_max


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _z_distances(k, cz, h):
    """Squared z distances of the 6 samples of voxel ``k`` along z (as in :func:`_mark_points`), with their min, max."""
    d0 = sample_coord(k, 0, h) - cz
    d1 = sample_coord(k, 1, h) - cz
    d2 = sample_coord(k, 2, h) - cz
    d3 = sample_coord(k, 3, h) - cz
    d4 = sample_coord(k, 4, h) - cz
    d5 = sample_coord(k, 5, h) - cz
    t = (d0 * d0, d1 * d1, d2 * d2, d3 * d3, d4 * d4, d5 * d5)
    return t, min(t), max(t)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _voxel_count(dxy, d_min, d_max, k, cz, r2, h):
    """Samples of voxel ``k`` of a voxel row inside the ball: all 216 exact tests ``dxy + dz*dz <= r*r``, vectorised.

    ``dxy`` (N_ROWS) and its min/max over the 36 rows from :func:`_row_distances`. Rounding is monotone, so when the
    smallest squared distance fails the test no sample passes (0), and when the largest passes all do (216).
    """
    t, t_min, t_max = _z_distances(k, cz, h)
    if d_min + t_min > r2:
        return 0
    if d_max + t_max <= r2:
        return N_SAMPLES
    t0, t1, t2, t3, t4, t5 = t
    total = 0
    for q in range(N_ROWS):  # branch-free: vectorises over the rows
        d = dxy[q]
        total += (
            np.int64(d + t0 <= r2)
            + np.int64(d + t1 <= r2)
            + np.int64(d + t2 <= r2)
            + np.int64(d + t3 <= r2)
            + np.int64(d + t4 <= r2)
            + np.int64(d + t5 <= r2)
        )
    return total


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _or_voxel(mask, j, k, dxy, cz, r2, h, bits):
    """OR the samples of voxel ``k`` inside the ball into its union mask (the 216 tests of :func:`_voxel_count`).

    Row q's 6 bits (bit sz = sample sz along z) are found for all rows in one vectorised loop into ``bits``
    (N_ROWS int64), then packed in the layout of :func:`porepipe._shared.sample_points.or_row`.
    """
    t, _, _ = _z_distances(k, cz, h)
    t0, t1, t2, t3, t4, t5 = t
    for q in range(N_ROWS):
        d = dxy[q]
        bits[q] = (
            np.int64(d + t0 <= r2)
            | (np.int64(d + t1 <= r2) << 1)
            | (np.int64(d + t2 <= r2) << 2)
            | (np.int64(d + t3 <= r2) << 3)
            | (np.int64(d + t4 <= r2) << 4)
            | (np.int64(d + t5 <= r2) << 5)
        )
    for w in range(WORDS):
        acc = np.uint64(0)
        for q in range(ROWS_PER_WORD * w, min(ROWS_PER_WORD * (w + 1), SUB * SUB)):
            acc |= np.uint64(bits[q]) << np.uint64(SUB * (q - ROWS_PER_WORD * w))
        mask[j, k, w] |= acc


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _add_shell(status, mask, j, lo, hi, dxy, d_min, d_max, cz, r2, h, bits, out):
    """Voxels ``lo .. hi - 1`` of row ``j``: add the ball's count to PARTIAL ones, OR its sample bits into MULTI ones."""
    for k in range(lo, hi):
        st = status[j, k]
        if st == PARTIAL:
            out[j, k] += _voxel_count(dxy, d_min, d_max, k, cz, r2, h)
        elif st == MULTI:
            _or_voxel(mask, j, k, dxy, cz, r2, h, bits)


@njit(cache=True, fastmath=FASTMATH)
def _shell_grey(i, cx, cy, cz, r, h, ny, status, mask, ranges, dx2, dxy, bits, out):
    """Add one ball's samples to the shell voxels of plane ``i``: counts into ``out`` (PARTIAL), bits into masks (MULTI).

    Per voxel row with a shell (voxels outside the untested FULL run of :func:`_row_ranges`), the 36 squared (x, y)
    row distances are found once; its PARTIAL and MULTI voxels are then tested, FULL ones (of another ball) skipped. A
    ball that does not reach a PARTIAL voxel adds 0 to it (the reach test is conservative), so summing into ``out``
    leaves the count of the one ball that does. ``ranges``: the
    rows' ranges from :func:`_classify`; ``dx2`` (6), ``dxy`` (N_ROWS, padded with FAR) and ``bits`` (N_ROWS) are
    scratch.
    """
    r2 = r * r
    j0, j1 = axis_range(cy, r, h, ny)
    dx2_min = np.inf
    dx2_max = 0.0
    for sx in range(SUB):
        dx = sample_coord(i, sx, h) - cx
        dx2[sx] = dx * dx
        dx2_min = min(dx2_min, dx2[sx])
        dx2_max = max(dx2_max, dx2[sx])
    for j in range(j0, j1):
        lo, hi, f_lo, f_hi = ranges[j - j0, 0], ranges[j - j0, 1], ranges[j - j0, 2], ranges[j - j0, 3]
        if lo == f_lo and f_hi == hi:
            continue
        d_min, d_max = _row_distances(dx2, dx2_min, dx2_max, j, cy, h, dxy)
        _add_shell(status, mask, j, lo, f_lo, dxy, d_min, d_max, cz, r2, h, bits, out)
        _add_shell(status, mask, j, f_hi, hi, dxy, d_min, d_max, cz, r2, h, bits, out)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _multi_grey(status, mask, j, lo, hi, out):
    """Grey values of the MULTI voxels among ``lo .. hi - 1`` of row ``j``: the popcount of their union masks."""
    for k in range(lo, hi):
        if status[j, k] == MULTI:
            bits = 0
            for w in range(WORDS):
                bits += popcount64(mask[j, k, w])
            out[j, k] = bits


@njit(cache=True, fastmath=FASTMATH)
def _shell_plane(i, images, order, xmin_sorted, r_max, h, ny, nz, status, mask, dx2, dxy, bits, out):
    """Grey values of plane x = i, interior runs in bulk and shell voxels tested (bit-identical to brute force).

    First every ball marks the voxels it reaches (:func:`_classify`: runs of FULL voxels in bulk, the shell one by
    one); then each ball's samples are counted into the shell voxels that it alone reaches and ORed into the masks
    of voxels two or more balls reach (:func:`_shell_grey`), so a sample counts once if it is in any ball; last the
    MULTI voxels in the balls' shells get their masks' popcounts (:func:`_multi_grey`).
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
    ranges = np.empty((n_rows, 5), dtype=np.int64)  # per ball, its voxel rows' ranges (_row_ranges) and j
    row = 0
    for q in range(first, last):
        s = order[q]
        cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
        if cx + r >= plane_lo:
            j0, j1 = axis_range(cy, r, h, ny)
            _classify(i, cx, cy, cz, r, h, ny, nz, status, mask, ranges[row : row + j1 - j0], out)
            row += j1 - j0
    row = 0
    for q in range(first, last):
        s = order[q]
        cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
        if cx + r >= plane_lo:
            j0, j1 = axis_range(cy, r, h, ny)
            rows = ranges[row : row + j1 - j0]
            _shell_grey(i, cx, cy, cz, r, h, ny, status, mask, rows, dx2, dxy, bits, out)
            row += j1 - j0
    for t in range(row):  # every MULTI voxel lies in the shell of a ball that reaches it
        j, lo, hi, f_lo, f_hi = ranges[t, 4], ranges[t, 0], ranges[t, 1], ranges[t, 2], ranges[t, 3]
        _multi_grey(status, mask, j, lo, f_lo, out)
        _multi_grey(status, mask, j, f_hi, hi, out)


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _voxelize_slab(i0, i1, images, order, xmin_sorted, r_max, h, ny, nz, boundary_only, out):
    """Grey values of planes i0..i1-1 into ``out`` (i1 - i0, ny, nz), parallel over planes.

    ``boundary_only`` selects the shell method (:func:`_shell_plane`), else brute force (216 tests per voxel).
    """
    nplanes = i1 - i0
    nthreads = min(nplanes, 64)
    per = (nplanes + nthreads - 1) // nthreads
    for t in prange(nthreads):
        status = np.empty((ny, nz), dtype=np.uint8)
        mask = np.empty((ny, nz, WORDS), dtype=np.uint64)
        dx2 = np.empty(SUB)
        dxy = np.full(N_ROWS, FAR)  # rows 36.. stay FAR: padding without a sample inside
        bits = np.empty(N_ROWS, dtype=np.int64)
        scratch = np.empty((3, SUB))
        words = np.empty(WORDS, dtype=np.uint64)
        for p in range(t * per, min((t + 1) * per, nplanes)):
            i = i0 + p
            if boundary_only:
                _shell_plane(
                    i, images, order, xmin_sorted, r_max, h, ny, nz, status, mask, dx2, dxy, bits, out[p]
                )
            else:
                _voxelize_plane(
                    i, images, order, xmin_sorted, r_max, h, ny, nz, status, mask, scratch, words, out[p]
                )
