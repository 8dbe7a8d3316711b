"""Numba kernels of the grey-value voxelisation (§4.7.2): 6x6x6 sample points per voxel, counted in the matrix.

Sample point k (0..5) of voxel i along an axis sits at ``(6*i + k + 0.5) * (a/6)``: every kernel computes it with
:func:`porepipe._shared.sample_points.sample_coord`, and a point is in the matrix when
``dx*dx + dy*dy + dz*dz <= r*r`` for some sphere image, in exactly this order of operations — that is what makes the
shell method bit-identical to brute force.

Brute force (:func:`_voxelize_plane`) tests all 216 points of every voxel near a sphere. The shell method
(:func:`_shell_plane`) adds the balls one after the other in one pass per plane (:func:`_ball_plane`): per voxel row
(fixed x, y), square roots give the run of voxels wholly inside (written as 216 without a test) and the shell around
it (:func:`_row_ranges`). A shell voxel's first count comes from the chords of its 36 sample rows (the samples
inside along a row form one interval): per voxel row, 36 float32 square roots, vectorised, give every chord once
for all its voxels (:func:`_row_chords`), and a voxel's count is the difference of the chords' prefix sums at its
two ends (:func:`_chord_prefix`; at an end of the row or of its run inside, a sum the chords gave or 36 x the end).
float32 ends are exact unless an end lies within a bounded margin of a sample (:func:`_chord_margin`, 1e-5 to
1e-4 samples on the benchmark's spheres; 0.3 % of first counts); such a voxel row's voxels get the 216 exact
tests instead, in one branch-free loop that vectorises over the 36 sample rows (:func:`_voxel_count`; the squared
z distances of a ball's samples are found once per plane). A voxel keeps the count of the first ball that puts
samples in it and that ball as its ``owner``; when a second ball adds samples, the voxel's grey value becomes
the count of the union of the two balls' samples (from both balls' chords, :func:`_chord_union_count`, or where
either is ambiguous the 2 x 216 tests of :func:`_union_count`), and from a third ball on the popcount of
the union of the balls' sample bit masks (:func:`_share`), so a sample counts once if it is in any ball.

Chords in float64 with every end fixed by exact tests measured slower than the 216 tests (~54 vs 47 ms on spheres
10-20 voxels wide): the square roots and fix-ups of ~36 chords per voxel row cost more than the tests of its ~3
shell voxels. In float32 (8-wide) with the fix-ups replaced by the margin test, the chords of a voxel row take
~31 ns and a voxel's count ~6 ns against ~20 ns for its 216 tests (1 thread, load ~4).

Where the time went before the chords, on spheres 10-20 voxels wide (the benchmark's small case: 1500 balls,
8 Mvoxel, 1 thread, ~46 ms; each part timed by leaving it out): row ranges, runs inside and plane clearing ~8 ms;
the first counts of 1.10 M shell voxels (216 tests, ~21 ns each) ~23 ms; 88.6 k unions (84.6 k of two balls,
4.0 k masks) ~10 ms; row distances and the loop over the shell voxels of 329 k voxel rows ~11 ms. Almost every
first count is partial (3 of 1.10 M are 216, 26 are 0), so no cheap pre-test skips any; filling every ball's runs
inside before counting any shell (two passes per plane, to skip counts that a later ball's run overwrites)
measured equal.

Now (~34 ms there, 1 thread; profiled with perf on the JIT code) the time is spread: row ranges ~20 %, the chords
~16 %, the chord counts ~15 %, row distances and room ~12 %, unions ~9 %, the shell loop's control ~7 %. Tried
and not kept, same run, 1 thread, spheres 10-20 voxels wide: the row ranges taken from the exact chords' extremes
(chords then found for every row) 9 % slower; every row's ranges first, branch-free, 4 % slower (with branches:
equal); row distances in one vectorised 36-row loop equal with the float32 room in it, 6 % slower without; room
computed in the chord loop from float64 (numba then vectorises it 4-wide) 15 % slower; padding the chord loop to
whole 8-wide vectors 0-2 %; the two shells of a row by two calls instead of a loop over both equal.

Session 12 (same run against the kernel before, kernel alone, CPU time, 1 thread, load 1.2-2): the room's
float64-to-float32 loop given a run-time trip count, so that numba vectorises it (a constant one it unrolls
into 36 scalar conversions), ~3 % less time on spheres 10-20 voxels wide; unions of two balls from their
chords (:func:`_chord_union_count`) instead of the 2 x 216 tests, ~6 % more (their cost was ~5 ms of ~32; all
but 0.6 k of the 84.6 k unions take the chords; the owner's are found for 54 k rows). Both together, three
runs: 1.09-1.10x / 1.05-1.07x / 1.06-1.07x on spheres 10-20 / 20-40 / 40-80 voxels wide. Tried and not kept
(spheres 10-20 voxels wide): the 36 row distances in one vectorised loop (run-time trip count) 5 % slower,
with the room in it 3 %; the room after the ranges 4 % slower; every row's chords found first, then the
shells, ~20 % slower; each row's ranges found one row ahead 7 % slower; shell voxels already full counted
branch-free like empty ones 3 % slower; the run inside written in 32-byte blocks (numba makes conditional
scalar stores of them) 6 % slower; the balls' frames found once per call instead of once per plane, the chord
loop over whole vectors and the count loop over N_ROWS equal; both shells of a row in one loop equal; the
chords of every row kept in a per-plane pool, so that unions need not recompute the owner's, +1.4 % / 0-1 % /
-3-0 % on the three sizes. Profiled (perf on the JIT code, 1 thread): chords ~23 %, row ranges ~10 %, chord
counts ~15 %, row distances and room ~15 %; left out, unions and shares take ~13 % (shares 3 %).

Session 13, tried and not kept (kernel alone, CPU time, same run against the kernel before, interleaved, 1 thread,
load 1.1-2.4; spheres 10-20 / 20-40 / 40-80 voxels wide): chord ends and voxel starts in int16 (the counts then take
3 vectors of 16 lanes instead of 5 of 8, as LLVM compiled them) +0.4 % / +0.1 % / +0.5 %, so the counts' arithmetic
is not what limits them; the owner's frame found once per owner instead of per union voxel -2 %; the owner's chords
kept across both shells of a row +0.8 % / +0.4 % / +0.4 %; a ball-plane's row distances and room found in a pre-pass
(so that no vector load waits on the row's 36 scalar stores) -7 % / -6 % / -5 %; room from y distances tiled per
ball-plane -13 % / -15 % / -15 %. More than half the JIT samples (perf, raw addresses) fall in the row block
(distances, room, ranges ~35 %) and the chords (~21 %), spread over many instructions.
Session 14 (kernel alone, CPU time, same run against the kernel before, interleaved, 1 thread, load 1.1-1.6; spheres
10-20 / 20-40 / 40-80 voxels wide): kept, the row ranges from a per-ball frame in voxels (:func:`_ranges_frame`:
each end one square root, one subtraction and one rounding from the reach) +1.3-2.3 % / +1.6-2.1 % / +2.3-2.8 %;
with the squared z distances found only where the exact tests need them (no per-plane pass over the samples in
reach) +3.6 % / +3.6 % / +2.8 %; with the hull gaps branch-free (:func:`porepipe._shared.sample_points.hull_gap`)
+5.7 % / +6.0 % / +5.5 %; a first count stored without testing it for 0, +1.3 % / +2.3 % / +1.3 % (kept as one
branch less, not for its speed). All four against main's kernel (and main's hull gaps), four processes, best of 9
each, load 1.4-1.5: +5.9-7.1 % / +4.5-6.5 % / +3.8-5.8 %; the ratio varies by ~2 % from one process to the next (the
hull gaps alone, four processes: +0.5-3.0 % on spheres 10-20 voxels wide). Tried and not kept: the room straight
from ``r*r - dx*dx`` per plane and ``dy*dy`` per row, the row distances only where needed (-1 % / -1 % / -3 %); rows
with no voxel wholly inside given one shell loop (-1 % / +1 % / -3 %); the run inside found branch-free (square root
of max(inner, 0), empty run by selects) -3 % / -5 % / -2 %; the row loop bounded by the rows in reach (the y range
found as the z range of a row) +0 % / +0 % / -1 %; the owner's frame found once per owner and row again -0 % / -2 %
/ +0 %. Timed by leaving out or doubling (spheres 10-20 voxels wide): unions of two balls ~16 % of the time: the
owner's row distances, room and chords found again ~8.5 % (its row distances alone ~3 %, so the room straight from
``r*r - dx*dx`` for the owner alone would not pay either), the union counts from both balls' chords ~2.7 %; the
chords ~18 %, bound by their 36 float32 square roots per row (5 vectors); the row ranges up to ~20 %.
Session 16 (kernel alone, CPU time, same process against the kernel before, both from numba's cache, 1 thread,
spheres 10-20 voxels wide, load 1.5-4.4): kept, :func:`_ball_plane` with 6 scratch arrays instead of 9 (see there),
1.045-1.079x. Tried on top of it and not kept (each within +-2 % of it, three processes): the ``bits`` scratch
dropped, the ball loop in a function without reference counting that inlines :func:`_ball_plane`, that one inlined
into a :func:`_shell_plane` without reference counting, :func:`_share` with 6 arrays instead of 9 (equal from the
cache; compiled in the process it ran 1.06x the kernel before where this one ran 1.00x), ``error_model="numpy"``,
:func:`_chord_margin` inlined, the owner's frame found once per owner and row; slower: the row's room without storing
its distances (found again where the exact tests need them) -2 to -3 %, a per-call table of every ball's frames
(image, chord and ranges frames in one (N, 10) array in place of the images, so no argument more) -1 to -4 %.
"""

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH, NO_REFCOUNT
from porepipe._shared.sample_points import (
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


#: relative slack (of r + |cz|, µm) on the z extent of a ball in one voxel row: far above the rounding of the square
#: root and divisions of :func:`_row_ranges` (~1e-8 r at worst), far below any voxel
SLACK = 1e-7


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _row_reach(r2, near_xy):
    """r*r*(1 + MARGIN) minus a voxel row's squared near hull distance in x and y: < 0 where the brute-force reach
    test accepts no voxel of the row.
    """
    return r2 * (1.0 + MARGIN) - near_xy


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _ranges_frame(cz, r, h):
    """A ball's frame for :func:`_row_ranges` (µm in, voxels out): ``(a, b, s2)``, with ``s = 1/(6h)`` the voxels per µm,
    ``a = cz*s - (SUB - 0.5)/SUB - eps*s``, ``b = cz*s - 0.5/SUB + eps*s`` and ``s2 = s*s``; ``eps = SLACK*(r + |cz|)``.
    """
    s = 1.0 / (SUB * h)
    eps = SLACK * (r + abs(cz)) * s
    centre = cz * s
    return centre - (SUB - 0.5) / SUB - eps, centre - 0.5 / SUB + eps, s * s


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _row_ranges(frame, r2, near_xy, far_xy, k0, k1):
    """Voxel ranges of one voxel row (fixed x, y) for one ball: ``lo, hi, f_lo, f_hi``.

    ``[lo, hi)`` (within ``[k0, k1)``) holds every voxel that the brute-force reach test (squared hull distance
    within ``r*r*(1 + MARGIN)``) accepts, widened by ``eps`` µm (in ``frame``, from :func:`_ranges_frame`) against
    rounding; ``[f_lo, f_hi)`` inside it the voxels whose whole sample hull is within ``r*r*(1 - MARGIN)``, narrowed
    by ``eps`` (empty as ``f_lo == f_hi == lo``). ``near_xy``/``far_xy``: the squared near/far hull distances in x
    and y. Voxel k's sample hull along z is ``(6k + 0.5 .. 6k + 5.5) h``, so with the half-width ``w`` (µm) of the
    ball in the row, ``lo = ceil((cz - w - eps)/(6h) - 5.5/6)`` and ``hi = floor((cz + w + eps)/(6h) - 0.5/6) + 1``
    (``f_lo``, ``f_hi`` alike with the hull's other end): in voxels, ``w/(6h) = sqrt(reach*s2)``, and the frame's
    constants hold the rest, so that each end is one square root, one subtraction and one rounding from ``reach``.
    The rounding of these few operations (a few ulp of ``|cz|/(6h) + w/(6h)``) is far below ``eps``/(6h)
    (1e-7 relative), which also covers that of the square root near ``reach = 0`` (~1e-8 r).
    """
    reach = _row_reach(r2, near_xy)
    if reach < 0.0:
        return k0, k0, k0, k0
    a, b, s2 = frame
    w = np.sqrt(reach * s2)
    lo = max(int(np.ceil(a - w)), k0)
    hi = min(int(np.floor(b + w)) + 1, k1)
    if lo >= hi:
        return k0, k0, k0, k0
    inner = r2 * (1.0 - MARGIN) - far_xy
    if inner <= 0.0:
        return lo, hi, lo, lo
    wf = np.sqrt(inner * s2)
    f_lo = max(int(np.ceil(b - wf)), lo)
    f_hi = min(int(np.floor(a + wf)) + 1, hi)
    if f_lo >= f_hi:  # also where wf <= eps/(6h): then f_lo >= ceil(cz/(6h) - 0.5/6) > f_hi - 1
        return lo, hi, lo, lo
    return lo, hi, f_lo, f_hi


#: sample rows per voxel row: q = 6·sy + sx (the order is the shell method's own: only popcounts of its masks are
#: read, never a single bit)
N_ROWS = SUB * SUB


#: per sample row q = 6·sy + sx, its sample index sy along y plus 0.5: ``SUB*j + ROW_Y[q]`` is, exactly, the
#: ``SUB*j + sy + 0.5`` of :func:`porepipe._shared.sample_points.sample_coord`
ROW_Y = np.arange(N_ROWS) // SUB + 0.5


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _plane_distances(i, cx, h, dx2):
    """Squared x distances of the samples of voxel plane ``i``, per sample row (``dx2[q]``, sx = q % 6, as in
    :func:`_mark_points`).
    """
    for q in range(N_ROWS):
        dx = sample_coord(i, q % SUB, h) - cx
        dx2[q] = dx * dx


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _row_distances(dx2, j, cy, h, dxy, r2=0.0, room=None):
    """Squared (x, y) distances ``dx2[q] + dy*dy`` of the 36 sample rows of voxel row ``j`` into ``dxy`` (row 6·sy + sx),
    and where ``room`` is given, their room ``r2 - dxy`` too (as :func:`_row_room`).

    The same operations as :func:`_mark_points` (``dy`` from :func:`porepipe._shared.sample_points.sample_coord`,
    its ``SUB*j + sy + 0.5`` as ``SUB*j + ROW_Y[q]``), in one loop over the rows that vectorises: against 6 scalar
    ``dy`` with 36 scalar stores and the room in a loop of its own, whose vector loads waited on those stores, kernel
    alone, same run, 1 thread: ~2.5 % less time on spheres 10-20 voxels wide (the loop without the room: ~0 %).
    """
    row_y = np.float64(SUB * j)
    for q in range(dxy.size):  # a run-time trip count: vectorised
        dy = (row_y + ROW_Y[q]) * h - cy
        d = dx2[q] + dy * dy
        dxy[q] = d
        if room is not None:
            room[q] = np.float32(r2 - d)


# not inline="always" (issue #22): called on the rare paths of :func:`_add_shell` (exact tests, unions), so a plain
# call costs nothing measurable, and numba's IR inlining of it into every call site cost compile time
@njit(cache=True, fastmath=FASTMATH)
def _z_distances(k, cz, h):
    """Squared z distances of the 6 samples of voxel ``k`` along z (as in :func:`_mark_points`)."""
    d0 = sample_coord(k, 0, h) - cz
    d1 = sample_coord(k, 1, h) - cz
    d2 = sample_coord(k, 2, h) - cz
    d3 = sample_coord(k, 3, h) - cz
    d4 = sample_coord(k, 4, h) - cz
    d5 = sample_coord(k, 5, h) - cz
    return d0 * d0, d1 * d1, d2 * d2, d3 * d3, d4 * d4, d5 * d5


# not inline="always" (issue #22): called on the rare paths of :func:`_add_shell` (exact tests, unions), so a plain
# call costs nothing measurable, and numba's IR inlining of it into every call site cost compile time
@njit(cache=True, fastmath=FASTMATH)
def _voxel_count(dxy, t, r2):
    """Samples of a voxel of a voxel row inside the ball: all 216 exact tests ``dxy + dz*dz <= r*r``, vectorised.

    ``dxy`` (N_ROWS) from :func:`_row_distances`; ``t`` the squared z distances of the voxel's 6 samples
    (:func:`_z_distances`). No early exit for empty or full voxels: shell voxels are mostly partly filled, and the
    branch cost more than it saved (measured).
    """
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


#: unit roundoff of float64 and float32
U64 = 2.0**-53
U32 = 2.0**-24
#: a row whose chord half-width (samples) is below this is grazed by the surface: its voxels get the 216 tests
W_LOW = 0.02


@njit(cache=True, fastmath=FASTMATH)
def _chord_margin(cz, r, h):
    """Distance (samples) from the nearest integer that a float32 chord end of :func:`_row_chords` must keep for
    the chord to hold exactly the samples that pass ``dxy + dz*dz <= r*r`` (float64): its own error (float32,
    ~4 roundings of W, W <= r/h), plus how far a sample may sit from the real chord end and still round the other
    way. The latter: the float64 test errs by at most E = 7u(r + a + |cz|)^2 in squared distance (roundings of the
    sample coordinate, dz, dz*dz and the sum), a sample |m - end| samples from the end differs from r*r - dxy by at
    least h^2 |m - end| W, and W > W_LOW / 2 where the chord is used. Bounds taken 2x generous or more.
    """
    e = cz / h - 0.5
    width = r / h
    own = 8.0 * U32 * (width + 2.0) + 4.0 * U64 * (abs(e) + 1.0)
    rounding = 16.0 * U64 * (r + SUB * h + abs(cz)) ** 2 / (h * h)
    return own + rounding / (0.5 * W_LOW)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _row_room(dxy, r2, room):
    """``r*r - dxy`` of the 36 sample rows of a voxel row (``dxy`` from :func:`_row_distances`) into ``room``:
    subtracted in float64 (its sign is exact), stored in float32 for :func:`_row_chords`.

    The trip count is ``dxy.size`` (N_ROWS), known only at run time: numba then vectorises the loop, where over the
    constant N_ROWS it unrolls it into scalar conversions (~3 % of the time on spheres 10-20 voxels wide, same run,
    1 thread). Done as soon as the row is known to meet the ball, before its ranges (:func:`_row_ranges`), so that
    the chords' vector loads do not wait on them (against finding it with the chords, same run, 1 thread: ~3 % less
    time on spheres 10-20 voxels wide).
    """
    for q in range(dxy.size):  # < 0: no sample of the row is inside (fl(dxy + dz*dz) >= dxy > r*r)
        room[q] = np.float32(r2 - dxy[q])


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _row_chords(room, e_frac, inv_h, margin, ends):
    """Chords of the 36 sample rows of a voxel row through the ball (``room`` from :func:`_row_room`): samples
    ``ends[0, q] .. ends[1, q] - 1`` (int32) of row q are inside, as sample index minus ``floor(e)``, with
    ``e = cz/h - 0.5`` the ball centre in samples and ``e_frac = e - floor(e)``; empty where ``room < 0``.

    float32, vectorised 8-wide; returns ``(ambiguous, lo_sum, hi_sum)``: ambiguous is True where any end is within
    ``margin`` (:func:`_chord_margin`) of a sample or a row is grazed (half-width below W_LOW): then the chords may
    miss or add a sample and the caller tests the 216 samples instead (exact); the sums are those of the chords'
    starts and ends (int32, for :func:`_end_prefix`).
    """
    zero = np.float32(0.0)
    half = np.float32(0.5)
    one = np.float32(1.0)
    low = np.float32(W_LOW)
    ambiguous = False
    lo_sum = np.int32(0)
    hi_sum = np.int32(0)
    for q in range(N_ROWS):  # branch-free: float32 only, vectorises 8-wide
        t = room[q]
        w = np.sqrt(max(t, zero)) * inv_h
        hi = e_frac + w
        lo = e_frac - w
        f_hi = np.floor(hi)
        f_lo = np.floor(lo)
        near = half - max(
            abs(hi - f_hi - half), abs(lo - f_lo - half)
        )  # distance of the nearer end to a sample
        ambiguous |= (t >= zero) & ((w < low) | (near <= margin))
        start = np.int32(f_lo + one)
        stop = np.int32(f_hi + one)
        ends[0, q] = start
        ends[1, q] = stop
        lo_sum = np.int32(lo_sum + start)
        hi_sum = np.int32(hi_sum + stop)
    return ambiguous, lo_sum, hi_sum


#: a voxel row's chords: not found yet, found exact, ambiguous (its voxels get the 216 tests)
CHORDS_UNKNOWN, CHORDS_EXACT, CHORDS_AMBIGUOUS = -1, 0, 1

#: 32-bit lanes of a 256-bit vector; the chord arrays hold N_ROWS rounded up to LANES (extra rows: empty chords)
LANES = 8
CHORD_ROWS = LANES * ((N_ROWS + LANES - 1) // LANES)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _chord_prefix(ends, base):
    """Sum over the row chords (:func:`_row_chords`) of ``clamp(base, lo, hi)``: the row's samples inside the ball
    before sample ``base`` (int32, relative as the chords) plus the sum of the chords' starts, so that a voxel's
    count is the difference of the prefixes at its two ends (:func:`_add_shell`); vectorised 8-wide, in int32 (kept
    there by the casts; numba would widen to int64).
    """
    total = np.int32(0)
    for q in range(CHORD_ROWS):
        total = np.int32(total + min(max(ends[0, q], base), ends[1, q]))
    return np.int64(total)


#: how the chord prefix at an end of a shell is found: the sum of the chords' starts (the row's first voxel, not
#: clipped: no chord starts before it) or ends (its last, likewise), N_ROWS times the base (a boundary of the run
#: wholly inside, which every chord covers), or a pass over the chords
END_SUM, END_INSIDE, END_PASS = 0, 1, 2


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _end_prefix(ends, kind, chord_sum, base):
    """:func:`_chord_prefix` at ``base``, an end of a shell, found as ``kind`` says (END_SUM: it is ``chord_sum``)."""
    if kind == END_SUM:
        return chord_sum
    if kind == END_INSIDE:
        return N_ROWS * np.int64(base)
    return _chord_prefix(ends, np.int32(base))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _or_voxel(mask, j, k, dxy, t, r2, bits):
    """OR the samples of voxel ``k`` inside the ball into its union mask (the 216 tests of :func:`_voxel_count`).

    ``t``: the voxel's 6 squared z distances. Row q's 6 bits (bit sz = sample sz along z), shifted to bits
    6·(q // 4) .. + 5 of word q % 4, are found for all rows in one vectorised loop into ``bits`` (N_ROWS int64), then
    ORed word by word.
    """
    t0, t1, t2, t3, t4, t5 = t
    for q in range(N_ROWS):  # row q in bits 6 (q // 4) .. + 5 of word q % 4
        d = dxy[q]
        bits[q] = (
            np.int64(d + t0 <= r2)
            | (np.int64(d + t1 <= r2) << 1)
            | (np.int64(d + t2 <= r2) << 2)
            | (np.int64(d + t3 <= r2) << 3)
            | (np.int64(d + t4 <= r2) << 4)
            | (np.int64(d + t5 <= r2) << 5)
        ) << (SUB * (q // WORDS))
    a0 = a1 = a2 = a3 = 0
    for g in range(0, N_ROWS, WORDS):
        a0 |= bits[g]
        a1 |= bits[g + 1]
        a2 |= bits[g + 2]
        a3 |= bits[g + 3]
    mask[j, k, 0] |= np.uint64(a0)
    mask[j, k, 1] |= np.uint64(a1)
    mask[j, k, 2] |= np.uint64(a2)
    mask[j, k, 3] |= np.uint64(a3)


#: ``owner`` of a voxel whose grey value is the popcount of its union mask (three or more balls put samples in it);
#: two balls ``o`` and ``second[j, k]`` are ``owner = PAIR - o`` (<= PAIR), one ball is its index (>= 0)
SHARED = -1
PAIR = -2


# not inline="always" (issue #22): called on the rare paths of :func:`_add_shell` (exact tests, unions), so a plain
# call costs nothing measurable, and numba's IR inlining of it into every call site cost compile time
@njit(cache=True, fastmath=FASTMATH)
def _ball_rows(i, j, b, images, h, dx2, dxy):
    """Row distances of ball ``b`` in voxel row (i, j) into ``dxy`` (``dx2`` scratch); returns its r*r."""
    _plane_distances(i, images[b, 0], h, dx2)
    _row_distances(dx2, j, images[b, 1], h, dxy)
    return images[b, 3] * images[b, 3]


# not inline="always" (issue #22): called on the rare paths of :func:`_add_shell` (exact tests, unions), so a plain
# call costs nothing measurable, and numba's IR inlining of it into every call site cost compile time
@njit(cache=True, fastmath=FASTMATH)
def _union_count(da, ta, ra2, db, tb, rb2):
    """Samples of a voxel inside ball a or ball b (row distances ``da``/``db``, squared z distances ``ta``/``tb``):
    the 2 x 216 exact tests of :func:`_voxel_count`, ORed per sample and counted, vectorised over the rows.
    """
    a0, a1, a2, a3, a4, a5 = ta
    b0, b1, b2, b3, b4, b5 = tb
    total = 0
    for q in range(N_ROWS):
        d = da[q]
        e = db[q]
        total += (
            np.int64((d + a0 <= ra2) | (e + b0 <= rb2))
            + np.int64((d + a1 <= ra2) | (e + b1 <= rb2))
            + np.int64((d + a2 <= ra2) | (e + b2 <= rb2))
            + np.int64((d + a3 <= ra2) | (e + b3 <= rb2))
            + np.int64((d + a4 <= ra2) | (e + b4 <= rb2))
            + np.int64((d + a5 <= ra2) | (e + b5 <= rb2))
        )
    return total


@njit(cache=True, fastmath=FASTMATH, **NO_REFCOUNT)
def _share(i, j, k, images, h, owner, second, mask, dxy, t, r2, dx2, odxy, bits, out):
    """A ball (row distances ``dxy``, squared z distances ``t`` of voxel k) adds samples to voxel (j, k), where two
    or more balls counted before (PAIR or SHARED).

    From PAIR, the mask starts as the two balls' samples (:func:`_or_voxel`; their row distances recomputed into
    ``dx2``/``odxy``) and the voxel becomes SHARED; then this ball's samples are ORed in, and the grey value is the
    mask's popcount. (A third ball on one partly filled voxel is rare; masks cost ~3x a count.)
    """
    o = owner[j, k]
    if o != SHARED:
        for w in range(WORDS):
            mask[j, k, w] = 0
        for n in range(2):
            b = np.int64(PAIR - o) if n == 0 else np.int64(second[j, k])
            rb2 = _ball_rows(i, j, b, images, h, dx2, odxy)
            _or_voxel(mask, j, k, odxy, _z_distances(k, images[b, 2], h), rb2, bits)
        owner[j, k] = SHARED
    _or_voxel(mask, j, k, dxy, t, r2, bits)
    count = 0
    for w in range(WORDS):
        count += popcount64(mask[j, k, w])
    out[j, k] = count


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _ball_frame(cz, r, h):
    """A ball's frame for its chords (:func:`_row_chords`): ``floor(e)``, ``e - floor(e)`` (float32) and the margin
    (:func:`_chord_margin`), with ``e = cz/h - 0.5`` its centre in samples along z.
    """
    e = cz / h - 0.5
    e_int = np.int64(np.floor(e))
    return e_int, np.float32(e - e_int), np.float32(_chord_margin(cz, r, h))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _chords_state(room, ends, frame, h):
    """Find a voxel row's chords (:func:`_row_chords`) in the ball's ``frame``: CHORDS_EXACT or CHORDS_AMBIGUOUS, and
    the sums of the chords' starts and ends (int64).
    """
    ambiguous, lo_sum, hi_sum = _row_chords(room, frame[1], np.float32(1.0 / h), frame[2], ends)
    return CHORDS_AMBIGUOUS if ambiguous else CHORDS_EXACT, (np.int64(lo_sum), np.int64(hi_sum))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _chord_union_count(count_a, ends_a, base_a, ends_b, base_b):
    """Samples of a voxel inside ball a or ball b from both balls' exact row chords (:func:`_row_chords`):
    ``count_a`` (ball a's own count) plus, per row, b's overlap with the voxel less that of the intersection of the
    two chords. ``base_a``/``base_b``: the voxel's first sample in each ball's frame (as for :func:`_chord_prefix`);
    int32, vectorised 8-wide.
    """
    zero = np.int32(0)
    six = np.int32(SUB)
    extra = np.int32(0)
    for q in range(CHORD_ROWS):
        lo_a = max(np.int32(ends_a[0, q] - base_a), zero)
        hi_a = min(np.int32(ends_a[1, q] - base_a), six)
        lo_b = max(np.int32(ends_b[0, q] - base_b), zero)
        hi_b = min(np.int32(ends_b[1, q] - base_b), six)
        both = max(np.int32(min(hi_a, hi_b) - max(lo_a, lo_b)), zero)
        extra = np.int32(extra + max(np.int32(hi_b - lo_b), zero) - both)
    return count_a + np.int64(extra)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _add_shell(
    i, j, k0, k1, s, images, h, dxy, r2, chords, frame, chord_row, owner, second, mask, dx2, odxy, bits, out
):
    """Count ball ``s``'s samples into the shell voxels ``k0 .. k1 - 1`` of row ``j``.

    A voxel nothing counted in yet (0) takes the ball's count (from the row chords, ``chords = (room, ends,
    end_kinds)``, row 0 of the first two, or where they are ambiguous the 216 tests of :func:`_voxel_count`) and
    ``s`` as its owner; a full one (216) stays; one that a single ball counted in before gets the count of the union
    of the two balls' samples and becomes PAIR: from both balls' chords (:func:`_chord_union_count`; the owner's in row 1
    of ``chords``, its row distances in ``odxy``, both kept for the next voxel of the row), or where either is
    ambiguous the 2 x 216 tests of :func:`_union_count`; one that two or more counted in gets the union of the
    balls' masks (:func:`_share`).

    The chords are found at the row's first voxel that needs them (``state`` CHORDS_UNKNOWN until then; ``frame``
    from :func:`_ball_frame`): a row whose shell voxels earlier balls have all filled needs none (against
    finding them for every row, same run, 1 thread: 2.5 % / 4 % / 7 % less time on spheres 10-20 / 20-40 / 40-80
    voxels wide). ``chord_row = (state, sums)``: the state and the sums of the chords' starts and ends
    (:func:`_row_chords`); returned for the row's other shell.

    A first count from the chords is the difference of the chord prefixes (:func:`_chord_prefix`) at the voxel's two
    ends, the lower one kept from the voxel before: a shell of n voxels takes n - 1 passes over the chords, as
    ``end_kinds`` (:func:`_end_prefix`) give the prefixes at its two ends without one. At the row's first voxel
    (not clipped by the grid) the prefix is the sum of the chords' starts, past its last the sum of their ends, and
    at a boundary of the run wholly inside N_ROWS times the boundary (every chord covers that run). Against one pass
    of 36 overlaps per voxel, 0.68 M passes instead of 1.10 M on spheres 10-20 voxels wide.
    """
    room, ends, end_kinds = chords
    state, sums = chord_row
    prefix_at, prefix = -1, np.int64(0)  # the chord prefix at the start of voxel prefix_at
    cached = -1  # the ball whose row distances odxy and chords (row 1) hold
    owner_state = CHORDS_UNKNOWN
    for k in range(k0, k1):
        g = out[j, k]
        if g == N_SAMPLES:
            continue
        if state == CHORDS_UNKNOWN:
            state, sums = _chords_state(room[0], ends[0], frame, h)
        if g == 0:
            if state == CHORDS_AMBIGUOUS:
                c = _voxel_count(dxy, _z_distances(k, images[s, 2], h), r2)
            else:
                base = SUB * k - frame[0]
                if prefix_at != k:
                    prefix = _end_prefix(ends[0], end_kinds[0] if k == k0 else END_PASS, sums[0], base)
                if k + 1 == k1:
                    upper = _end_prefix(ends[0], end_kinds[1], sums[1], base + SUB)
                else:
                    upper = _chord_prefix(ends[0], np.int32(base + SUB))
                c = upper - prefix
                prefix_at, prefix = k + 1, upper
            # stored without a test for c == 0 (26 of 1.10 M first counts): an owner is read only at 1..215
            out[j, k] = c
            owner[j, k] = s
            continue
        o = np.int64(owner[j, k])
        if o >= 0:
            ro = images[o, 3]
            if o != cached:
                _ball_rows(i, j, o, images, h, dx2, odxy)
                cached = o
                owner_state = CHORDS_UNKNOWN
            ocz = images[o, 2]
            o_frame = _ball_frame(ocz, ro, h)
            if owner_state == CHORDS_UNKNOWN and state == CHORDS_EXACT:
                _row_room(odxy, ro * ro, room[1])
                owner_state = _chords_state(room[1], ends[1], o_frame, h)[0]
            if state == CHORDS_EXACT and owner_state == CHORDS_EXACT:
                base = SUB * k
                out[j, k] = _chord_union_count(
                    np.int64(g), ends[1], np.int32(base - o_frame[0]), ends[0], np.int32(base - frame[0])
                )
            else:
                t = _z_distances(k, images[s, 2], h)
                out[j, k] = _union_count(odxy, _z_distances(k, ocz, h), ro * ro, dxy, t, r2)
            owner[j, k] = PAIR - o
            second[j, k] = s
        else:
            t = _z_distances(k, images[s, 2], h)
            _share(i, j, k, images, h, owner, second, mask, dxy, t, r2, dx2, odxy, bits, out)
            cached = -1
    return state, sums


@njit(cache=True, fastmath=FASTMATH, **NO_REFCOUNT)
def _ball_plane(i, s, images, h, owners, mask, dist, bits, room, ends, out):
    """Add ball ``s`` to plane ``i``: per voxel row its run inside as 216, its shell voxels counted (exact).

    ``owners`` (2, ny, nz) int32 holds ``owner`` and ``second`` (:func:`_add_shell`); ``dist`` (4, N_ROWS) the
    squared x distances of this ball's samples and an earlier ball's, then ``dxy`` and ``odxy``; ``bits`` (N_ROWS),
    ``room`` (2, CHORD_ROWS) float32 and ``ends`` (2, 2, CHORD_ROWS) int32 (row 0: this ball's, row 1: an earlier
    ball's), zero from column N_ROWS on, are scratch. The squared z distances of a voxel's samples are found where
    the exact tests need them (:func:`_z_distances`), not for every sample in reach once per plane: the exact tests
    run on 0.3 % of first counts and on few unions.

    Called once per ball and plane (27.5 k calls on spheres 10-20 voxels wide), so its arguments are few arrays: a
    numba array argument is 7-11 machine words, all passed at every call. Against 9 scratch arrays (owner, second,
    dx2, dxy, odxy apart) and ``ny``/``nz``, 6 arrays: kernel alone, CPU time, 1 thread, same process against the
    kernel before, both from numba's cache, best of 9-13, load 1.4-1.9, 1.045-1.079x on spheres 10-20 voxels wide
    (seven processes), 1.051x on 20-40, 1.016x on 40-80; the same with three more (unused) array arguments ran as
    the kernel before. Also tried, no better than this within the noise: the ``bits`` scratch dropped (one array
    less), the ball loop moved into a function without reference counting that inlines this one (no call per ball),
    or this one inlined into :func:`_shell_plane` compiled without reference counting (earlier, inlined into a
    :func:`_shell_plane` with reference counting, it ran 0.61-0.66x).
    """
    owner, second = owners[0], owners[1]
    dxy, odxy = dist[2], dist[3]
    ny, nz = out.shape
    cx, cy, cz, r = images[s, 0], images[s, 1], images[s, 2], images[s, 3]
    r2 = r * r
    nx_, fx_ = hull_gap(cx, i, h)
    j0, j1 = axis_range(cy, r, h, ny)
    k0, k1 = axis_range(cz, r, h, nz)
    _plane_distances(i, cx, h, dist[0])
    frame = _ball_frame(cz, r, h)
    z_frame = _ranges_frame(cz, r, h)
    for j in range(j0, j1):
        ny_, fy_ = hull_gap(cy, j, h)
        near_xy = nx_ * nx_ + ny_ * ny_
        if _row_reach(r2, near_xy) < 0.0:  # before the row's distances and room, which its ranges then follow
            continue
        _row_distances(dist[0], j, cy, h, dxy, r2, room[0])
        lo, hi, f_lo, f_hi = _row_ranges(z_frame, r2, near_xy, fx_ * fx_ + fy_ * fy_, k0, k1)
        if f_hi > f_lo:  # a slice fill: ~2x faster than a loop over these short runs (measured)
            out[j, f_lo:f_hi] = np.uint8(N_SAMPLES)
        if lo < f_lo or f_hi < hi:
            chord_row = (CHORDS_UNKNOWN, (np.int64(0), np.int64(0)))
            first_end = END_SUM if lo > k0 else END_PASS
            last_end = END_SUM if hi < k1 else END_PASS
            inner_end = END_INSIDE if f_hi > f_lo else first_end
            for k_a, k_b, end_kinds in (
                (lo, f_lo, (first_end, END_INSIDE)),
                (f_hi, hi, (inner_end, last_end)),
            ):
                chord_row = _add_shell(
                    i,
                    j,
                    k_a,
                    k_b,
                    s,
                    images,
                    h,
                    dxy,
                    r2,
                    (room, ends, end_kinds),
                    frame,
                    chord_row,
                    owner,
                    second,
                    mask,
                    dist[1],
                    odxy,
                    bits,
                    out,
                )


@njit(cache=True, fastmath=FASTMATH)
def _shell_plane(i, images, order, xmin_sorted, r_max, h, ny, nz, shell, out):
    """Grey values of plane x = i, ball after ball in one pass (bit-identical to brute force).

    ``shell``: the scratch of :func:`_plane_scratch` that :func:`_ball_plane` takes; its ``owners`` (2, ny, nz)
    int32 and ``mask`` (ny, nz, WORDS) need no clearing: they are read only in voxels whose grey value a ball of
    this plane has already set to 1..215.
    """
    owners, mask, dist, bits, room, ends = shell
    out[:, :] = 0
    plane_lo, first, last = plane_candidates(i, h, xmin_sorted, r_max)
    for q in range(first, last):
        s = order[q]
        if images[s, 0] + images[s, 3] >= plane_lo:
            _ball_plane(i, s, images, h, owners, mask, dist, bits, room, ends, out)


@njit(cache=True, fastmath=FASTMATH)
def _plane_scratch(ny, nz):
    """One thread's scratch, reused plane after plane: (status, the shell method's (:func:`_shell_plane`), and brute
    force's two arrays besides status and mask (:func:`_voxelize_plane`)).
    """
    shell = (
        np.empty((2, ny, nz), dtype=np.int32),  # owner, second
        np.empty((ny, nz, WORDS), dtype=np.uint64),  # mask
        np.empty((4, N_ROWS)),  # dist: dx2 (this ball's, an earlier one's), dxy, odxy
        np.empty(N_ROWS, dtype=np.int64),  # bits
        np.zeros((2, CHORD_ROWS), dtype=np.float32),  # room (this ball's, an earlier one's)
        np.zeros((2, 2, CHORD_ROWS), dtype=np.int32),  # ends: zero (empty chords) from row N_ROWS on
    )
    status = np.empty((ny, nz), dtype=np.uint8)
    return status, shell, np.empty((3, SUB)), np.empty(WORDS, dtype=np.uint64)  # brute force: scratch, words


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _voxelize_slab(i0, i1, images, order, xmin_sorted, r_max, h, ny, nz, boundary_only, out, tasks=64):
    """Grey values of planes i0..i1-1 into ``out`` (i1 - i0, ny, nz), parallel over ``tasks`` blocks of planes.

    ``boundary_only`` selects the shell method (:func:`_shell_plane`), else brute force (216 tests per voxel). Each
    block allocates its scratch once (:func:`_plane_scratch`); the callers pass one block per thread
    (:func:`porepipe.voxelize._api.run_slab`).
    """
    nplanes = i1 - i0
    ntasks = max(1, min(nplanes, tasks))
    per = (nplanes + ntasks - 1) // ntasks
    for t in prange(ntasks):
        status, shell, brute, words = _plane_scratch(ny, nz)
        for p in range(t * per, min((t + 1) * per, nplanes)):
            i = i0 + p
            if boundary_only:
                _shell_plane(i, images, order, xmin_sorted, r_max, h, ny, nz, shell, out[p])
            else:
                _voxelize_plane(
                    i, images, order, xmin_sorted, r_max, h, ny, nz, status, shell[1], brute, words, out[p]
                )
