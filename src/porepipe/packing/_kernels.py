"""numba kernels of the DEM packing: pair law, neighbour lists, the damped Störmer-Verlet step, reductions.

Only ``_``-prefixed kernels and the kernel factory live here: arrays in, preallocated arrays out, no validation.
Axis order (x, y, z); lengths in µm; sphere indices and counters are int64.
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, prange
from numba.core import cgutils
from numba.core import types as nbtypes
from numba.extending import intrinsic

from porepipe._shared.numba_config import FASTMATH, NO_REFCOUNT, by_threads

#: one-thread calls on arrays up to this many elements (~1 300 spheres) run the serial kernels: they compile in half
#: the time, but step 2.2x slower than the parallel code on one thread, so only short runs of small packings gain
_SERIAL_MAX = 2**12

#: exponents of the generalised Lennard-Jones branch (5.2.2); the closed forms below assume m = 2n = 16
LJ_M = 16
LJ_N = 8
_NEG_INF = -np.inf


# ---------------------------------------------------------------------------------------------------------------------
# pair law (§5.2)
@njit(cache=True, fastmath=FASTMATH, inline="always")
def _pair_dxeq(r_i, r_j, sigma_pair):
    """Equilibrium distance dx_eq = r_i + r_j - sigma/2 * (r_i + r_j - |r_i - r_j|)."""
    rsum = r_i + r_j
    return rsum - 0.5 * sigma_pair * (rsum - abs(r_i - r_j))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _pair_force(dx, dxeq, k):
    """Radial pair force f(dx) (positive = repulsive) of the harmonic core + (16, 8) Lennard-Jones tail.

    f = sqrt(k) (1 + k/4) / dx_eq * (1 - dx/dx_eq)              for dx <= dx_eq,
    f = 4 k / dx * u^8 (u^8 - 1),  u = dx_eq / dx               for dx >  dx_eq,
    which is k [m b^m / dx^(m+1) - n b^n / dx^(n+1)] with b^8 = dx_eq^8 / 2.
    """
    if dx <= dxeq:
        return math.sqrt(k) * (1.0 + 0.25 * k) / dxeq * (1.0 - dx / dxeq)
    u = dxeq / dx
    u2 = u * u
    u4 = u2 * u2
    u8 = u4 * u4
    return 4.0 * k / dx * u8 * (u8 - 1.0)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _pair_force_over_dist(dx, dxeq, k, hcoef):
    """f(dx) / dx of :func:`_pair_force` for dx > 0, with hcoef = sqrt(k) (1 + k/4) precomputed per type pair.

    The step kernel's hot path: both branches from one reciprocal q = 1 / (dx dx_eq^2) (u = dx_eq / dx = dx_eq^3 q,
    1 / dx^2 = u^2 dx q), then a select instead of a branch that the processor would mispredict half the time.
    """
    q = 1.0 / (dx * dxeq * dxeq)
    harmonic = hcoef * (dxeq - dx) * q
    u = dxeq * dxeq * dxeq * q
    u2 = u * u
    u4 = u2 * u2
    u8 = u4 * u4
    lj = 4.0 * k * u2 * dx * q * u8 * (u8 - 1.0)
    return harmonic if dx <= dxeq else lj


@njit(cache=True, fastmath=FASTMATH)
def _pair_potential(dx, dxeq, k):
    """Pair potential V(dx) whose negative derivative is :func:`_pair_force` (continuous at dx_eq, V(dx_eq) = -k/4)."""
    vmin = -0.25 * k
    if dx <= dxeq:
        t = 1.0 - dx / dxeq
        return 0.5 * (1.0 - vmin) * math.sqrt(k) * t * t + vmin
    u = dxeq / dx
    u2 = u * u
    u4 = u2 * u2
    u8 = u4 * u4
    return k * (0.25 * u8 * u8 - 0.5 * u8)


@njit(cache=True, fastmath=FASTMATH)
def _splitmix(z):
    """SplitMix64 finaliser on a uint64 (counter-based random numbers: same value for any thread count)."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True, fastmath=FASTMATH)
def _uniform(seed, a, b, c):
    """Uniform double in [0, 1) from the counter (seed, a, b, c)."""
    z = _splitmix(
        np.uint64(seed) ^ _splitmix(np.uint64(a) ^ _splitmix(np.uint64(b) ^ _splitmix(np.uint64(c))))
    )
    return (z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _tie_direction(i, j):
    """Push direction (x, y, z) on sphere id i from sphere id j when their centres coincide.

    A unit vector drawn from the unordered pair, with the sign flipped for the other partner, so that
    f_ij = -f_ji holds exactly (Newton's third law) even at dx = 0.
    """
    a = min(i, j)
    b = max(i, j)
    ux = _uniform(0x5EED, a, b, 0) - 0.5
    uy = _uniform(0x5EED, a, b, 1) - 0.5
    uz = _uniform(0x5EED, a, b, 2) - 0.5
    norm = math.sqrt(ux * ux + uy * uy + uz * uz) + 1e-300
    sign = 1.0 if i < j else -1.0
    return sign * ux / norm, sign * uy / norm, sign * uz / norm


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _tie_axis(i, j, axis):
    """Component ``axis`` of :func:`_tie_direction` (for the earlier kernels of ``benchmarks/_pack_previous.py``)."""
    return _tie_direction(i, j)[axis]


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _min_image(d, length, periodic):
    """Minimum image of a difference of two coordinates that both lie in [0, length) (|d| < length): no
    division, no floor. The engine keeps periodic coordinates in [0, L); callers wrap external input first.
    """
    if periodic:
        if d > 0.5 * length:
            return d - length
        if d < -0.5 * length:
            return d + length
    return d


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _wrap(xa, length):
    """Coordinate wrapped into [0, length); the division only for a coordinate that left the box."""
    if 0.0 <= xa < length:
        return xa
    xa -= length * math.floor(xa / length)
    return 0.0 if xa >= length else xa


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _wrap_cell(q, n):
    """Cell index q in [-n, 2n) wrapped onto [0, n) without an integer division."""
    if q < 0:
        return q + n
    if q >= n:
        return q - n
    return q


# ---------------------------------------------------------------------------------------------------------------------
# neighbour search: hierarchical cell grids (one per radius class), half list, then the full list by transposition
@njit(cache=True, fastmath=FASTMATH)
def _assign_cells(x, cls, side, ncell, cell_off, cell_of):
    """Global cell id of every sphere in the grid of its radius class."""
    for i in prange(x.shape[0]):
        c = cls[i]
        lin = np.int64(0)
        for a in range(3):
            q = np.int64(math.floor(x[i, a] / side[c, a]))
            q = min(max(q, np.int64(0)), ncell[c, a] - 1)
            lin = lin * ncell[c, a] + q
        cell_of[i] = cell_off[c] + lin


@njit(cache=True, fastmath=FASTMATH)
def _counting_sort(keys, nkeys, start, items):
    """Stable counting sort of 0..N-1 by key: start (nkeys+1,) offsets, items (N,) indices."""
    start[:] = 0
    for i in range(keys.size):
        start[keys[i] + 1] += 1
    for k in range(nkeys):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    for i in range(keys.size):
        items[fill[keys[i]]] = i
        fill[keys[i]] += 1


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _axis_range(xa, reach, side, n, periodic):
    """Cell range [lo, hi] to scan along one axis; the whole axis if the range would wrap onto itself."""
    lo = np.int64(math.floor((xa - reach) / side))
    hi = np.int64(math.floor((xa + reach) / side))
    if hi - lo + 1 >= n:
        return np.int64(0), n - 1
    if not periodic:
        lo = max(lo, np.int64(0))
        hi = min(hi, n - 1)
    return lo, hi


# ``write`` flags of _scan_half as typed globals: a literal True / False would make numba compile _scan_half once
# per value (Literal[bool]); np.bool_ globals type as plain booleans, so one compiled version serves both calls.
_COUNT_ONLY = np.bool_(False)
_WRITE = np.bool_(True)


@njit(cache=True, fastmath=FASTMATH)
def _scan_half(
    i,
    x,
    r,
    types,
    cls,
    ncls,
    side,
    ncell,
    cell_off,
    cell_start,
    cell_items,
    box,
    periodic,
    pair_on,
    cut,
    skin,
    out,
    write,
):
    """Partners j of sphere i in the half list: classes <= cls[i], and j > i inside the own class.

    A sphere looks *down* the hierarchy: a large sphere scans the fine grids of the smaller classes over its own
    reach, so a fine sphere never visits the (few, far-reaching) cells of the large classes; the work per pair
    stays O(1) for any radius ratio. Counts the partners, and writes them to ``out`` when ``write`` is set.
    """
    ci = cls[i]
    ti = types[i]
    cnt = np.int64(0)
    for c in range(ci, -1, -1):
        if side[c, 0] <= 0.0:
            continue  # empty class
        reach = cut * (r[i] + side[c, 3]) + skin
        lo0, hi0 = _axis_range(x[i, 0], reach, side[c, 0], ncell[c, 0], periodic[0])
        lo1, hi1 = _axis_range(x[i, 1], reach, side[c, 1], ncell[c, 1], periodic[1])
        lo2, hi2 = _axis_range(x[i, 2], reach, side[c, 2], ncell[c, 2], periodic[2])
        for q0 in range(lo0, hi0 + 1):
            w0 = _wrap_cell(q0, ncell[c, 0])
            for q1 in range(lo1, hi1 + 1):
                w1 = _wrap_cell(q1, ncell[c, 1])
                row = cell_off[c] + (w0 * ncell[c, 1] + w1) * ncell[c, 2]
                for q2 in range(lo2, hi2 + 1):
                    cell = row + _wrap_cell(q2, ncell[c, 2])
                    for p in range(cell_start[cell], cell_start[cell + 1]):
                        j = cell_items[p]
                        if c == ci and j <= i:
                            continue
                        if not pair_on[ti, types[j]]:
                            continue
                        d2 = 0.0
                        for a in range(3):
                            d = _min_image(x[i, a] - x[j, a], box[a], periodic[a])
                            d2 += d * d
                        lim = cut * (r[i] + r[j]) + skin
                        if d2 <= lim * lim:
                            if write:
                                out[cnt] = j
                            cnt += 1
    return cnt


@by_threads(_SERIAL_MAX, cache=True, fastmath=FASTMATH)
def _half_counts(
    x,
    r,
    types,
    cls,
    ncls,
    side,
    ncell,
    cell_off,
    cell_start,
    cell_items,
    box,
    periodic,
    pair_on,
    cut,
    skin,
    counts,
):
    dummy = np.empty(0, dtype=np.int64)
    for i in prange(x.shape[0]):
        counts[i] = _scan_half(
            np.int64(i),  # the parallel loop's index may be unsigned: one compile for both variants
            x,
            r,
            types,
            cls,
            ncls,
            side,
            ncell,
            cell_off,
            cell_start,
            cell_items,
            box,
            periodic,
            pair_on,
            cut,
            skin,
            dummy,
            _COUNT_ONLY,
        )


@by_threads(_SERIAL_MAX, cache=True, fastmath=FASTMATH)
def _half_fill(
    x,
    r,
    types,
    cls,
    ncls,
    side,
    ncell,
    cell_off,
    cell_start,
    cell_items,
    box,
    periodic,
    pair_on,
    cut,
    skin,
    half_start,
    half_idx,
):
    for i in prange(x.shape[0]):
        _scan_half(
            np.int64(i),  # (see _half_counts)
            x,
            r,
            types,
            cls,
            ncls,
            side,
            ncell,
            cell_off,
            cell_start,
            cell_items,
            box,
            periodic,
            pair_on,
            cut,
            skin,
            half_idx[half_start[i] : half_start[i + 1]],
            _WRITE,
        )


@njit(cache=True, fastmath=FASTMATH)
def _full_from_half(half_start, half_idx, nbr_start, nbr_idx):
    """Full (symmetric) CSR list from the half list: own half entries first, then the transposed ones (serial,
    so the order, and with it every force sum, is the same for any thread count).
    """
    n = half_start.size - 1
    deg = np.zeros(n, dtype=np.int64)
    for i in range(n):
        deg[i] += half_start[i + 1] - half_start[i]
        for p in range(half_start[i], half_start[i + 1]):
            deg[half_idx[p]] += 1
    nbr_start[0] = 0
    for i in range(n):
        nbr_start[i + 1] = nbr_start[i] + deg[i]
    fill = nbr_start[:-1].copy()
    for i in range(n):
        for p in range(half_start[i], half_start[i + 1]):
            nbr_idx[fill[i]] = half_idx[p]
            fill[i] += 1
    for i in range(n):
        for p in range(half_start[i], half_start[i + 1]):
            j = half_idx[p]
            nbr_idx[fill[j]] = i
            fill[j] += 1


# ---------------------------------------------------------------------------------------------------------------------
@njit(cache=True, fastmath=FASTMATH, inline="always")
def _sphere_aux(i, x_old, x_new, v, x_build, r, r_build, box, periodic, cut, mass, aux):
    """Per-sphere diagnostics: kinetic energy, step displacement, list staleness |x - x_build| + cut (r - r_build)+."""
    d2 = 0.0
    e2 = 0.0
    for a in range(3):
        d = _min_image(x_new[i, a] - x_old[i, a], box[a], periodic[a])
        d2 += d * d
        e = _min_image(x_new[i, a] - x_build[i, a], box[a], periodic[a])
        e2 += e * e
    aux[i, 0] = 0.5 * mass * (v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2])
    aux[i, 1] = math.sqrt(d2)
    aux[i, 2] = math.sqrt(e2) + cut * max(0.0, r[i] - r_build[i])


# ---------------------------------------------------------------------------------------------------------------------
#: the per-step reductions run over this many fixed chunks, so their floating-point sums are the same for any thread count
_REDUCE_CHUNKS = 64


@by_threads(_SERIAL_MAX, cache=True, fastmath=FASTMATH)
def _step_reductions(sig, conv, aux):
    """One pass over the per-sphere results of a step: (converged count, kinetic energy, max sigma, sum and count of
    finite sigma, largest step displacement and its sphere, list staleness, first non-finite sphere or -1).
    """
    n = sig.size
    part = np.zeros((_REDUCE_CHUNKS, 9))
    for c in prange(_REDUCE_CHUNKS):
        nconv = 0
        ke = 0.0
        smax = _NEG_INF
        ssum = 0.0
        scnt = 0
        dmax = -1.0
        darg = -1
        stale = 0.0
        bad = -1
        for i in range(c * n // _REDUCE_CHUNKS, (c + 1) * n // _REDUCE_CHUNKS):
            nconv += conv[i]
            ke += aux[i, 0]
            if sig[i] > smax:
                smax = sig[i]
            if sig[i] > _NEG_INF:
                ssum += sig[i]
                scnt += 1
            if aux[i, 1] > dmax:
                dmax = aux[i, 1]
                darg = i
            stale = max(stale, aux[i, 2])
            if bad < 0 and not (
                math.isfinite(aux[i, 0]) and math.isfinite(aux[i, 1]) and math.isfinite(aux[i, 2])
            ):
                bad = i
        part[c, 0] = nconv
        part[c, 1] = ke
        part[c, 2] = smax
        part[c, 3] = ssum
        part[c, 4] = scnt
        part[c, 5] = dmax
        part[c, 6] = darg
        part[c, 7] = stale
        part[c, 8] = bad
    nconv = 0
    ke = 0.0
    smax = _NEG_INF
    ssum = 0.0
    scnt = 0
    dmax = 0.0
    darg = -1
    stale = 0.0
    bad = -1
    for c in range(_REDUCE_CHUNKS):
        nconv += int(part[c, 0])
        ke += part[c, 1]
        smax = max(smax, part[c, 2])
        ssum += part[c, 3]
        scnt += int(part[c, 4])
        if part[c, 6] >= 0 and (darg < 0 or part[c, 5] > dmax):
            dmax = part[c, 5]
            darg = int(part[c, 6])
        stale = max(stale, part[c, 7])
        if bad < 0 and part[c, 8] >= 0:
            bad = int(part[c, 8])
    return nconv, ke, smax, ssum, scnt, dmax, darg, stale, bad


# ---------------------------------------------------------------------------------------------------------------------
@intrinsic
def _prefetch_row(typingctx, rows, i):
    """Hint the processor to load the cache line of ``rows[i, 0]`` (a C-contiguous 2-D array) into all cache levels
    (LLVM's ``llvm.prefetch``, read, locality 3): no effect on any value, and no fault for any address.
    """

    def codegen(context, builder, signature, args):
        arrty = signature.args[0]
        arr = context.make_array(arrty)(context, builder, args[0])
        zero = context.get_constant(nbtypes.intp, 0)
        ptr = cgutils.get_item_pointer(context, builder, arrty, arr, [args[1], zero], wraparound=False)
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [cgutils.voidptr_t, i32, i32, i32])
        # named as this llvmlite spells pointers: .p0i8 here (typed), which LLVM 22 upgrades to the opaque .p0
        fn = builder.module.declare_intrinsic("llvm.prefetch", [cgutils.voidptr_t], fnty)
        read, keep_everywhere, data = ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)
        builder.call(fn, [builder.bitcast(ptr, cgutils.voidptr_t), read, keep_everywhere, data])
        return context.get_dummy_value()

    return nbtypes.void(rows, i), codegen


# ---------------------------------------------------------------------------------------------------------------------
# the step: forces at x^{s-1}, damped velocity-Störmer-Verlet update (§5.3), per-sphere overlap and convergence
#: rows of the pair scratch: what :func:`_gather_pairs` copies in (differences of centres x, y, z, r_i, r_j and the
#: type-pair k, hcoef, sigma*) and what :func:`_pair_terms` writes (force x, y, z, sigma_ij, distance, reach flag)
_D0, _RI, _RJ, _KP, _HC, _SP, _C0, _SIG, _DIST, _REACH, _ROWS = 0, 3, 4, 5, 6, 7, 8, 11, 12, 13, 14
#: pairs evaluated per batch (the scratch holds at least one sphere's whole list besides)
_BATCH = 512
#: :func:`_gather_pairs` prefetches the work row of the partner this many list entries ahead (about 100 spheres).
#: Same run, 10^6 spheres, one thread, load 3-4: 1.13-1.19x the step without it at 256-2048 entries ahead (a
#: plateau), 1.09-1.12x at 128, 1.11x at 16; at 2·10^5 spheres 1.03-1.04x (more of the rows sit in the caches)
_PREFETCH_AHEAD = 512
#: the step's two passes over the spheres prefetch the rows of their per-sphere arrays this many spheres ahead (the
#: arrays are walked in order, but there are up to a dozen of them, more streams than the hardware follows well).
#: Same run, 10^6 spheres, one thread, load 3-3.5, on top of the pair prefetch: 1.11x at 64 spheres ahead, 1.08x
#: at 32, and at 32 the advance pass alone 1.03-1.07x; at 2·10^5 spheres 1.04x
_STREAM_AHEAD = 64
#: columns of the step kernel's (N, WORK_COLUMNS) work array: one 64-byte row per sphere holds what a pair reads of
#: its partner (x, y, z, r) and what it adds to it (force x, y, z, max sigma), so gather and scatter touch one line
WORK_COLUMNS = 8
_WF, _WSIG = 4, 7


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _gather_pairs(i, half_start, half_idx, xr, types, kpair, hcoef, sigp, w, k, one_type):
    """Copy what the pairs of sphere i need into columns k, k+1, ... of the scratch w; return the next column.

    The scattered reads (x_j, r_j, the type tables) happen here, in a plain loop, so that :func:`_pair_terms` reads
    contiguous rows only and vectorises. With ``one_type`` the type-pair rows hold their one value already. Each
    entry prefetches the row of the partner :data:`_PREFETCH_AHEAD` entries further down the list (the next
    spheres' partners: the slab loop walks the list in order), so that its read here does not wait on memory.
    """
    ti = types[i]
    last = half_idx.size - 1
    for p in range(half_start[i], half_start[i + 1]):
        _prefetch_row(xr, half_idx[min(p + _PREFETCH_AHEAD, last)])
        j = half_idx[p]
        w[_D0, k] = xr[i, 0] - xr[j, 0]
        w[_D0 + 1, k] = xr[i, 1] - xr[j, 1]
        w[_D0 + 2, k] = xr[i, 2] - xr[j, 2]
        w[_RI, k] = xr[i, 3]
        w[_RJ, k] = xr[j, 3]
        if not one_type:
            tj = types[j]
            w[_KP, k] = kpair[ti, tj]
            w[_HC, k] = hcoef[ti, tj]
            w[_SP, k] = sigp[ti, tj]
        k += 1
    return k


@njit(cache=True, fastmath=FASTMATH, inline="always", error_model="numpy")
def _min_image_select(d, length, half):
    """:func:`_min_image` as two selects (half = L/2 on periodic axes, inf on walled ones): the same value."""
    d = d - length if d > half else d
    return d + length if d < -half else d


@njit(cache=True, fastmath=FASTMATH, inline="always", error_model="numpy")
def _pair_terms(w, npairs, box, half_box, cut):
    """Force, sigma_ij, distance and reach flag of the first ``npairs`` gathered pairs of the scratch w.

    Contiguous rows in and out, no branch (selects for the minimum image and the force law's two branches), no
    division check (numpy's error model): the loop vectorises. Each value comes from the same operations in the
    same order as one pair at a time, so the results are bit for bit those of a scalar loop. The force of
    coincident centres (distance 0) is not finite here; :func:`_scatter_pairs` replaces it.
    """
    b0, b1, b2 = box[0], box[1], box[2]
    h0, h1, h2 = half_box[0], half_box[1], half_box[2]
    for k in range(npairs):
        d0 = _min_image_select(w[_D0, k], b0, h0)
        d1 = _min_image_select(w[_D0 + 1, k], b1, h1)
        d2 = _min_image_select(w[_D0 + 2, k], b2, h2)
        dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        ri = w[_RI, k]
        rj = w[_RJ, k]
        rsum = ri + rj
        rmin2 = rsum - abs(ri - rj)
        dxeq = rsum - 0.5 * w[_SP, k] * rmin2
        in_reach = dist <= cut * dxeq
        g = _pair_force_over_dist(dist, dxeq, w[_KP, k], w[_HC, k])
        g = g if in_reach else 0.0
        w[_C0, k] = g * d0
        w[_C0 + 1, k] = g * d1
        w[_C0 + 2, k] = g * d2
        w[_SIG, k] = (rsum - dist) / rmin2
        w[_DIST, k] = dist
        w[_REACH, k] = 1.0 if in_reach else 0.0


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", **NO_REFCOUNT)
def _tie_force(i, j, xr, types, ids, hcoef, sigp):
    """The pair force (x, y, z) on i from j when their centres coincide: the harmonic force at distance 0,
    hcoef / dx_eq, along the pair's random direction :func:`_tie_direction`.

    Not inlined: coincident centres are rare, and this cold path inlined once per axis (as it was) made up most of
    the pair loop's compile time (:func:`_slab_pairs` 15 CPU-s on this project's 2-core machine, 4 without).
    """
    rsum = xr[i, 3] + xr[j, 3]
    rmin2 = rsum - abs(xr[i, 3] - xr[j, 3])
    dxeq = rsum - 0.5 * sigp[types[i], types[j]] * rmin2
    f = hcoef[types[i], types[j]] / dxeq
    ex, ey, ez = _tie_direction(ids[i], ids[j])
    return f * ex, f * ey, f * ez


@njit(cache=True, fastmath=FASTMATH, inline="always", error_model="numpy")
def _scatter_pairs(i, k, half_start, half_idx, xr, types, ids, frozen, hcoef, sigp, conv, freeze, w):
    """Apply the evaluated pairs of sphere i (scratch columns from k on) to both ends (Newton's third law); return
    the next column.

    Adds the pair force to the force columns of xr's row i (summed over the list first) and its negative to row
    j's, raises the max-sigma column of both to sigma_ij and sets conv of both to 1 when the partner is within
    reach (the flag the step's stochastic forces read). The caller runs spheres that share a partner in one thread,
    in a fixed order.
    """
    fro_i = False
    if freeze:
        fro_i = frozen[i] != 0
    fx = 0.0
    fy = 0.0
    fz = 0.0
    smax = xr[i, _WSIG]
    reach_any = 0
    for p in range(half_start[i], half_start[i + 1]):
        j = half_idx[p]
        sig_ij = w[_SIG, k]
        smax = max(smax, sig_ij)
        xr[j, _WSIG] = max(xr[j, _WSIG], sig_ij)
        col = k
        k += 1
        fro_j = False
        if freeze:
            fro_j = frozen[j] != 0
            if fro_i and fro_j:
                continue
        in_reach = w[_REACH, col] != 0.0
        if w[_DIST, col] > 0.0:
            c0 = w[_C0, col]
            c1 = w[_C0 + 1, col]
            c2 = w[_C0 + 2, col]
        elif in_reach:
            c0, c1, c2 = _tie_force(i, j, xr, types, ids, hcoef, sigp)
        else:
            continue  # coincident centres out of reach: no force
        reach_any |= in_reach
        conv[j] |= in_reach
        if not fro_i:
            fx += c0
            fy += c1
            fz += c2
        if not fro_j:
            xr[j, _WF] -= c0
            xr[j, _WF + 1] -= c1
            xr[j, _WF + 2] -= c2
    xr[i, _WF] += fx
    xr[i, _WF + 1] += fy
    xr[i, _WF + 2] += fz
    xr[i, _WSIG] = smax
    if reach_any:
        conv[i] = 1
    return k


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _slab_scratch(lo, hi, slab_items, half_start, kpair, hcoef, sigp):
    """The pair scratch of :func:`_slab_pairs` for the spheres ``slab_items[lo:hi]``: :data:`_BATCH` columns plus
    the longest list among them, the type-pair rows filled when there is one type only.
    """
    most = 0
    for m in range(lo, hi):
        i = slab_items[m]
        most = max(most, half_start[i + 1] - half_start[i])
    w = np.empty((_ROWS, _BATCH + most))
    if kpair.size == 1:
        w[_KP, :] = kpair[0, 0]
        w[_HC, :] = hcoef[0, 0]
        w[_SP, :] = sigp[0, 0]
    return w


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", **NO_REFCOUNT)
def _slab_pairs(
    lo, hi, slab_items, half_start, half_idx, xr, types, ids, frozen, box, half_box, kpair, hcoef, sigp, cut,
    conv, freeze, w,
):  # fmt: skip
    """Every pair owned by the spheres ``slab_items[lo:hi]``, in that order, in batches of about :data:`_BATCH`
    pairs: gather, evaluate (vectorised), scatter, in the scratch w of :func:`_slab_scratch`.

    Compiled without reference counting (a call per slab, no allocation inside): inlined into the reference-counted
    step kernel, the compiled sphere loop incremented and decremented array counts (atomic, on cache lines that
    the threads share) for every sphere.
    """
    one_type = kpair.size == 1
    m = lo
    while m < hi:
        first = m
        k = 0
        while m < hi and k < _BATCH:
            k = _gather_pairs(
                slab_items[m], half_start, half_idx, xr, types, kpair, hcoef, sigp, w, k, one_type
            )
            m += 1
        _pair_terms(w, k, box, half_box, cut)
        k = 0
        for mm in range(first, m):
            k = _scatter_pairs(
                slab_items[mm],
                k,
                half_start,
                half_idx,
                xr,
                types,
                ids,
                frozen,
                hcoef,
                sigp,
                conv,
                freeze,
                w,
            )


_STEP_CACHE: dict = {}


def work_array(n: int) -> np.ndarray:
    """The step kernel's (n, :data:`WORK_COLUMNS`) float64 work array, each row on one 64-byte cache line (NumPy
    aligns large arrays to 16 bytes only: a row would then straddle two lines).
    """
    row = WORK_COLUMNS * 8
    raw = np.empty(n * WORK_COLUMNS + row // 8)
    skip = (-raw.ctypes.data % row) // 8
    return raw[skip : skip + n * WORK_COLUMNS].reshape(n, WORK_COLUMNS)


def make_step_kernel(freeze: bool, stochastic: bool, walls: bool):
    """Return the step kernel compiled with exactly the requested optional effects.

    The flags are closure constants, so numba removes the code of a switched-off effect entirely; each flag
    combination is compiled (and cached on disk) once per thread mode (serial for one thread, parallel for more:
    :class:`porepipe._shared.numba_config.ByThreads`; the same forces and sums either way).

    Parameters
    ----------
    freeze : bool
        Skip force computation and propagation of spheres with ``frozen[i]`` set (§5.4.4, frozen types).
    stochastic : bool
        Add uniform random forces in [-f_max, f_max]^3 to spheres that feel no pair force and are not converged.
    walls : bool
        Some axes are closed by reflecting walls (centres stay in [0, L]); otherwise every axis is periodic.

    The kernel's last argument is a (N, :data:`WORK_COLUMNS`) float64 work array (its contents on entry do not
    matter): the step copies x, y, z, r of every sphere into one 64-byte row there and sums the sphere's pair forces
    and max sigma in the same row, so the pair pass reads and updates one cache line per partner (with separate
    position, force and sigma arrays it touched three). The caller allocates it once per run: a fresh 64 MB array
    per step (10^6 spheres) costs page faults.
    """
    key = (bool(freeze), bool(stochastic), bool(walls))
    if key in _STEP_CACHE:
        return _STEP_CACHE[key]
    FREEZE, STOCH, WALLS = key

    @by_threads(_SERIAL_MAX, cache=True, fastmath=FASTMATH)
    def _step(
        x_old,
        x_new,
        v,
        f_prev,
        f_new,
        r,
        types,
        ids,
        frozen,
        half_start,
        half_idx,
        slab_start,
        slab_items,
        box,
        periodic,
        kpair,
        hcoef,
        sigp,
        sig_t,
        cm_t,
        cp_t,
        fmax_t,
        cut,
        dt,
        mass,
        seed,
        step,
        x_build,
        r_build,
        sig_max,
        conv,
        aux,
        xr,
    ):
        n = x_old.shape[0]
        for i in prange(n):
            ahead = min(i + _STREAM_AHEAD, n - 1)
            _prefetch_row(x_old, ahead)
            _prefetch_row(xr, ahead)
            for a in range(3):
                xr[i, a] = x_old[i, a]
                xr[i, _WF + a] = 0.0
            xr[i, 3] = r[i]
            xr[i, _WSIG] = _NEG_INF
            conv[i] = 0
        # forces: each pair once, from its owner's half list, applied to both ends. The spheres sit in slabs at
        # least one pair reach wide, so a pair spans two neighbouring slabs at most; slabs of one colour (slab
        # number mod 3) share no sphere and run in parallel, each in sphere order: the same sums for any thread
        # count
        nslab = slab_start.size - 1
        half_box = np.empty(3)
        for a in range(3):
            half_box[a] = (
                0.5 * box[a] if periodic[a] or not WALLS else np.inf
            )  # minimum image on periodic axes
        for colour in range(min(nslab, 3)):
            for k in prange((nslab - colour + 2) // 3):
                s = colour + 3 * k
                lo, hi = slab_start[s], slab_start[s + 1]
                w = _slab_scratch(lo, hi, slab_items, half_start, kpair, hcoef, sigp)
                _slab_pairs(
                    lo, hi, slab_items, half_start, half_idx, xr, types, ids, frozen, box, half_box, kpair,
                    hcoef, sigp, cut, conv, FREEZE, w,
                )  # fmt: skip
        half_dt2_m = 0.5 * dt * dt / mass
        decay_t = np.empty(cm_t.size)  # velocity decay and force kick per type: no division per sphere
        kick_t = np.empty(cm_t.size)
        for t in range(cm_t.size):
            decay_t[t] = cm_t[t] / cp_t[t]
            kick_t[t] = dt / (2.0 * mass * cp_t[t])
        for i in prange(n):
            ahead = min(i + _STREAM_AHEAD, n - 1)
            _prefetch_row(v, ahead)
            _prefetch_row(f_prev, ahead)
            _prefetch_row(x_build, ahead)
            _prefetch_row(x_old, ahead)
            _prefetch_row(xr, ahead)
            ti = types[i]
            ri = r[i]
            is_frozen = False
            if FREEZE:
                is_frozen = frozen[i] != 0
            fx = xr[i, _WF]
            fy = xr[i, _WF + 1]
            fz = xr[i, _WF + 2]
            nforce = conv[i]
            smax = xr[i, _WSIG]
            sig_max[i] = smax
            ok = smax > 0.0 and smax <= sig_t[ti]
            conv[i] = 1 if ok else 0
            if FREEZE:
                if is_frozen:
                    for a in range(3):
                        x_new[i, a] = x_old[i, a]
                        v[i, a] = 0.0
                        f_new[i, a] = 0.0
                    _sphere_aux(i, x_old, x_new, v, x_build, r, r_build, box, periodic, cut, mass, aux)
                    continue
            if STOCH:
                if nforce == 0 and not ok and fmax_t[ti] > 0.0:
                    fm = fmax_t[ti] * ri
                    fx += fm * (2.0 * _uniform(seed, step, ids[i], 0) - 1.0)
                    fy += fm * (2.0 * _uniform(seed, step, ids[i], 1) - 1.0)
                    fz += fm * (2.0 * _uniform(seed, step, ids[i], 2) - 1.0)
            f_new[i, 0] = fx
            f_new[i, 1] = fy
            f_new[i, 2] = fz
            cm = cm_t[ti]
            decay = decay_t[ti]
            kick = kick_t[ti]
            for a in range(3):
                va = decay * v[i, a] + (f_prev[i, a] + f_new[i, a]) * kick
                xa = x_old[i, a] + cm * va * dt + f_new[i, a] * half_dt2_m
                if WALLS:
                    if periodic[a]:
                        xa = _wrap(xa, box[a])
                    else:
                        if xa < 0.0:
                            xa = -xa
                            va = -va
                        if xa > box[a]:
                            xa = 2.0 * box[a] - xa
                            va = -va
                        xa = min(max(xa, 0.0), box[a])
                else:
                    xa = _wrap(xa, box[a])
                v[i, a] = va
                x_new[i, a] = xa
            _sphere_aux(i, x_old, x_new, v, x_build, r, r_build, box, periodic, cut, mass, aux)

    _STEP_CACHE[key] = _step
    return _step
