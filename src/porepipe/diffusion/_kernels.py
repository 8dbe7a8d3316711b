"""Numba kernels of the Knudsen engine: counter-based random numbers, the 1-byte distance geometry, exact flights
(3-D DDA with empty-space jumps), wall laws, and the set-up kernels built by a factory from the scene's choices.

Geometry code per voxel (uint8), built by :func:`_box_codes`: 0 = solid; any other code names a box centred
on the voxel, inside the volume and all pore, of half-widths ``_HALF_WIDTH[:, code]`` along the three axes, so that a
particle may fly straight to that box's surface without looking at single voxels. Codes 1..63: the L-infinity
(chessboard) distance k to the nearest solid voxel or to the outside of the box (saturated), the cube of half-width
k - 1; 64..123: edge boxes, thin across two axes and long along the third, for the voxels where two walls meet
(:func:`_edge_codes`); 128..199: slabs, thin across a wall, for the voxels next to one (:func:`_slab_codes`);
200..253: prisms, four times longer along one axis than across (:func:`_prism_codes`).

Events returned by :func:`_fly`: 0..5 = wall face ``2 * axis + (step > 0)`` (the particle moved in direction ``step``
along ``axis`` and met a solid voxel or the closed outside), 6 = left through the low face of the exit axis, 7 = left
through its high face.
"""

from __future__ import annotations

import math
import platform

import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.core import cgutils
from numba.extending import intrinsic

from porepipe._shared.numba_config import FASTMATH, NO_REFCOUNT

_NEVER = 1e300  # crossing time of an axis a flight does not move along (r * _NEVER stays finite)
_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_TWO_M53 = 1.0 / 9007199254740992.0
_TWO_PI = 2.0 * math.pi

# wall / inlet laws (closure constants of the kernel factory)
SPECULAR = 0
LAMBERT = 1
COSINE_DTHETA = 2
ISOTROPIC = 3
# speed distributions
SPEED_MEAN = 0  # every particle at its species' mean speed
SPEED_MAXWELL = 1  # Maxwell-Boltzmann f(v) ~ v^2 exp(-v^2 / 2 s^2) (thesis 3.2)
SPEED_FLUX = 2  # flux-weighted Maxwell-Boltzmann ~ v^3 exp(-v^2 / 2 s^2) (particles crossing a plane)
SPEED_KEPT = -1  # wall keeps |v| (thesis)

EXIT_LOW = 6
EXIT_HIGH = 7


# ---------------------------------------------------------------------------------------------------------------------
# counter-based random numbers: SplitMix64, one stream per particle, state = mix(seed, particle id)
@njit(cache=True, inline="always")
def _mix(z):
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@njit(cache=True, **NO_REFCOUNT)
def _stream_state(seed, particle):
    """Start state of particle ``particle``'s stream under the 63-bit ``seed`` (independent of thread count)."""
    return _mix(np.uint64(seed) ^ _mix(np.uint64(particle) * _GAMMA + _GAMMA))


@njit(cache=True, inline="always")
def _uniform(state):
    """(u in (0, 1], new state)."""
    state = state + _GAMMA
    return (float(_mix(state) >> _S11) + 1.0) * _TWO_M53, state


# ---------------------------------------------------------------------------------------------------------------------
# geometry: chessboard distance to the solid (outside of the box counts as solid), two raster passes
@njit(cache=True)
def _box_codes(pore, out):
    """The flights' geometry codes of ``pore`` in ``out`` (may be ``pore`` itself): the chessboard distances
    (:func:`_chessboard_distance`), then slab, prism and edge codes where those boxes get further (see the module's
    docstring).
    """
    _chessboard_distance(pore, out)
    _slab_codes(out)
    _prism_codes(out)
    _edge_codes(out)


@njit(cache=True)
def _chessboard_distance(pore, out):
    """``out[i,j,k]`` = 0 for solid, else min(255, L-inf distance to the nearest solid or outside voxel).

    Two raster passes of the 3x3x3 unit-weight chamfer mask, which is exact for the chessboard metric.
    """
    n0, n1, n2 = pore.shape
    for i in range(n0):
        for j in range(n1):
            for k in range(n2):
                if pore[i, j, k] == 0:
                    out[i, j, k] = 0
                    continue
                best = 255
                for di in range(-1, 1):
                    for dj in range(-1, 2):
                        for dk in range(-1, 2):
                            if di == 0 and (dj > 0 or (dj == 0 and dk >= 0)):
                                continue
                            a, b, c = i + di, j + dj, k + dk
                            if a < 0 or b < 0 or c < 0 or b >= n1 or c >= n2:
                                val = 0
                            else:
                                val = out[a, b, c]
                            best = min(best, val + 1)
                out[i, j, k] = best
    for i in range(n0 - 1, -1, -1):
        for j in range(n1 - 1, -1, -1):
            for k in range(n2 - 1, -1, -1):
                cur = out[i, j, k]
                if cur == 0:
                    continue
                best = cur
                for di in range(2):
                    for dj in range(-1, 2):
                        for dk in range(-1, 2):
                            if di == 0 and (dj < 0 or (dj == 0 and dk <= 0)):
                                continue
                            a, b, c = i + di, j + dj, k + dk
                            if a >= n0 or b < 0 or c < 0 or b >= n1 or c >= n2:
                                val = 0
                            else:
                                val = out[a, b, c]
                            best = min(best, val + 1)
                out[i, j, k] = best


# ---------------------------------------------------------------------------------------------------------------------
# geometry: box codes (slabs across the walls, prisms along the free runs, edge boxes where two walls meet)
#: first edge code; chessboard codes are saturated below it (cubes of half-width up to 62)
_EDGE_CODE = 64
#: an edge box's half-width along its long axis (6 to 8 alike on the capillary, 16 and more slower: the box must fit
#: between the inlet and the voxel, where a transmission run hits the walls most)
_EDGE_LONG = 8
#: the half-widths (across the lower, across the higher of the two other axes) the edge codes can hold: one of the two
#: at most 2 (a voxel of chessboard code <= 3, where a flight walks), the other up to 6 (slabs take over from 7); a
#: box is rounded down to one of them (so it stays all pore); 20 of them fit below _SLAB_CODE
_EDGE_CROSS = np.array(
    [(1, 1), (2, 2)]
    + [
        p
        for x, y in ((0, 3), (0, 6), (1, 2), (1, 3), (1, 4), (1, 6), (2, 3), (2, 4), (2, 6))
        for p in ((x, y), (y, x))
    ],
    np.int64,
)
#: first slab code
_SLAB_CODE = 128
#: chessboard codes 1.._SLAB_THICK may become slab codes: those of the voxels next to a wall, where a flight walks
_SLAB_THICK = 4
#: the (half-widths + 1) across the thin axis a slab code can hold; a slab's is rounded down to one of them (so its
#: box stays all pore), and one narrower than the first is not worth a jump
_SLAB_WIDTHS = np.array([8, 10, 12, 16, 24, 32], np.int64)
#: first prism code (after the slab codes)
_PRISM_CODE = _SLAB_CODE + 3 * _SLAB_THICK * len(_SLAB_WIDTHS)
#: the cross half-widths of the prism codes (that of a voxel of chessboard code r + 1; from _JUMP_CODE - 1)
_PRISM_CROSS = np.arange(3, 21, dtype=np.int64)
#: a prism's half-width along its long axis, in cross half-widths (3 to 12 measured alike on the capillary)
_PRISM_LONG = 4


def _half_width_table():
    """(3, 256) float64: per code, the half-width along each axis of its all-pore box centred on the voxel.

    Chessboard code c < _EDGE_CODE: the cube, c - 1 along every axis. Edge code _EDGE_CODE + 3 j + e: _EDGE_LONG
    along the long axis e and _EDGE_CROSS[j] across the two others (lower axis first). Slab code _SLAB_CODE +
    (3 t + d) w + j (w = len(_SLAB_WIDTHS), t < _SLAB_THICK): t along the thin axis d (the voxel's chessboard code is
    t + 1) and _SLAB_WIDTHS[j] - 1 along the other two. Prism code _PRISM_CODE + 3 i + e: r = _PRISM_CROSS[i] across and
    _PRISM_LONG r along the long axis e. Floats: the jump multiplies them by the times between crossings.
    """
    table = np.zeros((3, 256))
    table[:, 1:_EDGE_CODE] = np.arange(_EDGE_CODE - 1)
    for j, cross in enumerate(_EDGE_CROSS):
        for e in range(3):
            table[e, _EDGE_CODE + 3 * j + e] = _EDGE_LONG
            table[[d for d in range(3) if d != e], _EDGE_CODE + 3 * j + e] = cross
    nw = len(_SLAB_WIDTHS)
    for t in range(_SLAB_THICK):
        for d in range(3):
            for j in range(nw):
                code = _SLAB_CODE + (3 * t + d) * nw + j
                table[:, code] = _SLAB_WIDTHS[j] - 1
                table[d, code] = t
    for i, r in enumerate(_PRISM_CROSS):
        for e in range(3):
            table[:, _PRISM_CODE + 3 * i + e] = r
            table[e, _PRISM_CODE + 3 * i + e] = _PRISM_LONG * r
    return table


#: per-axis half-widths of the box of each code (see _half_width_table)
_HALF_WIDTH = _half_width_table()
#: per code, its box's smallest half-width (-1: solid)
_SMALLEST = np.concatenate(([-1], _HALF_WIDTH[:, 1:].min(axis=0))).astype(np.int64)
#: per code, the harmonic mean of its box's half-widths + 1: how far a flight in a random direction gets
_MEAN_REACH = 3.0 / (
    1.0 / (_HALF_WIDTH[0] + 1.0) + 1.0 / (_HALF_WIDTH[1] + 1.0) + 1.0 / (_HALF_WIDTH[2] + 1.0)
)
#: the largest half-width across of an edge box
_EDGE_REACH = int(_EDGE_CROSS.max())
#: the edge cross-sections (rows of _EDGE_CROSS), furthest-reaching first: the first that fits a voxel is its best
_EDGE_ORDER = np.argsort(-_MEAN_REACH[_EDGE_CODE : _EDGE_CODE + 3 * len(_EDGE_CROSS) : 3], kind="stable")


@njit(cache=True)
def _plane_chessboard(plane):
    """In place: the 2-D chessboard distance (saturated at 255) of the nonzero pixels of ``plane`` to the nearest
    zero pixel or the outside (two raster passes of the 3x3 unit-weight mask, as :func:`_chessboard_distance`).
    """
    na, nb = plane.shape
    for a in range(na):
        for b in range(nb):
            if plane[a, b] != 0:
                best = 255
                for da, db in ((-1, -1), (-1, 0), (-1, 1), (0, -1)):
                    x, y = a + da, b + db
                    best = min(best, (plane[x, y] if (x >= 0) & (y >= 0) & (y < nb) else 0) + 1)
                plane[a, b] = best
    for a in range(na - 1, -1, -1):
        for b in range(nb - 1, -1, -1):
            if plane[a, b] != 0:
                best = plane[a, b]
                for da, db in ((1, 1), (1, 0), (1, -1), (0, 1)):
                    x, y = a + da, b + db
                    best = min(best, (plane[x, y] if (x < na) & (y >= 0) & (y < nb) else 0) + 1)
                plane[a, b] = best


@njit(cache=True, inline="always")
def _voxel(codes, d, p, a, b):
    """Flat index into ``codes`` of the voxel at ``p`` along axis ``d`` and (a, b) along the other two, in order."""
    n0, n1, n2 = codes.shape
    if d == 0:
        return (p * n1 + a) * n2 + b
    if d == 1:
        return (a * n1 + p) * n2 + b
    return (a * n1 + b) * n2 + p


@njit(cache=True)
def _slab_codes(codes):
    """In place on chessboard codes: saturate them at _EDGE_CODE - 1, and give a voxel of code c <= _SLAB_THICK a
    slab code (see :func:`_half_width_table`) where a box centred on it, c - 1 voxels thick along one axis and at
    least _SLAB_WIDTHS[0] - 1 wide along the other two, lies in the volume and is all pore: the widest such box of the
    three thin axes (the first axis among equals).

    The widths across thin axis d at thickness t are the 2-D chessboard distance, in each plane across d, of the
    voxels whose segment of half-length t along d is all pore. Memory: two planes.
    """
    flat = codes.reshape(codes.size)
    for f in range(flat.size):
        flat[f] = min(flat[f], _EDGE_CODE - 1)
    nw = _SLAB_WIDTHS.shape[0]
    n = codes.shape
    for d in range(3):
        stride = _voxel(codes, d, 1, 0, 0)
        free = np.empty((n[1 if d == 0 else 0], n[1 if d == 2 else 2]), np.uint8)
        plane = np.empty_like(free)
        for p in range(n[d]):
            for t in range(min(_SLAB_THICK, p + 1, n[d] - p)):
                for a in range(plane.shape[0]):
                    for b in range(plane.shape[1]):
                        at = _voxel(codes, d, p, a, b)
                        if t == 0:
                            free[a, b] = flat[at] != 0
                        else:  # the segment of half-length t along d: that of t - 1 and its two new ends
                            free[a, b] &= (flat[at - t * stride] != 0) & (flat[at + t * stride] != 0)
                        plane[a, b] = free[a, b]
                _plane_chessboard(plane)
                for a in range(plane.shape[0]):
                    for b in range(plane.shape[1]):
                        at = _voxel(codes, d, p, a, b)
                        v = flat[at]
                        if (_SMALLEST[v] != t) | (plane[a, b] < _SLAB_WIDTHS[0]):
                            continue  # solid, not t + 1 from the nearest solid, or too narrow
                        j = np.searchsorted(_SLAB_WIDTHS, plane[a, b], side="right") - 1
                        if (
                            max(_HALF_WIDTH[0, v], max(_HALF_WIDTH[1, v], _HALF_WIDTH[2, v]))
                            < _SLAB_WIDTHS[j] - 1
                        ):
                            flat[at] = _SLAB_CODE + (3 * t + d) * nw + j  # wider than its box so far


@njit(cache=True)
def _prism_codes(codes):
    """In place on slab codes: give a voxel of chessboard code r + 1 (r in _PRISM_CROSS) a prism code where a box
    centred on it, r across and _PRISM_LONG r along one axis e, lies in the volume and is all pore, and gets further
    than its box so far (_MEAN_REACH; the first axis among equals).

    That box is the union of the cubes of half-width r centred on the line along e within ell = (_PRISM_LONG - 1) r
    of the voxel, each all pore where the code's smallest half-width is at least r (:func:`_free_run`). A code's
    smallest half-width is the voxel's chessboard code - 1, also after recoding. Memory: one line.
    """
    flat = codes.reshape(codes.size)
    n = codes.shape
    for e in range(3):
        stride = _voxel(codes, e, 1, 0, 0)
        smallest = np.empty(n[e], np.int64)
        lower = np.empty(n[e], np.int64)
        upper = np.empty(n[e], np.int64)
        for a in range(n[1 if e == 0 else 0]):
            for b in range(n[1 if e == 2 else 2]):
                first = _voxel(codes, e, 0, a, b)
                for q in range(n[e]):
                    smallest[q] = _SMALLEST[flat[first + q * stride]]
                _free_run(smallest, lower, upper)
                for q in range(n[e]):
                    r = smallest[q]
                    if (r < _PRISM_CROSS[0]) | (r > _PRISM_CROSS[-1]):
                        continue
                    if min(q - lower[q], upper[q] - q) <= (_PRISM_LONG - 1) * r:
                        continue
                    at = first + q * stride
                    code = _PRISM_CODE + 3 * (r - _PRISM_CROSS[0]) + e
                    if _MEAN_REACH[code] > _MEAN_REACH[flat[at]]:
                        flat[at] = code


@njit(cache=True)
def _free_run(values, lower, upper):
    """Per entry q of ``values``: the nearest index below (``lower[q]``, -1 if none) and above (``upper[q]``,
    len(values) if none) whose value is smaller than ``values[q]`` (a stack of rising values, O(n)).
    """
    n = values.shape[0]
    stack = np.empty(n, np.int64)
    top = 0
    for q in range(n):
        while top > 0 and values[stack[top - 1]] >= values[q]:
            top -= 1
        lower[q] = stack[top - 1] if top > 0 else -1
        stack[top] = q
        top += 1
    top = 0
    for q in range(n - 1, -1, -1):
        while top > 0 and values[stack[top - 1]] >= values[q]:
            top -= 1
        upper[q] = stack[top - 1] if top > 0 else n
        stack[top] = q
        top += 1


@njit(cache=True)
def _edge_codes(codes):
    """In place on prism codes: give a voxel of chessboard code < _JUMP_CODE (one a flight walks through, or already
    an edge code) an edge code where a box centred on it, _EDGE_LONG along one axis e and _EDGE_CROSS[j] across, lies
    in the volume and is all pore, and gets further than its box so far (_MEAN_REACH; the first axis among equals).
    Its smallest half-width stays the voxel's chessboard code - 1.

    Plane by plane across e: a pixel is free where the segment of half-length _EDGE_LONG along e is all pore (a run
    of pore voxels along e, counted _EDGE_LONG planes ahead), and the box's cross-section is a rectangle of free
    pixels (:func:`_free_half_runs`, :func:`_widest_edge`). Memory: 4 bytes per pixel of a plane.
    """
    flat = codes.reshape(codes.size)
    n = codes.shape
    segment = 2 * _EDGE_LONG + 1
    for e in range(3):
        stride, sa, sb = _voxel(codes, e, 1, 0, 0), _voxel(codes, e, 0, 1, 0), _voxel(codes, e, 0, 0, 1)
        shape = (n[1 if e == 0 else 0], n[1 if e == 2 else 2])
        run = np.zeros(
            shape, np.uint8
        )  # pore voxels in a row along e up to the plane read last (at most segment)
        free = np.empty(shape, np.bool_)
        reach = np.empty((2, *shape), np.int8)
        for p in range(n[e]):
            back = (p - _EDGE_LONG) * stride  # the plane whose voxels may take an edge code
            walk = False
            for a in range(shape[0]):
                for b in range(shape[1]):
                    run[a, b] = min(run[a, b] + 1, segment) if flat[a * sa + b * sb + p * stride] != 0 else 0
                    free[a, b] = run[a, b] == segment
                    walk |= free[a, b] and _may_take_edge(flat[a * sa + b * sb + back])
            if not walk:
                continue
            _free_half_runs(free.T, reach[0].T)
            _free_half_runs(free, reach[1])
            for a in range(shape[0]):
                for b in range(shape[1]):
                    at = a * sa + b * sb + back
                    if free[a, b] and _may_take_edge(flat[at]):
                        flat[at] = _widest_edge(reach, a, b, e, flat[at])


@njit(cache=True, inline="always")
def _may_take_edge(v):
    """Whether a voxel of code ``v`` (pore) may take an edge code: a chessboard code below _JUMP_CODE or an edge code."""
    return (v < _JUMP_CODE) | ((v >= _EDGE_CODE) & (v < _SLAB_CODE))


@njit(cache=True)
def _free_half_runs(free, out):
    """Per pixel of the 2-D ``free``: ``out[a, b]`` = the largest k <= _EDGE_REACH such that the 2 k + 1 pixels
    centred on it along the second axis are all free (-1 where it is not free): runs counted forward, then backward.
    """
    na, nb = free.shape
    for a in range(na):
        before = -1
        for b in range(nb):
            before = min(before + 1, _EDGE_REACH) if free[a, b] else -1
            out[a, b] = before
        after = -1
        for b in range(nb - 1, -1, -1):
            after = min(after + 1, _EDGE_REACH) if free[a, b] else -1
            out[a, b] = min(out[a, b], after)


@njit(cache=True)
def _widest_edge(reach, a, b, e, v):
    """The code of the edge box along ``e`` centred on pixel (a, b) that gets furthest, or ``v`` if none gets further
    than ``v``'s box: _EDGE_CROSS[j] = (x, y) fits where x <= ``reach[0, a, b]`` and the rows a - x .. a + x of column
    b reach y along the second axis (``reach[1]``); tried furthest-reaching first (_EDGE_ORDER).
    """
    for j in _EDGE_ORDER:
        code = _EDGE_CODE + 3 * j + e
        if _MEAN_REACH[code] <= _MEAN_REACH[v]:
            return v
        x, y = _EDGE_CROSS[j, 0], _EDGE_CROSS[j, 1]
        if (x > reach[0, a, b]) | (min(x, y) < _SMALLEST[v]):
            continue
        fits = True
        for k in range(-x, x + 1):
            fits &= reach[1, a + k, b] >= y
        if fits:
            return code
    return v


# ---------------------------------------------------------------------------------------------------------------------
# the flight
@intrinsic
def _select(typingctx, cond, a, b):
    """``a if cond else b`` as one LLVM select (a conditional move, no branch), for the walk's unpredictable choice
    of axis; ``a`` and ``b`` of one type.
    """
    if not isinstance(cond, types.Boolean) or a != b:
        return None

    def codegen(context, builder, signature, args):
        return builder.select(args[0], args[1], args[2])

    return a(cond, a, b), codegen


#: scalar double compares into an all-ones / all-zeros bit mask (SSE2's cmpsd), which x86's backend keeps in vector
#: registers; elsewhere the generic compare, which LLVM may turn back into selects
_X86 = platform.machine().lower() in ("x86_64", "amd64")
_V2 = ir.VectorType(ir.DoubleType(), 2)
_MASK2 = ir.VectorType(ir.IntType(64), 2)
_LANE = ir.Constant(ir.IntType(32), 0)


def _lane(builder, x):
    """Double ``x`` in lane 0 of a 2-vector (the other lane undefined)."""
    return builder.insert_element(ir.Constant(_V2, ir.Undefined), x, _LANE)


def _le_mask(builder, a, b):
    """Lane 0 all-ones bits where double ``a <= b``, else 0 (a 2 x i64 vector: the masks stay in vector
    registers).
    """
    if not _X86:
        bit = builder.sext(builder.fcmp_ordered("<=", a, b), ir.IntType(64))
        return builder.insert_element(ir.Constant(_MASK2, ir.Undefined), bit, _LANE)
    cmp = cgutils.get_or_insert_function(
        builder.module, ir.FunctionType(_V2, [_V2, _V2, ir.IntType(8)]), "llvm.x86.sse2.cmp.sd"
    )
    mask = builder.call(cmp, [_lane(builder, a), _lane(builder, b), ir.Constant(ir.IntType(8), 2)])  # 2: <=
    return builder.bitcast(mask, _MASK2)


@intrinsic
def _advance(typingctx, t0, t1, t2, dt0, dt1, dt2):
    """The walk's next crossing times after one step: the earliest axis (ties: lowest axis first) advances by its
    ``dt``, the others keep theirs — by bit masks from the compares (``t + (mask & dt)``), no branch and no select.
    Bit for bit ``t + dt`` or ``t + 0.0 = t`` (times are >= 0 and finite).
    """
    if not all(isinstance(x, types.Float) for x in (t0, t1, t2, dt0, dt1, dt2)):
        return None

    def codegen(context, builder, signature, args):
        a0, a1, a2, d0, d1, d2 = args
        m0 = builder.and_(_le_mask(builder, a0, a1), _le_mask(builder, a0, a2))  # axis 0 earliest
        m1 = builder.and_(builder.not_(m0), _le_mask(builder, a1, a2))  # else axis 1 if not after axis 2
        m2 = builder.not_(builder.or_(m0, m1))

        def step(t, m, d):
            masked = builder.and_(m, builder.bitcast(_lane(builder, d), _MASK2))
            return builder.fadd(t, builder.extract_element(builder.bitcast(masked, _V2), _LANE))

        return context.make_tuple(
            builder, signature.return_type, [step(a0, m0, d0), step(a1, m1, d1), step(a2, m2, d2)]
        )

    return types.UniTuple(types.float64, 3)(t0, t1, t2, dt0, dt1, dt2), codegen


@njit(cache=True, inline="always")
def _axis_start(u, p, i, h):
    """(step sign, time to the first face crossing, time between crossings, crossings per unit time) of one axis for
    a flight from ``p`` in voxel ``i`` with direction component ``u``. An axis the flight does not move along never
    crosses: its times are the finite _NEVER, so that a jump's ``0 * dt`` stays 0 (not ``0 * inf = nan``).
    """
    if u > 0.0:
        iu = 1.0 / u
        return 1, min(max(((i + 1) * h - p) * iu, 0.0), _NEVER), min(h * iu, _NEVER), u / h
    if u < 0.0:
        iu = 1.0 / u
        return -1, min(max((i * h - p) * iu, 0.0), _NEVER), min(-h * iu, _NEVER), -u / h
    return 0, _NEVER, _NEVER, 0.0


@njit(cache=True, inline="always")
def _crossed(t_leave, t, rate, s, r):
    """How many faces of one axis (next crossing at ``t``, then ``rate`` per unit time) a flight crosses up to
    ``t_leave``, at most ``r``: the index advance along that axis of a jump through a pore box ``r`` faces deep ahead.
    A face crossed exactly at ``t_leave`` counts (either order of a tie is exact). A float (whole): the crossing time
    takes it without a conversion, the index converts it off that chain.
    """
    if s == 0:
        return 0.0
    return min(math.floor(max((t_leave - t) * rate, -1.0)) + 1.0, r)


@njit(cache=True, inline="always")
def _outside(i, n):
    """Whether index ``i`` is outside 0..n-1 (one unsigned compare: a negative ``i`` wraps to a huge one)."""
    return np.uint64(i) >= np.uint64(n)


@njit(cache=True, inline="always")
def _jump(m0, m1, m2, t0, t1, t2, dt0, dt1, dt2, q0, q1, q2, s0, s1, s2):
    """A jump through a pore box ``m0, m1, m2`` faces deep ahead per axis: it leaves the box at the earliest axis's
    far face, T = min_d(t_d + m_d dt_d), and each axis crosses its faces up to T (:func:`_crossed`). Returns the next
    crossing times and the faces crossed per axis (t0, t1, t2, k0, k1, k2).
    """
    t_leave = min(t0 + m0 * dt0, min(t1 + m1 * dt1, t2 + m2 * dt2))
    g0 = _crossed(t_leave, t0, q0, s0, m0)
    g1 = _crossed(t_leave, t1, q1, s1, m1)
    g2 = _crossed(t_leave, t2, q2, s2, m2)
    return t0 + g0 * dt0, t1 + g1 * dt1, t2 + g2 * dt2, np.int64(g0), np.int64(g1), np.int64(g2)


#: smallest chessboard code of a voxel whose cube is jumped through: a jump costs several walk steps, and the cube of
#: code 3 (half-width 2) saves fewer; every slab and prism code is above it
_JUMP_CODE = 4
#: offsets of the cube centres tried ahead of a voxel next to a wall, largest first (see _ahead_cube)
_AHEAD = (8, 5, 3)


@njit(cache=True, inline="always")
def _ahead_cube(flat, n0, n1, n2, i0, i1, i2, s0, s1, s2, lin, c):
    """(code, centre offsets) of a pore box that holds voxel (i0, i1, i2) and reaches far ahead of it, for a flight
    that starts in a voxel next to a wall (chessboard code ``c`` < _JUMP_CODE, an edge or a slab code), where the box
    centred on it reaches little ahead.

    The candidate centres are ``a`` voxels further along every axis the flight moves along, for ``a`` in _AHEAD in
    turn. A centre whose box's smallest half-width (_SMALLEST) is at least a and _JUMP_CODE - 1 still holds the
    particle's voxel (each offset is at most a), so the flight may jump to that box's surface; the first one wins,
    the largest offsets first because they give the largest boxes (the chessboard code is 1-Lipschitz: ca <= c + a).
    None (or outside the volume): (c, 0, 0, 0), the box of the voxel itself. ``lin`` is the voxel's flat index: a
    centre's is ``lin + a * diagonal`` (the flat step of one voxel along every moving axis), no product of indices and
    shape between the particle's voxel and the code loaded.
    """
    diagonal = (s0 * n1 + s1) * n2 + s2
    for a in _AHEAD:
        a0, a1, a2 = i0 + a * s0, i1 + a * s1, i2 + a * s2
        if (a0 < 0) | (a0 >= n0) | (a1 < 0) | (a1 >= n1) | (a2 < 0) | (a2 >= n2):
            continue
        ca = flat[np.uint64(lin + a * diagonal)]  # in the volume: no wraparound check
        if _SMALLEST[ca] >= max(a, _JUMP_CODE - 1):  # a code the flight jumps from, whatever _AHEAD holds
            return ca, a * s0, a * s1, a * s2
    return c, 0, 0, 0


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _flight(flat, n0, n1, n2, h, periodic, exit_axis, pos, idx, u, img):
    """:func:`_fly` on the flat (C order) view ``flat`` of the codes of shape (n0, n1, n2); inlined into the
    kernels, which take the view once per batch.

    Every face crossing is a time from the flight's start: per axis the next one, ``t0, t1, t2``, advanced by the
    fixed ``dt0, dt1, dt2`` (no position update, no division in the walk). A walk step picks the earliest axis
    (ties: lowest axis first) — its times by bit masks (:func:`_advance`), its indices by selects —, moves the flat
    index by that axis's stride and loads one byte. From a voxel of code >= _JUMP_CODE, a jump through the pore box
    of half-widths r_d = _HALF_WIDTH[d, code] around it leaves the box at T = min_d(t_d + r_d dt_d) and advances
    every axis by the faces it crosses before T (at most r_d: the index stays in the box). A flight that starts
    next to a wall (after a wall hit) first tries boxes centred ahead of it (:func:`_ahead_cube`): per axis it may
    then cross r_d + s_d o_d faces, up to the far face. That first jump is taken before the walk; the later ones
    inside the walk's loop (a step into a voxel of code >= _JUMP_CODE jumps on at once), so that only solid, the
    volume's outside or a periodic wrap leave the loop.
    """
    st0 = n1 * n2
    u0, u1, u2 = u[0], u[1], u[2]
    h0, h1, h2 = h[0], h[1], h[2]
    i0, i1, i2 = idx[0], idx[1], idx[2]
    s0, t0, dt0, q0 = _axis_start(u0, pos[0], i0, h0)
    s1, t1, dt1, q1 = _axis_start(u1, pos[1], i1, h1)
    s2, t2, dt2, q2 = _axis_start(u2, pos[2], i2, h2)
    f0, f1, f2 = s0 * st0, s1 * n2, s2  # flat index steps
    w0 = w1 = w2 = 0  # periodic wraps
    lin = (i0 * n1 + i1) * n2 + i2
    c = flat[np.uint64(lin)]
    if (c < _JUMP_CODE) | ((c >= _EDGE_CODE) & (c < _PRISM_CODE)):
        c, o0, o1, o2 = _ahead_cube(flat, n0, n1, n2, i0, i1, i2, s0, s1, s2, lin, c)
        if c >= _JUMP_CODE:  # the first jump: to the far face of a box centred (o0, o1, o2) from the voxel
            m0 = _HALF_WIDTH[0, c] + float(s0 * o0)  # faces ahead to the box's far face, per axis
            m1 = _HALF_WIDTH[1, c] + float(s1 * o1)
            m2 = _HALF_WIDTH[2, c] + float(s2 * o2)
            t0, t1, t2, k0, k1, k2 = _jump(m0, m1, m2, t0, t1, t2, dt0, dt1, dt2, q0, q1, q2, s0, s1, s2)
            i0, i1, i2 = i0 + k0 * s0, i1 + k1 * s1, i2 + k2 * s2
            lin += k0 * f0 + k1 * f1 + k2 * f2
            c = 1  # walk on from the box's far face
    crossings = 0
    event = -1
    t = 0.0
    while True:
        while True:  # face by face until solid or the volume's outside, jumping through the boxes worth it
            if c >= _JUMP_CODE:
                m0, m1, m2 = _HALF_WIDTH[0, c], _HALF_WIDTH[1, c], _HALF_WIDTH[2, c]
                t0, t1, t2, k0, k1, k2 = _jump(m0, m1, m2, t0, t1, t2, dt0, dt1, dt2, q0, q1, q2, s0, s1, s2)
                i0, i1, i2 = i0 + k0 * s0, i1 + k1 * s1, i2 + k2 * s2
                lin += k0 * f0 + k1 * f1 + k2 * f2
            x0 = (t0 <= t1) & (t0 <= t2)
            x1 = (not x0) & (t1 <= t2)
            x01 = x0 | x1
            t = _select(x0, t0, _select(x1, t1, t2))
            i0 = _select(x0, i0 + s0, i0)
            i1 = _select(x1, i1 + s1, i1)
            i2 = _select(x01, i2, i2 + s2)
            t0, t1, t2 = _advance(t0, t1, t2, dt0, dt1, dt2)
            lin += _select(x0, f0, _select(x1, f1, f2))
            out = _outside(i0, n0) | _outside(i1, n1) | _outside(i2, n2)
            if out:
                break
            c = flat[np.uint64(lin)]  # unsigned: no wraparound check
            if c == 0:
                break
            crossings += 1
        d = 0 if x0 else (1 if x1 else 2)
        if out:
            if d == exit_axis:
                event = EXIT_LOW + ((s0 if x0 else (s1 if x1 else s2)) > 0)
            elif periodic[d]:  # wrap, unless the voxel across the periodic face is solid
                if d == 0:
                    back, db = s0 * n0, s0 * n0 * st0
                elif d == 1:
                    back, db = s1 * n1, s1 * n1 * n2
                else:
                    back, db = s2 * n2, s2 * n2
                c = flat[lin - db]
                if c != 0:
                    lin -= db
                    if d == 0:
                        i0 -= back
                        w0 += s0
                    elif d == 1:
                        i1 -= back
                        w1 += s1
                    else:
                        i2 -= back
                        w2 += s2
                    crossings += 1
                    continue
        if event < 0:
            event = 2 * d + ((s0 if x0 else (s1 if x1 else s2)) > 0)
        break
    # the event: step back into the last pore voxel, put the particle on the face it meets
    if d == 0:
        i0 -= s0
    elif d == 1:
        i1 -= s1
    else:
        i2 -= s2
    p0 = min(max(pos[0] + t * u0 - w0 * (n0 * h0), i0 * h0), (i0 + 1) * h0)
    p1 = min(max(pos[1] + t * u1 - w1 * (n1 * h1), i1 * h1), (i1 + 1) * h1)
    p2 = min(max(pos[2] + t * u2 - w2 * (n2 * h2), i2 * h2), (i2 + 1) * h2)
    if d == 0:
        p0 = (i0 + (s0 > 0)) * h0
    elif d == 1:
        p1 = (i1 + (s1 > 0)) * h1
    else:
        p2 = (i2 + (s2 > 0)) * h2
    pos[0], pos[1], pos[2] = p0, p1, p2
    idx[0], idx[1], idx[2] = i0, i1, i2
    img[0] += w0
    img[1] += w1
    img[2] += w2
    return event, t, crossings


@njit(cache=True, fastmath=FASTMATH, **NO_REFCOUNT)
def _fly(geom, h, periodic, exit_axis, pos, idx, u, img):
    """Fly from ``pos`` (inside pore voxel ``idx``) along the unit vector ``u`` to the next event.

    Exact voxel traversal (Amanatides-Woo) with jumps through the pore boxes of the geometry codes (see
    :func:`_flight`). Ties between axes (a flight exactly through an edge or corner) are resolved
    deterministically, lowest axis first. On return ``pos``/``idx`` hold the event point and the (pore) voxel it
    belongs to; at a wall the coordinate of the hit axis is exactly the face plane. ``img`` counts periodic wraps
    per axis (unwrapped = pos + img * n * h); a wall met across a periodic face leaves it unchanged.

    Returns
    -------
    event : int
        0..5 wall face, 6 / 7 exit through the low / high face of ``exit_axis``.
    length : float
        Path length flown.
    crossings : int
        Voxel faces crossed face by face (the jumps' are not counted).
    """
    n0, n1, n2 = geom.shape
    return _flight(geom.reshape(n0 * n1 * n2), n0, n1, n2, h, periodic, exit_axis, pos, idx, u, img)


# ---------------------------------------------------------------------------------------------------------------------
# directions and speeds
@njit(cache=True, inline="always")
def _cos_theta(law, state):
    """Cos of the angle to the normal for a diffuse law; never 0 (no flight parallel to the wall)."""
    x, state = _uniform(state)
    if law == LAMBERT:
        return math.sqrt(x), state  # cosine per solid angle: sin^2 uniform
    if law == COSINE_DTHETA:
        return math.sqrt(
            1.0 - (1.0 - x) * (1.0 - x)
        ), state  # thesis (3.31) per d-theta: sin uniform in [0, 1)
    return x, state  # isotropic: cos uniform in (0, 1]


@njit(cache=True, inline="always")
def _disk(state):
    """A uniform point (a, b) of the open unit disk less its centre, and rho2 = a*a + b*b: rejection from the square
    (acceptance pi/4, two uniforms a try), no trigonometry.
    """
    while True:
        x, state = _uniform(state)
        y, state = _uniform(state)
        a = 2.0 * x - 1.0
        b = 2.0 * y - 1.0
        rho2 = a * a + b * b
        if 0.0 < rho2 < 1.0:
            return a, b, rho2, state


@njit(cache=True, inline="always")
def _diffuse_direction(law, state):
    """(c, wp, wq, state): a diffuse direction about a wall's normal for ``law``, as its component c > 0 along the
    normal and wp, wq along the next two axes (cyclic); :func:`_emit` sets it.

    Lambert: a uniform point of the unit disk (:func:`_disk`) lifted onto the hemisphere (Malley's method): sin^2 of
    the angle to the normal is rho2, uniform on (0, 1), as for ``cos = sqrt(x)`` of :func:`_cos_theta`, and the
    azimuth is uniform; the cosine is sqrt(1 - rho2) > 0 (no flight parallel to the wall). Other laws: the cosine from
    :func:`_cos_theta`, the azimuth's (cos, sin) = ((a*a - b*b), 2*a*b) / rho2 of the disk point (the angle doubled).
    """
    a, b, rho2, state = _disk(state)
    if law == LAMBERT:
        return math.sqrt(1.0 - rho2), a, b, state
    c, state = _cos_theta(law, state)
    s = math.sqrt(max(0.0, 1.0 - c * c)) / rho2
    return c, s * (a * a - b * b), s * (2.0 * a * b), state


@njit(cache=True, inline="always")
def _set_direction(axis, sign, c, wp, wq, u):
    """``u`` = ``sign * c`` along ``axis``, ``wp`` and ``wq`` along the next two axes (cyclic)."""
    u[axis] = sign * c
    u[(axis + 1) % 3] = wp
    u[(axis + 2) % 3] = wq


@njit(cache=True, **NO_REFCOUNT)
def _emit(law, axis, sign, u, state):
    """Overwrite ``u`` with a diffuse direction about the normal ``sign * e_axis`` (:func:`_diffuse_direction`)."""
    c, wp, wq, state = _diffuse_direction(law, state)
    _set_direction(axis, sign, c, wp, wq, u)
    return state


@njit(cache=True, **NO_REFCOUNT)
def _speed(dist, vmean, state):
    """A speed from ``dist`` (SPEED_MEAN / SPEED_MAXWELL / SPEED_FLUX) for a species of mean speed ``vmean``."""
    if dist == SPEED_MEAN:
        return vmean, state
    sigma = vmean * math.sqrt(math.pi / 8.0)
    if dist == SPEED_FLUX:
        x, state = _uniform(state)
        y, state = _uniform(state)
        return sigma * math.sqrt(-2.0 * math.log(x * y)), state
    x, state = _uniform(state)
    z, state = _uniform(state)
    w, state = _uniform(state)
    rad = -2.0 * math.log(x)  # g1^2 + g2^2 of a Box-Muller pair is exponential with mean 2; g3 from (z, w)
    g3 = math.sqrt(-2.0 * math.log(z)) * math.cos(_TWO_PI * w)
    acc = rad + g3 * g3
    return sigma * math.sqrt(acc), state


@njit(cache=True, **NO_REFCOUNT)
def _isotropic(u, state):
    """Uniform direction on the sphere."""
    x, state = _uniform(state)
    y, state = _uniform(state)
    c = 2.0 * x - 1.0
    s = math.sqrt(max(0.0, 1.0 - c * c))
    u[0] = c
    u[1] = s * math.cos(_TWO_PI * y)
    u[2] = s * math.sin(_TWO_PI * y)
    return state


@njit(cache=True, **NO_REFCOUNT)
def _uniform_in_pore(cells, h, pos, idx, state):
    """Uniform position in a random voxel of ``cells`` ((m, 3) int64)."""
    x, state = _uniform(state)
    c = min(int(x * cells.shape[0]), cells.shape[0] - 1)
    for d in range(3):
        idx[d] = cells[c, d]
        y, state = _uniform(state)
        pos[d] = (idx[d] + 1.0 - y) * h[d]
    return state


@njit(cache=True, **NO_REFCOUNT)
def _uniform_in_codes(geom, h, pos, idx, state):
    """Uniform position in the pore space of ``geom`` (code > 0) by rejection over the box: no voxel list, 1/ε tries."""
    n0, n1, n2 = geom.shape
    flat = geom.reshape(n0 * n1 * n2)
    while True:
        x, state = _uniform(state)
        f = min(int(x * flat.size), flat.size - 1)
        if flat[f] > 0:
            break
    idx[0], idx[1], idx[2] = f // (n1 * n2), (f // n2) % n1, f % n2
    for d in range(3):
        y, state = _uniform(state)
        pos[d] = (idx[d] + 1.0 - y) * h[d]
    return state


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _wall_draw(law, mixed, wall_speed, vmean, alpha, state):
    """The random numbers of a wall hit by ``law`` (see :func:`_reflect`), in the order :func:`_reflect` draws them:
    (diffuse, c, wp, wq, speed, state). A kernel may draw them before the flight that ends at the wall (they depend
    on the stream only), so that they are computed while the flight's walk runs, and apply them with
    :func:`_wall_apply` if the flight meets a wall (else it keeps the state from before the draw: the same stream).
    """
    diffuse = law != SPECULAR
    if mixed:
        x, state = _uniform(state)
        diffuse = diffuse and x <= alpha
    c = wp = wq = 0.0
    speed = vmean
    if diffuse:
        c, wp, wq, state = _diffuse_direction(law, state)
        if wall_speed == SPEED_FLUX:
            speed, state = _speed(SPEED_FLUX, vmean, state)
    return diffuse, c, wp, wq, speed, state


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _wall_apply(wall_speed, draw, event, u, speed_now):
    """Reflect ``u`` at wall face ``event`` with the random numbers ``draw`` of :func:`_wall_draw`; returns the
    speed after the hit.
    """
    diffuse, c, wp, wq, speed, _ = draw
    axis = event >> 1
    if diffuse:
        _set_direction(axis, -1.0 if (event & 1) else 1.0, c, wp, wq, u)  # back into the pore
        if wall_speed == SPEED_FLUX:
            return speed
    else:
        u[axis] = -u[axis]
    return speed_now


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _reflect(law, mixed, wall_speed, event, u, speed_now, vmean, alpha, state):
    """Reflect ``u`` at wall face ``event`` by ``law``; returns (speed, state).

    Called with closure constants of the kernel factories and inlined, so the branches of the laws a scene does
    not name are folded away at compile time.

    Parameters
    ----------
    law : int
        SPECULAR, LAMBERT, COSINE_DTHETA or ISOTROPIC.
    mixed : bool
        Maxwell mixture: diffuse with probability ``alpha`` (the accommodation coefficient), else specular.
    wall_speed : int
        SPEED_KEPT (|v| unchanged, thesis) or SPEED_FLUX (thermal re-emission, flux-weighted MB).
    """
    draw = _wall_draw(law, mixed, wall_speed, vmean, alpha, state)
    return _wall_apply(wall_speed, draw, event, u, speed_now), draw[5]


_CACHE: dict = {}


def wall_flags(law: int, accommodation: float, thermal: bool) -> tuple[int, bool, int]:
    """(law, mixed, wall_speed) closure constants for the factories."""
    mixed = law != SPECULAR and accommodation < 1.0
    return int(law), bool(mixed), SPEED_FLUX if thermal else SPEED_KEPT


# ---------------------------------------------------------------------------------------------------------------------
# tallies shared by the set-up kernels
#: columns of the per-batch tally array
T_PARTICLES, T_OUT_HIGH, T_OUT_LOW, T_TRUNC, T_HITS, T_CROSS, T_PATH, T_TIME, T_FLIGHTS = range(9)
N_TALLY = 9


#: bins of a flight's axial profile added without a branch on where it ends (:func:`_profile_add`)
_PROFILE_UNROLLED = 4


@njit(cache=True, **NO_REFCOUNT)
def _profile_add(prof, p_start, u_ax, length, speed, bin_w):
    """Add the time a straight flight of ``length`` from axial coordinate ``p_start`` spends in each axial bin.

    Bin by bin from the one holding the lower end: the first bin from the lower end, each next one from its lower
    edge, up to the higher end or the last bin. The first _PROFILE_UNROLLED bins are added without a branch on
    where the flight ends (a bin it does not reach adds 0.0 to the first: the same bits), the rest, if any, by the
    loop: that loop's exit, decided late by the divisions before it, was mispredicted at about every flight. Bit
    for bit the bin-by-bin loop alone (tested); the default transmission run (profile on, capillary 30 x 30 x 300,
    1 thread, CPU time, three alternated process pairs) 142-145 -> 137-139 ns per wall hit, the profile's cost
    over none ~25 -> ~19 ns (2 or 6 bins unrolled: no better or slower).
    """
    nb = prof.shape[0]
    if length <= 0.0:
        return
    p_end = p_start + u_ax * length
    lo = min(p_start, p_end)
    hi = max(p_start, p_end)
    total_t = length / speed
    if hi - lo <= 1e-300:
        b = min(max(int(lo / bin_w), 0), nb - 1)
        prof[b] += total_t
        return
    per_len = total_t / (hi - lo)
    b = min(max(int(lo / bin_w), 0), nb - 1)
    edge = (b + 1) * bin_w
    top = min(hi, edge)
    prof[b] += (top - lo) * per_len if top > lo else 0.0
    for k in range(1, _PROFILE_UNROLLED):
        reached = (hi > edge) & (b + k <= nb - 1)  # the loop would have gone on to bin b + k
        lower = edge
        edge = (b + k + 1) * bin_w
        top = min(hi, edge)
        prof[b + k if reached else b] += (top - lower) * per_len if reached else 0.0
    if (hi <= edge) | (b + _PROFILE_UNROLLED > nb - 1):
        return
    lo = edge
    b += _PROFILE_UNROLLED
    while True:
        edge = (b + 1) * bin_w
        top = min(hi, edge)
        if top > lo:
            prof[b] += (top - lo) * per_len
        if hi <= edge or b == nb - 1:
            break
        lo = edge
        b += 1


def make_transport_kernel(
    wall: tuple, inlet_law: int, inlet_speed: int, wk: bool, profile: bool, maps: bool, orient: bool
):
    """Transmission (``wk=False``) or Wicke-Kallenbach (``wk=True``) kernel with only the requested tallies.

    Transmission: each particle enters at the low face of the exit axis (a uniform point of an open inlet pixel,
    direction from ``inlet_law`` about the axis) and flies until it leaves through the high face (counted in
    T_OUT_HIGH) or back through the low face (T_OUT_LOW), or reaches ``max_hits`` wall hits (T_TRUNC).

    Wicke-Kallenbach (§3.6.3): each particle lives for ``t_end`` jiffies. It starts as species 1 at the low face or
    species 2 at the high face; leaving through its own start face (REFLEX) re-injects it there, reaching the
    opposite face (FLUSS) counts it (species 1: T_OUT_HIGH, species 2: T_OUT_LOW) and re-injects it there as the
    other species. The profile then holds the time-integrated amount of species 1 per axial bin.
    """
    key = ("transport", *wall, inlet_law, inlet_speed, bool(wk), bool(profile), bool(maps), bool(orient))
    if key in _CACHE:
        return _CACHE[key]
    _, LAW, MIXED, WSPEED, INLET, INSPEED, WK, PROFILE, MAPS, ORIENT = key

    @njit(cache=True, fastmath=FASTMATH, parallel=True)
    def _transport(
        geom,
        h,
        periodic,
        axis,
        inlet_cells,
        outlet_cells,
        seed,
        first,
        per_batch,
        max_hits,
        t_end,
        vmean,
        alpha,
        tally,
        prof,
        hitmap,
        orient_hist,
        map_bin,
    ):
        n_batches = tally.shape[0]
        n_ax = geom.shape[axis]
        length_ax = n_ax * h[axis]
        bin_w = length_ax / prof.shape[1]
        n0, n1, n2 = geom.shape
        for b in prange(n_batches):
            flat = geom.reshape(n0 * n1 * n2)
            pos = np.empty(3)
            u = np.empty(3)
            idx = np.empty(3, dtype=np.int64)
            img = np.zeros(3, dtype=np.int64)
            acc = np.zeros(4 * N_TALLY)  # batch-local counters (padded: no false sharing between threads)
            for q in range(per_batch):
                pid = first + b * per_batch + q
                state = _stream_state(seed, pid)
                species = 0
                if WK:
                    x, state = _uniform(state)
                    species = 0 if x <= 0.5 else 1
                side = species  # 0 = enter at the low face, 1 = at the high face
                t_now = 0.0
                hits = 0
                outcome = -1
                while True:
                    # (re-)injection at face `side`
                    cells = inlet_cells if side == 0 else outlet_cells
                    state = _uniform_in_pore(cells, h, pos, idx, state)
                    pos[axis] = 0.0 if side == 0 else length_ax
                    state = _emit(INLET, axis, 1.0 if side == 0 else -1.0, u, state)
                    speed, state = _speed(INSPEED, vmean, state)
                    while True:
                        p_ax = pos[axis]
                        if ORIENT:
                            ob = min(
                                int((u[axis] + 1.0) * 0.5 * orient_hist.shape[1]), orient_hist.shape[1] - 1
                            )
                            ph = math.atan2(u[(axis + 2) % 3], u[(axis + 1) % 3])
                            pb = min(
                                int((ph + math.pi) / _TWO_PI * orient_hist.shape[2]), orient_hist.shape[2] - 1
                            )
                            orient_hist[b, ob, pb] += 1
                        # the next wall hit's random numbers ahead of the flight (they overlap its walk)
                        draw = _wall_draw(LAW, MIXED, WSPEED, vmean, alpha, state)
                        ev, ln, cr = _flight(flat, n0, n1, n2, h, periodic, axis, pos, idx, u, img)
                        acc[T_CROSS] += cr
                        acc[T_PATH] += ln
                        acc[T_FLIGHTS] += 1
                        dt = ln / speed
                        if WK and t_now + dt > t_end:
                            ln = (t_end - t_now) * speed
                            dt = t_end - t_now
                            ev = -2
                        if PROFILE and ((not WK) or species == 0):
                            _profile_add(prof[b], p_ax, u[axis], ln, speed, bin_w)
                        t_now += dt
                        if ev == -2:
                            break
                        if ev >= 6:
                            break
                        hits += 1
                        if MAPS:
                            fa = ((ev >> 1) + 1) % 3
                            fb = ((ev >> 1) + 2) % 3
                            lo_ax, hi_ax = min(fa, fb), max(fa, fb)
                            ma = min(int(pos[lo_ax] / map_bin[lo_ax]), hitmap.shape[2] - 1)
                            mb = min(int(pos[hi_ax] / map_bin[hi_ax]), hitmap.shape[3] - 1)
                            hitmap[b, ev, ma, mb] += 1
                        if hits >= max_hits:
                            break
                        speed = _wall_apply(WSPEED, draw, ev, u, speed)
                        state = draw[5]
                    acc[T_TIME] += 0.0 if WK else t_now
                    if ev == -2:
                        break
                    if ev < 6:
                        outcome = 2
                        break
                    high = ev == EXIT_HIGH
                    if not WK:
                        outcome = 1 if high else 0
                        break
                    if high == (side == 0):  # FLUSS: count, swap species, re-enter from the face reached
                        acc[T_OUT_HIGH if species == 0 else T_OUT_LOW] += 1
                        species = 1 - species
                        side = 1 - side
                acc[T_PARTICLES] += 1
                acc[T_HITS] += hits
                if WK:
                    acc[T_TIME] += t_now
                elif outcome == 1:
                    acc[T_OUT_HIGH] += 1
                elif outcome == 0:
                    acc[T_OUT_LOW] += 1
                else:
                    acc[T_TRUNC] += 1
            for c in range(N_TALLY):
                tally[b, c] = acc[c]

    _CACHE[key] = _transport
    return _transport


def make_equilibrium_kernel(wall: tuple, speed_dist: int, msd: bool):
    """Particles in equilibrium (uniform in the pore space, isotropic, speeds from ``speed_dist``) for ``t_end``.

    Closed pores (``msd=False``): counts wall hits and path length (mean flight = path / hits -> 4V/S for diffuse
    Lambert walls). Periodic medium (``msd=True``): also the squared unwrapped displacement per axis at the
    sample times ``t_samples``, summed per batch into ``msd_out[b, k, axis]``. Start points: uniform over ``cells``
    ((m, 3) voxel list), or with an empty list by rejection over the codes (no per-voxel list in memory).
    """
    key = ("equilibrium", *wall, speed_dist, bool(msd))
    if key in _CACHE:
        return _CACHE[key]
    _, LAW, MIXED, WSPEED, SPEED, MSD = key

    @njit(cache=True, fastmath=FASTMATH, parallel=True)
    def _equilibrium(
        geom,
        h,
        periodic,
        cells,
        seed,
        first,
        per_batch,
        max_hits,
        t_end,
        t_samples,
        vmean,
        alpha,
        tally,
        msd_out,
    ):
        n_batches = tally.shape[0]
        n_t = t_samples.shape[0]
        ext = np.empty(3)
        for d in range(3):
            ext[d] = geom.shape[d] * h[d]
        n0, n1, n2 = geom.shape
        for b in prange(n_batches):
            flat = geom.reshape(n0 * n1 * n2)
            pos = np.empty(3)
            start = np.empty(3)
            u = np.empty(3)
            idx = np.empty(3, dtype=np.int64)
            img = np.zeros(3, dtype=np.int64)
            acc = np.zeros(4 * N_TALLY)  # batch-local counters (padded: no false sharing between threads)
            for q in range(per_batch):
                pid = first + b * per_batch + q
                state = _stream_state(seed, pid)
                if cells.shape[0] > 0:
                    state = _uniform_in_pore(cells, h, pos, idx, state)
                else:
                    state = _uniform_in_codes(geom, h, pos, idx, state)
                state = _isotropic(u, state)
                speed, state = _speed(SPEED, vmean, state)
                for d in range(3):
                    start[d] = pos[d]
                    img[d] = 0
                t_now = 0.0
                k = 0
                hits = 0
                while True:
                    ev, ln, cr = _flight(flat, n0, n1, n2, h, periodic, -1, pos, idx, u, img)
                    dt = ln / speed
                    stop = t_now + dt >= t_end or hits + 1 >= max_hits
                    if MSD:
                        while k < n_t and t_samples[k] <= t_now + dt:
                            back = (t_now + dt - t_samples[k]) * speed
                            for d in range(3):
                                disp = pos[d] - back * u[d] + img[d] * ext[d] - start[d]
                                msd_out[b, k, d] += disp * disp
                            k += 1
                    if t_now + dt > t_end:
                        ln = (t_end - t_now) * speed
                        dt = t_end - t_now
                        t_now = t_end
                        acc[T_PATH] += ln
                        break
                    t_now += dt
                    acc[T_PATH] += ln
                    acc[T_CROSS] += cr
                    acc[T_FLIGHTS] += 1
                    hits += 1
                    if stop:
                        break
                    speed, state = _reflect(LAW, MIXED, WSPEED, ev, u, speed, vmean, alpha, state)
                acc[T_PARTICLES] += 1
                acc[T_HITS] += hits
                acc[T_TIME] += t_now
                if hits >= max_hits:
                    acc[T_TRUNC] += 1
            for c in range(N_TALLY):
                tally[b, c] = acc[c]

    _CACHE[key] = _equilibrium
    return _equilibrium


# ---------------------------------------------------------------------------------------------------------------------
# geometry: the voxel wall area without full-size temporaries
@njit(cache=True)
def _wall_faces(pore, periodic, open_axis):
    """(3,) int64: pore-solid voxel faces normal to x, y, z; the outside counts as solid, except across periodic axes
    (wrap to the opposite layer) and ``open_axis`` (-1: none), where it is open.
    """
    n = np.array(pore.shape, dtype=np.int64)
    faces = np.zeros(3, dtype=np.int64)
    idx = np.empty(3, dtype=np.int64)
    for i in range(n[0]):
        for j in range(n[1]):
            for k in range(n[2]):
                p = pore[i, j, k] != 0
                idx[0], idx[1], idx[2] = i, j, k
                for d in range(3):
                    if idx[d] + 1 < n[d]:
                        nxt = idx.copy()
                        nxt[d] += 1
                        q = pore[nxt[0], nxt[1], nxt[2]] != 0
                        if p != q:
                            faces[d] += 1
                        continue
                    # the last layer of axis d: its high face, and the low face of layer 0 on the same line
                    if periodic[d]:
                        first = idx.copy()
                        first[d] = 0
                        if p != (pore[first[0], first[1], first[2]] != 0):
                            faces[d] += 1
                    elif d != open_axis:
                        first = idx.copy()
                        first[d] = 0
                        faces[d] += int(p) + int(pore[first[0], first[1], first[2]] != 0)
    return faces
