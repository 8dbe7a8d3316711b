"""Numba kernels of the sparse D3Q19 solver: neighbour table, fused stream-collide steps, reductions.

Populations are stored zero-centred, f̃_i = f_i − w_i (ρ° = 1), in a flat array ``src[q * n + node]``
(structure of arrays) of float64 or float32; arithmetic is always float64. Streaming is a two-array pull from a
source index that already encodes halfway bounce-back (the node's own opposite population when the upstream node
is solid), so the hot loop has no branch. Runs of nodes whose 18 sources all advance with the node (the open
interior of the pore space, nearly the whole of a dense box) stream by a constant offset per population:
contiguous copies, no index traffic; the other (irregular) runs read their sources from a table that holds only
their nodes. One step kernel serves the three collision operators and works a tile of nodes at a time: a tile at
least half in regular runs collides run by run straight from the population array into an L1 scratch (one
vectorised loop per run; the reads carry alias-scope metadata so the loop needs no overlap tests); any other tile
(mostly irregular, or with interpolated wall links) is first pulled into the scratch, so its collision loop has
full length however short its runs are. The scratch is then stored, with one non-temporal vector store per cache
line where the arrays exceed the last-level cache. Issue 22: the kernel before (every tile through the scratch,
element-wise stores) stays selectable as ``LEGACY`` for benchmarks/lbm.py; both give the same bits. The same
kernel also streams in place (``IN_PLACE``, the AA pattern): step pairs in one array, each store into a line the
step has just read (1.4x dense, 2x porous at 2 threads in one run of benchmarks/lbm.py), same bits; with halfway
walls, and with linear interpolated links (each link's value goes into its halfway slot before the tile collides;
the node's outgoing population it needs from the step before is kept per link). In its gather step the irregular
nodes collide in place through the gather table (:func:`_indexed_view`), in one pass instead of three (pull into
the scratch, collide, scatter back) — for float64 storage; float32 storage measured faster with the three
(:func:`_gathers_in_scratch`).
"""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np
from llvmlite import ir
from numba import literally, njit, prange, typeof, types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from porepipe._shared.numba_config import FASTMATH, by_threads
from porepipe.lbm._lattice import OPPOSITE, C, W

_CX = C[:, 0].astype(np.float64)
_CY = C[:, 1].astype(np.float64)
_CZ = C[:, 2].astype(np.float64)
_W = W.copy()
_OPP = OPPOSITE.copy()
#: nodes per tile (a multiple of 8): the 19 x _TILE float64 scratch (38.9 kB) stays in the 48 kB L1d of this machine.
#: 1 thread, f64, 128³, CPU time: 64 / 128 / 256 / 512 nodes give dense 42 / 43 / 49 / 43 MLUPS, porous φ = 0.2
#: 21 / 28 / 33 / 27 (on a 32 kB L1d, 128 may be the better choice).
_TILE = 256
#: nodes per parallel work chunk (a multiple of _TILE; one scratch allocation and one store fence per chunk).
_CHUNK = 16384
#: one-thread calls on lattices of up to one chunk of nodes (19 populations each) run the serial kernels: a single
#: chunk runs on one thread anyway, the serial code steps as fast there (mini scene, 25³), and compiles in half the time
_SERIAL_MAX = 19 * _CHUNK


def _last_level_cache_bytes(default: int = 16 * 2**20) -> int:
    """Size of the CPU's last-level cache (Linux sysfs), or ``default`` where it cannot be read."""
    try:
        text = Path("/sys/devices/system/cpu/cpu0/cache/index3/size").read_text().strip()
        return int(text[:-1]) * {"K": 2**10, "M": 2**20}[text[-1]] if text[-1] in "KM" else int(text)
    except (OSError, ValueError):
        return default


#: population arrays larger than this (bytes, both buffers) are written with non-temporal stores: they cannot stay
#: in cache until the next step reads them, and bypassing the cache saves the read-for-ownership of every line.
#: Below it cached stores win (porous 128³, 128 MB in a 480 MB L3: non-temporal stores cost 35 % there).
STREAMING_BYTES = max(16 * 2**20, _last_level_cache_bytes())


#: how a step kernel writes the populations: through the cache, non-temporally with aligned vector stores, or
#: element by element with the non-temporal hint (the kernel before issue 22: the loop does not vectorise, and on
#: x86 without SSE4a the scalar float64 stores lose the hint, so every line is read for ownership; kept so that
#: benchmarks/lbm.py can time the old kernel beside the new one in the same run).
STORE_CACHED, STORE_STREAM, LEGACY = 0, 1, 2
#: in-place streaming, the AA pattern (Bailey et al. 2009): one population array. Steps go in pairs: the gather step
#: pulls a node's populations as the two-array kernel does and writes each post-collision f*_q back into the slot
#: population ō was pulled from; the local step reads f_q of the node itself from its row ō and writes f*_q to its
#: row q. After the pair the array holds what two pull steps leave, bit for bit (the same collisions of the same
#: values); an odd last step is a pull step into the second array. Every store lands in a cache line the step has
#: just read, so plain cached stores need no read for ownership. Halfway bounce-back only (the gather table holds it);
#: interpolated links read the previous step's populations where the AA array no longer holds them.
IN_PLACE = 3
_CACHED = np.int64(STORE_CACHED)  # an int64, not a literal (see _ZERO)


def beyond_cache(nbytes: int) -> bool:
    """Whether population arrays of ``nbytes`` together exceed the last-level cache (:data:`STREAMING_BYTES`)."""
    return nbytes > STREAMING_BYTES


def streams(src) -> int:
    """How the step kernels should write ``src``'s populations (and its twin's): STORE_STREAM for arrays larger
    than the cache can hold (:data:`STREAMING_BYTES`), else STORE_CACHED.
    """
    return STORE_STREAM if beyond_cache(2 * src.nbytes) else STORE_CACHED


# -- unchecked element access (no negative-index wrap test: indices must be in range) ---------------------------------
def _item_pointer(context, builder, arrty, arr, idxty, idx):
    """Pointer to ``arr[idx]``; ``idx`` is one integer or a tuple of integers (one per axis)."""
    ary = context.make_array(arrty)(context, builder, arr)
    if isinstance(idxty, types.BaseTuple):
        parts = cgutils.unpack_tuple(builder, idx, len(idxty))
        inds = [context.cast(builder, v, t, types.intp) for v, t in zip(parts, idxty)]
    else:
        inds = [context.cast(builder, idx, idxty, types.intp)]
    return cgutils.get_item_pointer(context, builder, arrty, ary, inds, wraparound=False)


@intrinsic
def _get(typingctx, arr, idx):
    """``arr[idx]`` without the wrap-around test: loops over computed indices vectorise."""
    sig = arr.dtype(arr, idx)

    def codegen(context, builder, signature, args):
        return builder.load(
            _item_pointer(context, builder, signature.args[0], args[0], signature.args[1], args[1])
        )

    return sig, codegen


def _population_scope(builder):
    """Alias-scope list of the reads of a population array inside a collision loop: the scratch writes of the loop
    (:func:`_out`) carry it as ``!noalias``, so the vectoriser needs no run-time overlap test between 19 source rows
    and 19 scratch rows (it would give up: too many tests).
    """
    module = builder.module
    domain = module.add_metadata([ir.MetaDataString(module, "porepipe.lbm")])
    scope = module.add_metadata([ir.MetaDataString(module, "porepipe.lbm.populations"), domain])
    return module.add_metadata([scope])


def _store_codegen(nontemporal: bool):
    """Code generator of ``arr[idx] = val`` without the wrap-around test, optionally as a non-temporal store."""

    def codegen(context, builder, signature, args):
        arrty = signature.args[0]
        ptr = _item_pointer(context, builder, arrty, args[0], signature.args[1], args[1])
        store = builder.store(context.cast(builder, args[2], signature.args[2], arrty.dtype), ptr)
        if nontemporal:
            store.set_metadata("nontemporal", builder.module.add_metadata([ir.Constant(ir.IntType(32), 1)]))
        return context.get_dummy_value()

    return codegen


@intrinsic
def _set(typingctx, arr, idx, val):
    """``arr[idx] = val`` without the wrap-around test."""
    return types.void(arr, idx, val), _store_codegen(False)


@intrinsic
def _stream_store(typingctx, arr, idx, val):
    """``arr[idx] = val`` as a non-temporal store (no wrap-around test)."""
    return types.void(arr, idx, val), _store_codegen(True)


#: bytes per vector non-temporal store: one cache line (8 float64 or 16 float32 populations).
_LINE = 64


def _line_elements(arrty) -> int:
    return _LINE // (arrty.dtype.bitwidth // 8)


@intrinsic
def _per_line(typingctx, arr):
    """Elements of ``arr`` per cache line (a compile-time constant)."""
    sig = types.intp(arr)

    def codegen(context, builder, signature, args):
        return ir.Constant(ir.IntType(64), _line_elements(signature.args[0]))

    return sig, codegen


@intrinsic
def _misalign(typingctx, arr, idx):
    """Position of ``arr[idx]`` within its cache line, in elements (0: the line starts there)."""
    sig = types.intp(arr, idx)

    def codegen(context, builder, signature, args):
        ptr = _item_pointer(context, builder, signature.args[0], args[0], signature.args[1], args[1])
        address = builder.ptrtoint(ptr, ir.IntType(64))
        offset = builder.and_(address, ir.Constant(ir.IntType(64), _LINE - 1))
        return builder.udiv(offset, ir.Constant(ir.IntType(64), signature.args[0].dtype.bitwidth // 8))

    return sig, codegen


@intrinsic
def _stream_line(typingctx, dst, idx, src, sidx):
    """One cache line of ``dst`` from ``idx`` on = ``src[sidx:…]`` (converted to dst's type), written with one
    non-temporal vector store; ``dst[idx]`` must start a line (:func:`_misalign` is 0), ``src`` may be unaligned.

    The loop vectoriser emits no non-temporal vector store whose alignment it cannot prove, and x86 without SSE4a
    has no scalar non-temporal float store (LLVM writes such stores through the cache).
    """
    sig = types.void(dst, idx, src, sidx)

    def codegen(context, builder, signature, args):
        dty, ity, sty, sity = signature.args
        lanes = _line_elements(dty)
        s_type = context.get_value_type(sty.dtype)
        d_type = context.get_value_type(dty.dtype)
        sp = _item_pointer(context, builder, sty, args[2], sity, args[3])
        dp = _item_pointer(context, builder, dty, args[0], ity, args[1])
        value = builder.load(builder.bitcast(sp, ir.VectorType(s_type, lanes).as_pointer()), align=8)
        if dty.dtype != sty.dtype:
            value = builder.fptrunc(value, ir.VectorType(d_type, lanes))
        store = builder.store(
            value, builder.bitcast(dp, ir.VectorType(d_type, lanes).as_pointer()), align=_LINE
        )
        store.set_metadata("nontemporal", builder.module.add_metadata([ir.Constant(ir.IntType(32), 1)]))
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def _store_fence(typingctx):
    """Full fence (``mfence`` on x86): the non-temporal stores of this thread are visible before what follows."""
    sig = types.void()

    def codegen(context, builder, signature, args):
        builder.fence("seq_cst")
        return context.get_dummy_value()

    return sig, codegen


# -- geometry -------------------------------------------------------------------------------------------------------
@njit(cache=True)
def _node_ids(pore_flat, ids_out):
    """Number the pore voxels 0..N-1 in C order; solid voxels get -1. Returns N."""
    count = 0
    for v in range(pore_flat.size):
        if pore_flat[v]:
            ids_out[v] = count
            count += 1
        else:
            ids_out[v] = -1
    return count


@by_threads(_SERIAL_MAX, cache=True)
def _gather_table(ids, shape, periodic, n_nodes, gather_out):
    """Pull source index of every population q = 1..18 of every node (flat index into the population array).

    ``ids`` is the (L0, L1, L2) node numbering (-1 = solid). The source of population q at node x is node
    x − c_q; if that is solid (or outside a non-periodic face) the source is the node's own opposite
    population (halfway bounce-back).
    """
    l0, l1, l2 = shape[0], shape[1], shape[2]
    for i in prange(l0):
        for j in range(l1):
            for k in range(l2):
                n = ids[i, j, k]
                if n < 0:
                    continue
                for q in range(1, 19):
                    a, b, c = i - C[q, 0], j - C[q, 1], k - C[q, 2]
                    inside = True
                    if a < 0 or a >= l0:
                        if periodic[0]:
                            a %= l0
                        else:
                            inside = False
                    if b < 0 or b >= l1:
                        if periodic[1]:
                            b %= l1
                        else:
                            inside = False
                    if c < 0 or c >= l2:
                        if periodic[2]:
                            c %= l2
                        else:
                            inside = False
                    m = ids[a, b, c] if inside else -1
                    if m >= 0:
                        gather_out[q - 1, n] = q * n_nodes + m
                    else:
                        gather_out[q - 1, n] = _OPP[q] * n_nodes + n


@njit(cache=True)
def _runs(gather, min_run, start_out, regular_out):
    """Split the nodes into runs whose 18 pull sources all advance with the node (storage-order streaming).

    Within a regular run ``[start_out[r], start_out[r + 1])`` population q of node n comes from
    ``gather[q - 1, start] - start + n`` (a wall link pulls the node's own opposite population, which advances too),
    so the gather needs no index. Runs shorter than ``min_run`` are merged into irregular runs
    (``regular_out[r] = False``: use the gather table). Returns the number of runs.
    """
    n_nodes = gather.shape[1]
    n_runs = 0
    n = 0
    while n < n_nodes:
        m = n + 1
        while m < n_nodes:
            same = True
            for q in range(18):
                if np.int64(gather[q, m]) - m != np.int64(gather[q, n]) - n:
                    same = False
                    break
            if not same:
                break
            m += 1
        regular = m - n >= min_run
        if not regular and n_runs > 0 and not regular_out[n_runs - 1]:
            n = m  # extends the previous irregular run
            continue
        start_out[n_runs] = n
        regular_out[n_runs] = regular
        n_runs += 1
        n = m
    start_out[n_runs] = n_nodes
    return n_runs


@njit(cache=True)
def _wall_links(gather):
    """Number of bounce-back links: populations whose pull source is their own node's opposite population."""
    n_nodes = gather.shape[1]
    count = 0
    for q in range(1, 19):
        for n in range(n_nodes):
            count += np.int64(gather[q - 1, n]) == _OPP[q] * n_nodes + n
    return count


@njit(cache=True)
def _compact_columns(table, keep):
    """Pack the columns ``keep`` of the C-contiguous ``table`` (R, N), in order, into its first R k elements as a
    C-contiguous (R, k) table (in place); returns k. Row by row, element by element: a value moves from flat index
    q N + n to q k + i with i <= n and k <= N, never onto one not yet moved.
    """
    rows, n_cols = table.shape
    k = 0
    for n in range(n_cols):
        k += keep[n]
    flat = table.reshape(rows * n_cols)
    for q in range(rows):
        count = q * k
        for n in range(n_cols):
            if keep[n]:
                flat[count] = flat[q * n_cols + n]
                count += 1
    return k


@njit(cache=True)
def _wall_link_list(gather, node_out, pop_out, behind_out, far_out):
    """The bounce-back links of a full pull table, ordered by node then population; returns their number.

    Link k: population ``pop_out[k]`` of node ``node_out[k]`` pulls from a solid (or outside) upstream voxel.
    ``behind_out[k]`` is the pull source of the opposite population, the flat index of f*_ō at x + c_p (the node
    behind, away from the wall), or −1 if that neighbour is solid too (a one-voxel gap along the link).
    ``far_out[k]`` is the flat index of f*_ō at x + 2 c_p (two nodes behind), or −1 if that voxel or the one
    behind is solid (multi-reflection walls need both).
    """
    n_nodes = gather.shape[1]
    count = 0
    for n in range(n_nodes):
        for q in range(1, 19):
            if np.int64(gather[q - 1, n]) == _OPP[q] * n_nodes + n:
                node_out[count] = n
                pop_out[count] = q
                back = np.int64(gather[_OPP[q] - 1, n])
                behind_out[count] = -1 if back == q * n_nodes + n else back
                far_out[count] = -1
                if back != q * n_nodes + n:
                    m = back - _OPP[q] * n_nodes
                    far = np.int64(gather[_OPP[q] - 1, m])
                    far_out[count] = -1 if far == q * n_nodes + m else far
                count += 1
    return count


@njit(cache=True, parallel=True)
def _ray_sphere_fractions(points, dirs, centres, radii, box, periodic, cell_n, cell_start, cell_items, out):
    """First intersection t ∈ (0, 1] of the segments points + t · dirs with a set of (periodic) spheres.

    ``cell_start``/``cell_items`` list the spheres by the cell (edge box/cell_n >= r_max + |d|) of their centre;
    the 3 × 3 × 3 cells around a point and, on periodic axes, the images ±box of every candidate are tested.
    ``out[k]`` = −1 where no sphere meets the segment, 0 where the point itself lies in a sphere.
    """
    for k in prange(points.shape[0]):
        x0, x1, x2 = points[k, 0], points[k, 1], points[k, 2]
        d0, d1, d2 = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        aa = d0 * d0 + d1 * d1 + d2 * d2
        best = 2.0
        inside = False
        c0 = min(int(x0 / box[0] * cell_n[0]), cell_n[0] - 1)
        c1 = min(int(x1 / box[1] * cell_n[1]), cell_n[1] - 1)
        c2 = min(int(x2 / box[2] * cell_n[2]), cell_n[2] - 1)
        lo0, hi0 = (c0 - 1, c0 + 2) if cell_n[0] >= 3 else (0, cell_n[0])  # < 3 cells: each one once
        lo1, hi1 = (c1 - 1, c1 + 2) if cell_n[1] >= 3 else (0, cell_n[1])
        lo2, hi2 = (c2 - 1, c2 + 2) if cell_n[2] >= 3 else (0, cell_n[2])
        for a in range(lo0, hi0):
            for b in range(lo1, hi1):
                for c in range(lo2, hi2):
                    if (
                        ((a < 0 or a >= cell_n[0]) and not periodic[0])
                        or ((b < 0 or b >= cell_n[1]) and not periodic[1])
                        or ((c < 0 or c >= cell_n[2]) and not periodic[2])
                    ):
                        continue
                    cell = ((a % cell_n[0]) * cell_n[1] + (b % cell_n[1])) * cell_n[2] + (c % cell_n[2])
                    for m in range(cell_start[cell], cell_start[cell + 1]):
                        s = cell_items[m]
                        rr = radii[s] * radii[s]
                        for i0 in range(-1 if periodic[0] else 0, 2 if periodic[0] else 1):
                            for i1 in range(-1 if periodic[1] else 0, 2 if periodic[1] else 1):
                                for i2 in range(-1 if periodic[2] else 0, 2 if periodic[2] else 1):
                                    e0 = x0 - (centres[s, 0] + i0 * box[0])
                                    e1 = x1 - (centres[s, 1] + i1 * box[1])
                                    e2 = x2 - (centres[s, 2] + i2 * box[2])
                                    bb = e0 * d0 + e1 * d1 + e2 * d2
                                    cc = e0 * e0 + e1 * e1 + e2 * e2 - rr
                                    disc = bb * bb - aa * cc
                                    if disc < 0.0:
                                        continue
                                    t = (-bb - np.sqrt(disc)) / aa
                                    if cc <= 0.0:
                                        inside = True  # the point itself lies in the sphere
                                    if 0.0 < t < best:
                                        best = t
        out[k] = 0.0 if inside else (best if best <= 1.0 else -1.0)


@njit(cache=True, inline="always")
def _segment_polyhedron(x0, x1, x2, d0, d1, d2, planes, p0, p1):
    """First t of the segment x + t d inside the convex body {n·y <= o} of planes p0..p1 (rows n0 n1 n2 o, about
    the body's centre at the origin: x is relative to it); 2.0 where the segment misses it, 0 if x is inside.
    """
    t_in, t_out = -1e300, 1e300
    for p in range(p0, p1):
        a = planes[p, 0] * x0 + planes[p, 1] * x1 + planes[p, 2] * x2 - planes[p, 3]
        b = planes[p, 0] * d0 + planes[p, 1] * d1 + planes[p, 2] * d2
        if b == 0.0:
            if a > 0.0:
                return 2.0
        elif b < 0.0:
            t_in = max(t_in, -a / b)
        else:
            t_out = min(t_out, -a / b)
    if t_in > t_out or t_out <= 0.0:
        return 2.0
    return t_in if t_in > 0.0 else 0.0


@njit(cache=True, inline="always")
def _segment_ball(x0, x1, x2, d0, d1, d2, radius):
    """First t of the segment x + t d inside the ball of ``radius`` about the origin; 2.0 if it misses, 0 if x is in."""
    aa = d0 * d0 + d1 * d1 + d2 * d2
    bb = x0 * d0 + x1 * d1 + x2 * d2
    cc = x0 * x0 + x1 * x1 + x2 * x2 - radius * radius
    if cc <= 0.0:
        return 0.0
    disc = bb * bb - aa * cc
    if disc < 0.0:
        return 2.0
    t = (-bb - np.sqrt(disc)) / aa
    return t if t > 0.0 else 2.0


@njit(cache=True, parallel=True)
def _ray_grain_fractions(
    points,
    dirs,
    centres,
    grain,
    kind,
    radius,
    plane_ptr,
    planes,
    lo,
    edge,
    cell_n,
    cell_start,
    cell_items,
    out,
):
    """First intersection t ∈ (0, 1] of the segments points + t · dirs with placed grains (balls or convex
    polyhedra); ``out[k]`` = −1 where none meets the segment, 0 where the point itself lies in a grain.

    ``centres`` (M, 3) are the placed copies (periodic images) of grain ``grain[m]``; ``cell_start``/``cell_items``
    list, per cell of edge ``edge`` of a grid from ``lo``, every copy whose reach (its box grown by the segment length)
    overlaps the cell, so a point tests the copies of its own cell only.
    """
    for k in prange(points.shape[0]):
        best = 2.0
        cell = 0
        for ax in range(3):
            i = int((points[k, ax] - lo[ax]) / edge)
            i = min(max(i, 0), cell_n[ax] - 1)
            cell = cell * cell_n[ax] + i
        for m in range(cell_start[cell], cell_start[cell + 1]):
            c = cell_items[m]
            g = grain[c]
            x0 = points[k, 0] - centres[c, 0]
            x1 = points[k, 1] - centres[c, 1]
            x2 = points[k, 2] - centres[c, 2]
            if kind[g] == 0:
                t = _segment_ball(x0, x1, x2, dirs[k, 0], dirs[k, 1], dirs[k, 2], radius[g])
            else:
                t = _segment_polyhedron(
                    x0, x1, x2, dirs[k, 0], dirs[k, 1], dirs[k, 2], planes, plane_ptr[g], plane_ptr[g + 1]
                )
            if t < best:
                best = t
            if t == 0.0:
                break
        out[k] = best if best <= 1.0 else -1.0


# -- tiles: a parallel chunk of nodes is processed _TILE nodes at a time in a flat float64 scratch
#    ``f[q * _TILE + i]`` that stays in L1. Loading and storing a tile are contiguous per-population copies; BGK and
#    TRT collide a tile in one loop over its nodes that vectorises across nodes (the row offsets are compile-time
#    constants, so the compiler sees that the rows do not overlap and needs no run-time alias checks).
#: an int64 zero, not a literal: a literal 0 handed to a jitted helper, as an argument or as the first value of a
#: loop counter, makes numba compile the helper once more, for Literal[int](0) besides int64 (the TRT step compiled
#: _collide_trt and _fields_tile four times each instead of twice)
_ZERO = np.int64(0)
_NUMERIC = {"cache": True, "fastmath": FASTMATH, "error_model": "numpy"}  # numpy: no division-by-zero branch


@njit(inline="always", **_NUMERIC)
def _ix(q, i):
    """Index of population q of tile node i in the flat tile scratch."""
    return q * _TILE + i


@njit(**_NUMERIC)
def _lanes(cnt):
    """Nodes a tile's collision loop runs over: cnt rounded up to a multiple of 8 (whole vectors, no scalar
    remainder loop; the extra lanes hold stale scratch values and are never stored).
    """
    return (cnt + 7) & -8


@njit(**_NUMERIC)
def _load_segment(src, gather, run_offset, run_base, r, n0, cnt, t, f):
    """Pull populations 1..18 arriving at nodes n0 … n0+cnt-1 (all in run r) into tile lanes t … t+cnt-1.

    A regular run copies contiguous ranges (no index traffic); an irregular one reads its sources from the gather
    table of the irregular nodes (columns n + run_base[r], contiguous).
    """
    regular = run_offset[r, 0] >= 0
    for q in range(1, 19):
        row = q * _TILE + t
        if regular:
            off = run_offset[r, q - 1] + n0
            for i in range(cnt):
                _set(f, row + i, _get(src, off + i))
        else:
            col = n0 + run_base[r]
            for i in range(cnt):
                _set(f, row + i, _get(src, _get(gather, (q - 1, col + i))))


@njit(inline="always", **_NUMERIC)
def _pull_segment(src, gather, run_offset, run_base, r, n0, t, seg, f):
    """Pull all 19 populations of nodes n0 + t … n0 + t + seg - 1 (all in run r) into tile lanes t … t+seg-1: the
    rest population from the node itself, the others by :func:`_load_segment`.
    """
    for i in range(seg):
        _set(f, t + i, _get(src, n0 + t + i))
    _load_segment(src, gather, run_offset, run_base, r, n0 + t, seg, t, f)


@njit(inline="always", **_NUMERIC)
def _run_segment(run_start, r, pos, rest):
    """The run holding node ``pos`` (``r``: that run or an earlier one) and how many nodes from ``pos`` on lie in it,
    at most ``rest``: the step of a loop that walks a tile run by run.
    """
    while run_start[r + 1] <= pos:
        r += 1
    return r, min(rest, run_start[r + 1] - pos)


@njit(**_NUMERIC)
def _load_tile(src, gather, run_start, run_offset, run_base, r, n0, cnt, f):
    """Pull the populations arriving at nodes n0 … n0+cnt-1 into ``f``, run by run (a tile may span several runs,
    so its collision loop has full length however short the runs are). ``r`` is the run holding n0 or an earlier
    one; returns the run holding the tile's last node.
    """
    for i in range(cnt):
        _set(f, i, _get(src, n0 + i))
    t = _ZERO
    while t < cnt:
        r, seg = _run_segment(run_start, r, n0 + t, cnt - t)
        _load_segment(src, gather, run_offset, run_base, r, n0 + t, seg, t, f)
        t += seg
    return r


@njit(**_NUMERIC)
def _store_tile(dst, n0, cnt, n_nodes, f, streaming):
    """Write a tile's post-collision populations the way ``streaming`` says (STORE_CACHED, STORE_STREAM, …)."""
    for q in range(19):
        base = q * n_nodes + n0
        if streaming == LEGACY:
            for i in range(cnt):
                _stream_store(dst, base + i, _get(f, _ix(q, i)))
        elif streaming == STORE_STREAM:  # element-wise up to the first whole line and after the last one
            line = _per_line(dst)
            head = min(cnt, (line - _misalign(dst, base)) & (line - 1))
            body = head + (cnt - head) // line * line
            for i in range(head):
                _stream_store(dst, base + i, _get(f, _ix(q, i)))
            for i in range(head, body, line):
                _stream_line(dst, base + i, f, _ix(q, i))
            for i in range(body, cnt):
                _stream_store(dst, base + i, _get(f, _ix(q, i)))
        else:
            for i in range(cnt):
                _set(dst, base + i, _get(f, _ix(q, i)))


@njit(**_NUMERIC)
def _scatter_run(dst, run_offset, r, n0, t, seg, f):
    """AA gather step, regular run r: write the post-collision population q of tile lanes t … t+seg-1 (nodes
    n0 + t …) into the slots population ō was pulled from (the run's stream offsets).
    """
    for i in range(seg):
        _set(dst, n0 + t + i, _get(f, t + i))
    for q in range(1, 19):
        row = q * _TILE + t
        back = q - 2 + 2 * (q & 1)  # gather row of ō: pairs (q, q + 1) are opposite
        off = run_offset[r, back] + n0 + t
        for i in range(seg):
            _set(dst, off + i, _get(f, row + i))


# -- a tile view v = (source, rows, scope, f): the collision reads population q of tile node i from
#    ``source[rows[q] + i]`` and writes it to the scratch ``f``. Either the scratch itself (:func:`_scratch_view`, after
#    the tile was pulled into it) or, for a whole tile inside one regular run, the population array at the run's
#    stream offsets (:func:`_run_view`): the pull then happens in the collision loop, one pass over the tile less.
@njit(inline="always", **_NUMERIC)
def _scratch_view(f):
    """Source and rows None: the scratch at q * _TILE, one array at compile-time constant offsets, so the compiler
    sees that the rows do not overlap.
    """
    return (None, None, None, f)


@njit(inline="always", **_NUMERIC)
def _run_view(src, run_offset, r, n0, f):
    o = run_offset[r]
    rows = (
        n0,
        *(o[0] + n0, o[1] + n0, o[2] + n0, o[3] + n0, o[4] + n0, o[5] + n0, o[6] + n0, o[7] + n0, o[8] + n0),
        *(o[9] + n0, o[10] + n0, o[11] + n0, o[12] + n0, o[13] + n0, o[14] + n0, o[15] + n0, o[16] + n0),
        o[17] + n0,
    )
    return (src, rows, (), f)


@njit(inline="always", **_NUMERIC)
def _indexed_view(src, gather, col, n0):
    """In-place view of the irregular nodes n0 + i (gather column col + i) for the AA gather step: population q of
    lane i is read from ``src[gather[q - 1, col + i]]`` (``src[n0 + i]`` for q = 0) and its post-collision value is
    written straight back to ``src[gather[row(ō), col + i]]``, the slot the opposite population came from. No
    scratch, no scatter pass: the gather, the collision and the scatter of a node happen in one loop iteration (the
    loads and stores of one node touch slots no other node touches in this step).
    """
    return (src, (gather, col, n0), (), src)


def _indexed(rows) -> bool:
    return isinstance(rows, types.BaseTuple) and len(rows) == 3 and isinstance(rows.types[0], types.Array)


def _indexed_slot(context, builder, vty, view, q, i, back: bool):
    """Flat index of population q (with ``back``: the AA store slot of q, where ō was read) of lane i of an indexed
    view (:func:`_indexed_view`), as intp.
    """
    tabty = vty.types[1].types[0]
    rows = builder.extract_value(view, 1)
    table, col, n0 = (builder.extract_value(rows, k) for k in range(3))
    col = context.cast(builder, col, vty.types[1].types[1], types.intp)
    n0 = context.cast(builder, n0, vty.types[1].types[2], types.intp)
    one = ir.Constant(q.type, 1)
    # gather row of q is q - 1; of ō: q for odd q, q - 2 for even q (pairs (q, q + 1) are opposite)
    row = (
        builder.add(builder.sub(q, ir.Constant(q.type, 2)), builder.shl(builder.and_(q, one), one))
        if back
        else (builder.sub(q, one))
    )
    is_rest = builder.icmp_signed("==", q, ir.Constant(q.type, 0))
    out = cgutils.alloca_once(builder, ir.IntType(64))
    with builder.if_else(is_rest) as (rest, moving):
        with rest:
            builder.store(builder.add(n0, i), out)
        with moving:
            ary = context.make_array(tabty)(context, builder, table)
            ptr = cgutils.get_item_pointer(
                context, builder, tabty, ary, [row, builder.add(col, i)], wraparound=False
            )
            index = builder.load(ptr)
            index.set_metadata("alias.scope", _population_scope(builder))
            builder.store(context.cast(builder, index, tabty.dtype, types.intp), out)
    return builder.load(out)


@intrinsic
def _pop(typingctx, v, q, i):
    """Population q of tile node i of view ``v`` as float64, unchecked (the node loop vectorises):
    ``source[rows[q] + i]``, in the population scope (:func:`_population_scope`) if the view's scope is ``()``, or the
    scratch's ``f[q * _TILE + i]`` where ``source`` is None; through the gather table for an indexed view
    (:func:`_indexed_view`).

    One intrinsic rather than jitted helpers that numba inlines (a read intrinsic behind two inlined overloads was
    that): a collision loop reads ~70 populations per node, and inlining and retyping the helpers at each read took
    two thirds of the step kernel's cold compile. LLVM gets the same loads and index arithmetic (same assembly).
    """
    sig = types.float64(v, q, i)

    def codegen(context, builder, signature, args):
        vty, qty, ity = signature.args
        source, rows, scope, f = vty.types
        q = context.cast(builder, args[1], qty, types.intp)
        i = context.cast(builder, args[2], ity, types.intp)
        if isinstance(source, types.NoneType):
            arrty, arr = f, builder.extract_value(args[0], 3)
            index = builder.add(builder.mul(q, ir.Constant(q.type, _TILE)), i)
        elif _indexed(rows):
            arrty, arr = source, builder.extract_value(args[0], 0)
            index = _indexed_slot(context, builder, vty, args[0], q, i, back=False)
        else:
            arrty, arr = source, builder.extract_value(args[0], 0)
            slot = cgutils.alloca_once_value(builder, builder.extract_value(args[0], 1))
            start = context.cast(
                builder, builder.load(cgutils.gep(builder, slot, 0, q)), rows.dtype, types.intp
            )
            index = builder.add(start, i)
        value = builder.load(_item_pointer(context, builder, arrty, arr, types.intp, index))
        if not isinstance(scope, types.NoneType):
            value.set_metadata("alias.scope", _population_scope(builder))
        return context.cast(builder, value, arrty.dtype, types.float64)

    return sig, codegen


@intrinsic
def _out(typingctx, v, q, i, value):
    """Write the post-collision population q of tile node i: to the scratch ``f[q * _TILE + i]``, or for an indexed
    view (:func:`_indexed_view`) in place to the slot population ō of the node was read from. The store does not
    alias a scoped read (:func:`_population_scope`): a scratch write never does, and an in-place store only hits a
    slot its own node has already read (every store depends on all of the node's reads through ρ and j).
    """
    sig = types.void(v, q, i, value)

    def codegen(context, builder, signature, args):
        vty, qty, ity, valty = signature.args
        rows, f = vty.types[1], vty.types[3]
        q = context.cast(builder, args[1], qty, types.intp)
        i = context.cast(builder, args[2], ity, types.intp)
        if _indexed(rows):
            index = _indexed_slot(context, builder, vty, args[0], q, i, back=True)
        else:
            index = builder.add(builder.mul(q, ir.Constant(q.type, _TILE)), i)
        arr = builder.extract_value(args[0], 3)
        ptr = _item_pointer(context, builder, f, arr, types.intp, index)
        builder.store(context.cast(builder, args[3], valty, f.dtype), ptr).set_metadata(
            "noalias", _population_scope(builder)
        )
        set.add(builder.function.attributes, '"prefer-vector-width"="512"')
        return context.get_dummy_value()

    return sig, codegen


@njit(inline="always", **_NUMERIC)
def _moments(f, i):
    """(δρ, j_x, j_y, j_z) of tile node i: Σ f̃_q and Σ c_q f̃_q, summed in population order."""
    d = _pop(f, 0, i) + _pop(f, 1, i) + _pop(f, 2, i) + _pop(f, 3, i) + _pop(f, 4, i) + _pop(f, 5, i)
    d = d + _pop(f, 6, i) + _pop(f, 7, i) + _pop(f, 8, i) + _pop(f, 9, i) + _pop(f, 10, i) + _pop(f, 11, i)
    d = (
        d
        + _pop(f, 12, i)
        + _pop(f, 13, i)
        + _pop(f, 14, i)
        + _pop(f, 15, i)
        + _pop(f, 16, i)
        + _pop(f, 17, i)
    )
    d = d + _pop(f, 18, i)  # literal populations: a loop over q would index a view's rows at run time
    jx = (
        _pop(f, 1, i)
        - _pop(f, 2, i)
        + _pop(f, 7, i)
        - _pop(f, 8, i)
        + _pop(f, 9, i)
        - _pop(f, 10, i)
        + _pop(f, 11, i)
        - _pop(f, 12, i)
        + _pop(f, 13, i)
        - _pop(f, 14, i)
    )
    jy = (
        _pop(f, 3, i)
        - _pop(f, 4, i)
        + _pop(f, 7, i)
        - _pop(f, 8, i)
        - _pop(f, 9, i)
        + _pop(f, 10, i)
        + _pop(f, 15, i)
        - _pop(f, 16, i)
        + _pop(f, 17, i)
        - _pop(f, 18, i)
    )
    jz = (
        _pop(f, 5, i)
        - _pop(f, 6, i)
        + _pop(f, 11, i)
        - _pop(f, 12, i)
        - _pop(f, 13, i)
        + _pop(f, 14, i)
        + _pop(f, 15, i)
        - _pop(f, 16, i)
        - _pop(f, 17, i)
        + _pop(f, 18, i)
    )
    return d, jx, jy, jz


@njit(inline="always", **_NUMERIC)
def _force_on(n, force_lo, force_hi):
    """1.0 if node n lies in the force zone [force_lo, force_hi), else 0.0."""
    return 1.0 * ((n >= force_lo) & (n < force_hi))


@njit(**_NUMERIC)
def _fields_tile(f, lo, hi, n0, force_lo, force_hi, force, fields):
    """δρ and u = (j + ρb/2)/ρ of the pulled (pre-collision) populations of tile lanes lo … hi-1."""
    for i in range(lo, hi):
        d, jx, jy, jz = _moments(f, i)
        inv = 1.0 / (1.0 + d)
        on = 0.5 * _force_on(n0 + i, force_lo, force_hi)
        fields[0, n0 + i] = d
        fields[1, n0 + i] = jx * inv + on * force[0]
        fields[2, n0 + i] = jy * inv + on * force[1]
        fields[3, n0 + i] = jz * inv + on * force[2]


@njit(inline="always", **_NUMERIC)
def _force_coefficient(q, force):
    """3 w_q (b·c_q): the body-force source is φ_q = this × ρ (thesis Eq. 6.1.20, h0 = h2 = 0)."""
    return 3.0 * _W[q] * (_CX[q] * force[0] + _CY[q] * force[1] + _CZ[q] * force[2])


# -- collision operators on a tile (in place on the float64 scratch f). ``force`` is a tuple (b_x, b_y, b_z) so that
#    no array but f is touched in the node loop. Pairs (p, p + 1) are opposite; their c_p·j are listed in each loop.
#    BGK is TRT with ω⁻ = ω⁺ = ω (:func:`_collide`; the solver passes (ω, ω)): f + ω (f^eq − f) + φ population by
#    population.
@njit(inline="always", **_NUMERIC)
def _trt_pair(f, i, p, cj, base, inv45, rho_on, force, half_plus, half_minus):
    """TRT collision of the opposite pair (p, p + 1) with c_p·j = cj, written in the pair's sum and difference: the
    even part relaxes towards f̃^eq_p + f̃^eq_p+1 = 2 w (δρ + (9/2 (c·j)² − 3/2 j²)/ρ) at ω⁺, the odd part towards
    f̃^eq_p − f̃^eq_p+1 = 6 w c·j at ω⁻; the pair's force terms are opposite (φ_p+1 = −φ_p exactly: c and b·c change
    sign, w does not), so they ride with the odd part. ``base`` = δρ − 3/2 j²/ρ, ``inv45`` = 9/2 / ρ.

    The same operator as (f_p, f_p+1) − ½ω⁺ (…)⁺ ∓ ½ω⁻ (…)⁻ population by population, in 17 operations per pair
    instead of 27 (BGK's population-by-population form took 21): in place (the AA gather step, scalar through the
    gather table) the collision's arithmetic is what limits the step.
    """
    w = _W[p]
    f_p, f_r = _pop(f, p, i), _pop(f, p + 1, i)
    sym = half_plus * ((2.0 * w) * (base + inv45 * (cj * cj)) - (f_p + f_r))
    anti = half_minus * ((6.0 * w) * cj - (f_p - f_r)) + _force_coefficient(p, force) * rho_on
    _out(f, p, i, f_p + (sym + anti))
    _out(f, p + 1, i, f_r + (sym - anti))


@njit(**_NUMERIC)
def _collide_trt(f, lo, hi, n0, force_lo, force_hi, force, omega_plus, omega_minus):
    """TRT (BGK where ω⁻ = ω⁺) collision of tile lanes lo … hi-1, with the body force on nodes in [force_lo, force_hi)."""
    hp = 0.5 * omega_plus
    hm = 0.5 * omega_minus
    for i in range(lo, hi):
        d, jx, jy, jz = _moments(f, i)
        rho = 1.0 + d
        inv = 1.0 / rho
        base = d - 1.5 * (jx * jx + jy * jy + jz * jz) * inv
        inv45 = 4.5 * inv
        on = rho * _force_on(n0 + i, force_lo, force_hi)
        _out(f, 0, i, _pop(f, 0, i) + omega_plus * (_W[0] * base - _pop(f, 0, i)))
        _trt_pair(f, i, 1, jx, base, inv45, on, force, hp, hm)
        _trt_pair(f, i, 3, jy, base, inv45, on, force, hp, hm)
        _trt_pair(f, i, 5, jz, base, inv45, on, force, hp, hm)
        _trt_pair(f, i, 7, jx + jy, base, inv45, on, force, hp, hm)
        _trt_pair(f, i, 9, jx - jy, base, inv45, on, force, hp, hm)
        _trt_pair(f, i, 11, jx + jz, base, inv45, on, force, hp, hm)
        _trt_pair(f, i, 13, jx - jz, base, inv45, on, force, hp, hm)
        _trt_pair(f, i, 15, jy + jz, base, inv45, on, force, hp, hm)
        _trt_pair(f, i, 17, jy - jz, base, inv45, on, force, hp, hm)


# -- MRT (d'Humières 2002 basis, rows of :func:`porepipe.lbm._lattice.dhumieres_matrix`), per node as BGK/TRT.
#    f ← f − M⁻¹ Š (m − m^eq) + φ with M⁻¹ = Mᵀ diag(1/|M_k|²) (rows orthogonal). M has only 0/±1/±2/… entries
#    that depend on the pair sums a_p = f_p + f_p+1 (even moments) and differences b_p = f_p − f_p+1 (odd moments),
#    so m and Mᵀ(…) are written out as sums shared between moments. ``s`` is the tuple of s_k / |M_k|² in row order;
#    the conserved rows (ρ, j) have s_k = 0 and are skipped. The equilibrium moments of the zero-centred f̃^eq:
#    e = −11 δρ + 19 j²/ρ, ε = 3 δρ − 11/2 j²/ρ, q = −2/3 j, 3p_xx = (2j_x² − j_y² − j_z²)/ρ, p_ww = (j_y² − j_z²)/ρ,
#    π = −p/2, p_αβ = j_α j_β/ρ, m = 0.
@njit(inline="always", **_NUMERIC)
def _pair(f, i, p):
    """(f_p + f_p+1, f_p − f_p+1) of tile node i."""
    x, y = _pop(f, p, i), _pop(f, p + 1, i)
    return x + y, x - y


@njit(inline="always", **_NUMERIC)
def _mrt_even(r, ax, ay, az, a7, a9, a11, a13, a15, a17, jx, jy, jz, jj, inv, s):
    """Relaxed even moments mapped back: (Δf_0, axis x, y, z, diagonal xy, xz, yz, ±p_xy, ±p_xz, ±p_yz parts)."""
    dxy, dxz, dyz = a7 + a9, a11 + a13, a15 + a17
    sa, sd = ax + ay + az, dxy + dxz + dyz
    e = s[1] * (19.0 * (sd - r - jj * inv))
    eps = s[2] * (9.0 * r - 7.0 * sa - 2.0 * sd + 5.5 * jj * inv)
    axx, dxx, pxx = 2.0 * ax - ay - az, dxy + dxz - 2.0 * dyz, (2.0 * jx * jx - jy * jy - jz * jz) * inv
    aww, dww, pww = ay - az, dxy - dxz, (jy * jy - jz * jz) * inv
    p_xx, pi_xx = s[9] * (axx + dxx - pxx), s[10] * (dxx - 2.0 * axx + 0.5 * pxx)
    p_ww, pi_ww = s[11] * (aww + dww - pww), s[12] * (dww - 2.0 * aww + 0.5 * pww)
    u1, u2, w1, w2 = p_xx - 2.0 * pi_xx, p_xx + pi_xx, p_ww - 2.0 * pi_ww, p_ww + pi_ww
    axis, diag = -11.0 * e - 4.0 * eps, 8.0 * e + eps
    return (
        12.0 * eps - 30.0 * e,
        axis + 2.0 * u1,
        axis - u1 + w1,
        axis - u1 - w1,
        diag + u2 + w2,
        diag + u2 - w2,
        diag - 2.0 * u2,
        s[13] * (a7 - a9 - jx * jy * inv),
        s[15] * (a11 - a13 - jx * jz * inv),
        s[14] * (a15 - a17 - jy * jz * inv),
    )


@njit(inline="always", **_NUMERIC)
def _mrt_odd(bx, by, bz, b7, b9, b11, b13, b15, b17, s):
    """Relaxed odd moments mapped back: (axis x, y, z, then per diagonal plane xy, xz, yz the parts A ± B)."""
    qx = s[4] * (5.0 / 3.0) * (b7 + b9 + b11 + b13 - 2.0 * bx)
    qy = s[6] * (5.0 / 3.0) * (b7 - b9 + b15 + b17 - 2.0 * by)
    qz = s[8] * (5.0 / 3.0) * (b11 - b13 + b15 - b17 - 2.0 * bz)
    mx = s[16] * (b7 + b9 - b11 - b13)
    my = s[17] * (b9 - b7 + b15 + b17)
    mz = s[18] * (b11 - b13 - b15 + b17)
    return -4.0 * qx, -4.0 * qy, -4.0 * qz, qx + mx, qy - my, qx - mx, qz + mz, qy + my, qz - mz


@njit(inline="always", **_NUMERIC)
def _mrt_set(f, i, p, even, odd, rho_on, force):
    """Post-collision pair (p, p + 1): f_p − (even + odd) + φ_p, f_p+1 − (even − odd) + φ_p+1."""
    _out(f, p, i, _pop(f, p, i) - (even + odd) + _force_coefficient(p, force) * rho_on)
    _out(f, p + 1, i, _pop(f, p + 1, i) - (even - odd) + _force_coefficient(p + 1, force) * rho_on)


@njit(inline="always", **_NUMERIC)
def _mrt_plane(f, i, p, even, p_ab, odd_a, odd_b, rho_on, force):
    """The two diagonal pairs p, p + 2 of one plane: even ± p_αβ, odd A ± B."""
    _mrt_set(f, i, p, even + p_ab, odd_a + odd_b, rho_on, force)
    _mrt_set(f, i, p + 2, even - p_ab, odd_a - odd_b, rho_on, force)


@njit(inline="always", **_NUMERIC)
def _mrt_node(f, i, on, force, s):
    """MRT collision of tile node i in place (``on`` = 1.0 in the force zone)."""
    r = _pop(f, 0, i)
    ax, bx = _pair(f, i, 1)
    ay, by = _pair(f, i, 3)
    az, bz = _pair(f, i, 5)
    a7, b7 = _pair(f, i, 7)
    a9, b9 = _pair(f, i, 9)
    a11, b11 = _pair(f, i, 11)
    a13, b13 = _pair(f, i, 13)
    a15, b15 = _pair(f, i, 15)
    a17, b17 = _pair(f, i, 17)
    rho = 1.0 + (r + (ax + ay + az) + (a7 + a9 + a11 + a13 + a15 + a17))
    jx, jy, jz = bx + b7 + b9 + b11 + b13, by + b7 - b9 + b15 + b17, bz + b11 - b13 + b15 - b17
    ev = _mrt_even(
        r, ax, ay, az, a7, a9, a11, a13, a15, a17, jx, jy, jz, jx * jx + jy * jy + jz * jz, 1.0 / rho, s
    )
    od = _mrt_odd(bx, by, bz, b7, b9, b11, b13, b15, b17, s)
    rho_on = rho * on
    _out(f, 0, i, r - ev[0])
    _mrt_set(f, i, 1, ev[1], od[0], rho_on, force)
    _mrt_set(f, i, 3, ev[2], od[1], rho_on, force)
    _mrt_set(f, i, 5, ev[3], od[2], rho_on, force)
    _mrt_plane(f, i, 7, ev[4], ev[7], od[3], od[4], rho_on, force)
    _mrt_plane(f, i, 11, ev[5], ev[8], od[5], od[6], rho_on, force)
    _mrt_plane(f, i, 15, ev[6], ev[9], od[7], od[8], rho_on, force)


@njit(**_NUMERIC)
def _collide_mrt(f, lo, hi, n0, force_lo, force_hi, force, s):
    for i in range(lo, hi):
        _mrt_node(f, i, _force_on(n0 + i, force_lo, force_hi), force, s)


# -- interpolated bounce-back: after a tile is pulled, the scratch slot of a boundary link holds the halfway value
#    h = f*_ō(x), and the slot of population ō holds f*_ō(x + c_p) (pulled from the node behind). The link becomes
#    f_p = h + b (f*_ō(x + c_p) − h) + c (f*_p(x) − h) (porepipe.lbm._walls). Per link only its slot in the tile
#    (uint16: p · _TILE + i) and b, c (float32) are stored, grouped by tile; the one extra read is f*_p(x).
@njit(inline="always", **_NUMERIC)
def _link_value(h, behind, own, b, c):
    """A linear link, h + b (f*_ō(x + c_p) − h) + c (f*_p(x) − h), from its halfway value h, the population behind
    the node and the node's own outgoing one (one expression for the pull and the in-place kernels: same bits).
    """
    return h + np.float64(b) * (behind - h) + np.float64(c) * (own - h)


@njit(inline="always", **_NUMERIC)
def _linear_link(f, src, s, n0, n_nodes, b, c):
    """Linear link value of the link in scratch slot ``s`` (p · _TILE + i), :func:`_link_value`."""
    p = s // _TILE
    i = s - p * _TILE
    return _link_value(_get(f, s), _get(f, _OPP[p] * _TILE + i), _get(src, p * n_nodes + n0 + i), b, c)


@njit(**_NUMERIC)
def _apply_links(f, src, n0, n_nodes, tile_start, slot, coef_b, coef_c):
    """Interpolate the boundary links of the tile that starts at node n0 (a multiple of _TILE)."""
    tile = n0 // _TILE
    for k in range(tile_start[tile], tile_start[tile + 1]):
        s = np.int64(slot[k])
        _set(f, s, _linear_link(f, src, s, n0, n_nodes, coef_b[k], coef_c[k]))


# -- linear links in place (AA): a link's halfway value h sits in the slot its population is read from, the same
#    slot in both steps of a pair (row ō of the node); the population behind it sits in the slot the node reads ō
#    from (gather step: the upstream neighbour's, local step: row p of the node), which is also where the node
#    stores its own outgoing p; that outgoing value is needed again one step later, when the neighbour may already
#    have overwritten its slot, so it is kept per link (``own``). Every slot touched belongs to the link's node alone
#    in that step, so tiles and chunks stay independent.
@njit(cache=True)
def _source_slot(gather, run_offset, run_base, r, x, q):
    """Flat index population q (1..18) of node x (in run r) is pulled from."""
    if run_offset[r, 0] >= 0:
        return run_offset[r, q - 1] + x
    return np.int64(gather[q - 1, x + run_base[r]])


@njit(cache=True)
def aa_link_slots(gather, run_start, run_offset, run_base, tile_start, link_slot, out):
    """Fill ``out`` (K,) uint32 with the slot of the population behind every linear link in a gather step (in a
    local step it is row p of the node itself). Returns -1, or the first link whose population is not pulled by
    bounce-back (not a wall link: the links do not belong to this lattice).
    """
    n_nodes = run_start[-1]
    for t in range(tile_start.size - 1):
        for k in range(tile_start[t], tile_start[t + 1]):
            s = np.int64(link_slot[k])
            p = s // _TILE
            x = t * _TILE + s - p * _TILE
            r = np.searchsorted(run_start, x, side="right") - 1
            if _source_slot(gather, run_offset, run_base, r, x, p) != _OPP[p] * n_nodes + x:
                return k
            out[k] = _source_slot(gather, run_offset, run_base, r, x, _OPP[p])
    return -1


@njit(inline="always", **_NUMERIC)
def _aa_link_at(n0, n_nodes, link_slot, behind_gather, local, k):
    """(halfway slot, behind slot) of link k of the tile at n0, in a local or a gather step."""
    s = np.int64(_get(link_slot, k))
    p = s // _TILE
    x = n0 + s - p * _TILE
    behind = p * n_nodes + x if local else np.int64(_get(behind_gather, k))
    return _OPP[p] * n_nodes + x, behind


@njit(**_NUMERIC)
def _aa_links_in(a, n0, n_nodes, tile_start, link_slot, link_b, link_c, behind_gather, local, own):
    """Before the tile at n0 collides in place: each linear link's value into its halfway slot (in link order, as
    :func:`_apply_links`). Indexed by ``_get``/``_set`` (no wrap-around test per index), as :func:`_aa_links_own`:
    both passes together ~1.5 ms less per step on the porous 128³ φ 0.2 sample with CLI walls (~1.0 M links;
    13.4-14.6 against 15.2-16.4 ms, 1 thread, alternated processes).
    """
    tile = n0 // _TILE
    for k in range(tile_start[tile], tile_start[tile + 1]):
        halfway, behind = _aa_link_at(n0, n_nodes, link_slot, behind_gather, local, k)
        h = np.float64(_get(a, halfway))
        link = _link_value(h, np.float64(_get(a, behind)), _get(own, k), _get(link_b, k), _get(link_c, k))
        _set(a, halfway, link)


@njit(**_NUMERIC)
def _aa_links_own(a, n0, n_nodes, tile_start, link_slot, behind_gather, local, own):
    """Keep each link node's outgoing population p of the tile at n0: after the tile stored, it sits where the
    population behind the link came from; before a run's first step, row p of the node (``local``).
    """
    tile = n0 // _TILE
    for k in range(tile_start[tile], tile_start[tile + 1]):
        _set(own, k, _get(a, _aa_link_at(n0, n_nodes, link_slot, behind_gather, local, k)[1]))


# -- multi-reflection (MR1) links add, per link, d (f*_ō(x + 2c_p) − f*_p(x + c_p)) (two flat indices into the source
#    array) and a correction e g n⁻_ō(x): n⁻ the antisymmetric non-equilibrium part of the node's pre-collision
#    populations in the previous step (equilibrium of j = Σ c f, no force shift), g = 1 − ω⁻/2; g n⁻ is kept per
#    link in ``state``.
@njit(**_NUMERIC)
def _momentum_tile(f, cnt, j):
    """Momenta Σ c_q f̃_q of tile lanes 0 … cnt-1 (rounded up to whole vectors) into ``j`` (3 · _TILE: x, y, z rows),
    in one vectorised pass: the multi-reflection state needs them at most nodes of a porous tile, and node by node
    they cost as much as the rest of the link (benchmarks/lbm.py: MR1 ns per link).
    """
    view = _scratch_view(f)
    for i in range(_lanes(cnt)):
        _, jx, jy, jz = _moments(view, i)
        _set(j, i, jx)
        _set(j, _TILE + i, jy)
        _set(j, 2 * _TILE + i, jz)


@njit(**_NUMERIC)
def _apply_mr_links(f, src, n0, cnt, n_nodes, tile_start, slot, coef_b, coef_c, mr, state, g, j):
    """Interpolate the tile's links as :func:`_apply_links` plus the multi-reflection terms, then store each link's
    g n⁻_ō(x) of the completed pre-collision populations for the next step.

    ``mr`` = (far, far_own, coef_d, coef_e): flat indices of f*_ō(x + 2c_p) and f*_p(x + c_p), and the weights;
    ``j``: scratch for the tile's momenta (:func:`_momentum_tile`).
    """
    far, far_own, coef_d, coef_e = mr
    tile = n0 // _TILE
    lo, hi = tile_start[tile], tile_start[tile + 1]
    for k in range(lo, hi):
        s = np.int64(slot[k])
        second = _get(src, far[k]) - _get(src, far_own[k])
        value = _linear_link(f, src, s, n0, n_nodes, coef_b[k], coef_c[k])
        _set(f, s, value + np.float64(coef_d[k]) * second + np.float64(coef_e[k]) * state[k])
    _momentum_tile(f, cnt, j)
    for k in range(lo, hi):
        s = np.int64(slot[k])
        p = s // _TILE
        i = s - p * _TILE
        o = _OPP[p]
        cj = _CX[o] * _get(j, i) + _CY[o] * _get(j, _TILE + i) + _CZ[o] * _get(j, 2 * _TILE + i)
        state[k] = g * (0.5 * (_get(f, o * _TILE + i) - _get(f, s)) - 3.0 * _W[o] * cj)


# -- the step kernel ------------------------------------------------------------------------------------------------
BGK, TRT, MRT = 0, 1, 2


@njit(inline="always", **_NUMERIC)
def _mostly_regular(run_start, run_offset, r, n0, cnt):
    """Whether regular runs hold at least half the tile n0 … n0+cnt-1 (``r``: the run holding n0 or an earlier one).

    Such tiles collide run by run straight from the population array (:func:`_pull_collide`); the others go through
    the scratch as a whole: on a porous sample (1 % of the nodes in regular runs) run by run was 12 % slower.
    """
    regular = 0
    while run_start[r] < n0 + cnt:
        if run_offset[r, 0] >= 0:
            regular += min(run_start[r + 1], n0 + cnt) - max(run_start[r], n0)
        r += 1
    return 2 * regular >= cnt


@njit(inline="always", **_NUMERIC)
def _has_links(n0, tile_start, link_slot):
    """Whether the tile at n0 has interpolated boundary links."""
    return link_slot.size > 0 and tile_start[n0 // _TILE] < tile_start[n0 // _TILE + 1]


@njit(**_NUMERIC)
def _pull_collide(
    op, src, gather, run_start, run_offset, run_base, r, n0, cnt, f, keep, fz, force, fields, w, s
):
    """Collide the tile at n0 (cnt nodes, no interpolated links) into the scratch ``f``, run by run: a regular run's
    nodes read their populations straight from ``src`` (:func:`_run_view`), an irregular run is pulled into the
    scratch first. ``fz`` = (force_lo, force_hi); the fields of the pulled populations if ``keep``. ``r`` is the run
    holding n0 or an earlier one; returns the run holding the tile's last node.
    """
    scratch = _scratch_view(f)
    t = _ZERO
    while t < cnt:
        r, seg = _run_segment(run_start, r, n0 + t, cnt - t)
        if run_offset[r, 0] >= 0:
            view = _run_view(src, run_offset, r, n0, f)
            if keep:
                _fields_tile(view, t, t + seg, n0, fz[0], fz[1], force, fields)
            _collide(literally(op), view, t, t + seg, n0, fz[0], fz[1], force, w, s)
        else:
            _pull_segment(src, gather, run_offset, run_base, r, n0, t, seg, f)
            if keep:
                _fields_tile(scratch, t, t + seg, n0, fz[0], fz[1], force, fields)
            _collide(literally(op), scratch, t, t + seg, n0, fz[0], fz[1], force, w, s)
        t += seg
    return r


@njit(**_NUMERIC)
def _aa_gather_tile(op, src, gather, run_start, run_offset, run_base, r, n0, cnt, f, fz, force, w, s):
    """AA gather step of the tile at n0 (cnt nodes; linear links already in their halfway slots) in place, run by
    run: a regular run collides straight from ``src`` into the scratch ``f`` and writes back by its stream offsets
    (:func:`_scatter_run`); an irregular run collides in place through the gather table (:func:`_indexed_view`: one
    pass, no scratch) or, where :func:`_gathers_in_scratch` says so (float32 storage), is pulled into the scratch,
    collided there and scattered back (:func:`_scatter_segment`). Arguments as :func:`_pull_collide` (no fields: a
    gather step is never a run's last step, which is a local or a pull step); returns the run holding the tile's
    last node.
    """
    t = _ZERO
    while t < cnt:
        r, seg = _run_segment(run_start, r, n0 + t, cnt - t)
        if run_offset[r, 0] >= 0:
            view = _run_view(src, run_offset, r, n0, f)
            _collide(literally(op), view, t, t + seg, n0, fz[0], fz[1], force, w, s)
            _scatter_run(src, run_offset, r, n0, t, seg, f)
        elif _gathers_in_scratch(src):
            _pull_segment(src, gather, run_offset, run_base, r, n0, t, seg, f)
            _collide(literally(op), _scratch_view(f), t, t + seg, n0, fz[0], fz[1], force, w, s)
            _scatter_segment(src, gather, n0 + run_base[r], n0, t, seg, f)
        else:
            view = _indexed_view(src, gather, n0 + run_base[r], n0)
            _collide(literally(op), view, t, t + seg, n0, fz[0], fz[1], force, w, s)
        t += seg
    return r


def _gathers_in_scratch(src):
    """Whether the AA gather step pulls an irregular run of population array ``src`` into the scratch, collides it
    there (vectorised) and scatters it back (:func:`_scatter_segment`), instead of colliding it in place through the
    gather table (scalar, one pass): for float32 storage, not for float64. Porous 128^3, 4-step bursts after a cache
    flush, processes alternated, 2 threads, on an AVX-512 Intel machine: float32 BGK / TRT / MRT 1.2x / 1.2x /
    1.24x faster in the scratch (the in-place loop converts every value it reads and writes one by one); float64 in
    place 1.16x / 1.12-1.17x / 1.13-1.2x faster, once TRT's arithmetic was slimmed (:func:`_trt_pair`; before, TRT
    alone ran faster in the scratch). The same arithmetic on the same values: the same bits either way.
    """


@overload(_gathers_in_scratch, jit_options=_NUMERIC)
def _gathers_in_scratch_of(src):
    """The jitted :func:`_gathers_in_scratch`: a constant of ``src``'s dtype, so the other path is not compiled."""
    in_scratch = src.dtype == types.float32
    return lambda src: in_scratch


@njit(**_NUMERIC)
def _scatter_segment(dst, gather, col, n0, t, seg, f):
    """AA gather step, irregular run: write the post-collision population q of tile lanes t … t+seg-1 (nodes
    n0 + t …, gather columns col + t …) into the slots population ō was pulled from (the gather table's row of ō).
    """
    for i in range(seg):
        _set(dst, n0 + t + i, _get(f, t + i))
    for q in range(1, 19):
        row = q * _TILE + t
        back = q - 2 + 2 * (q & 1)  # gather row of ō: pairs (q, q + 1) are opposite
        for i in range(seg):
            _set(dst, _get(gather, (back, col + t + i)), _get(f, row + i))


def _gather_step(with_aa, op, src, gather, run_start, run_offset, run_base, r, n0, cnt, f, fz, force, w, s):
    """The AA gather step of a tile (:func:`_aa_gather_tile`, same arguments after ``with_aa``) in a step kernel
    compiled for in-place streaming (the literal ``with_aa`` True); in one compiled for the two-array kernel alone
    (False: interpolated walls, ``streaming: pull``) nothing, so the in-place code is not compiled there (~5 of the
    step kernel's ~15 CPU-s of cold compilation, measured on the mini scene's CLI-wall job). Returns the run holding
    the tile's last node.
    """


@overload(_gather_step, prefer_literal=True, jit_options=_NUMERIC)
def _gather_step_if_compiled(
    with_aa, op, src, gather, run_start, run_offset, run_base, r, n0, cnt, f, fz, force, w, s
):
    """The jitted :func:`_gather_step` of the literal ``with_aa``."""
    if not isinstance(with_aa, types.BooleanLiteral):
        raise TypeError("_gather_step: with_aa must be a literal (call it with literally(with_aa))")
    if with_aa.literal_value:

        def gather_in_place(
            with_aa, op, src, gather, run_start, run_offset, run_base, r, n0, cnt, f, fz, force, w, s
        ):
            return _aa_gather_tile(
                literally(op), src, gather, run_start, run_offset, run_base, r, n0, cnt, f, fz, force, w, s
            )

        return gather_in_place

    def not_compiled(
        with_aa, op, src, gather, run_start, run_offset, run_base, r, n0, cnt, f, fz, force, w, s
    ):
        return r

    return not_compiled


def _collide(op, v, lo, hi, n0, force_lo, force_hi, force, omega, rates):
    """Collide tile lanes lo … hi-1 of view ``v`` with operator ``op``; ``omega`` = (ω⁺, ω⁻) for TRT and BGK (which
    is TRT with ω⁻ = ω⁺: the solver passes (ω, ω)), ``rates`` (s_k/|M_k|²) for MRT.

    In jitted code ``op`` must be a literal (``literally(op)``): only that operator's code is compiled, a third of
    the three (the step kernel's cold compile shrinks by ~40 %, the mini scene's by ~8 CPU-s).
    """
    if op == MRT:
        _collide_mrt(v, lo, hi, n0, force_lo, force_hi, force, rates)
    else:
        _collide_trt(v, lo, hi, n0, force_lo, force_hi, force, omega[0], omega[1])


@overload(_collide, prefer_literal=True, jit_options=_NUMERIC)
def _collide_one_operator(op, v, lo, hi, n0, force_lo, force_hi, force, omega, rates):
    """The jitted :func:`_collide` of the one operator the literal ``op`` names."""
    if not isinstance(op, types.IntegerLiteral):
        raise TypeError(
            "_collide: op must be a literal (call it with literally(op)), so one operator compiles"
        )
    if op.literal_value == MRT:
        return lambda op, v, lo, hi, n0, force_lo, force_hi, force, omega, rates: _collide_mrt(
            v, lo, hi, n0, force_lo, force_hi, force, rates
        )
    return lambda op, v, lo, hi, n0, force_lo, force_hi, force, omega, rates: _collide_trt(
        v, lo, hi, n0, force_lo, force_hi, force, omega[0], omega[1]
    )


@by_threads(_SERIAL_MAX, cache=True, fastmath=FASTMATH, error_model="numpy")
def _step(
    op,
    with_aa,
    src,
    dst,
    gather,
    run_start,
    run_offset,
    run_base,
    force_lo,
    force_hi,
    force,
    fields,
    store,
    n_steps,
    streaming,
    omega,
    rates,
    tile_start,
    link_slot,
    link_b,
    link_c,
    link_mr,
    link_state,
    link_aa,
):
    """``n_steps`` steps of operator ``op`` (BGK, TRT, MRT), alternating src -> dst -> src; the fields of the last
    step if ``store``. ``streaming``: how to write the populations (STORE_CACHED, STORE_STREAM, … :func:`streams`);
    IN_PLACE only in the variant compiled ``with_aa`` (a literal, as ``op``: :func:`_gather_step`).

    Each parallel chunk of _CHUNK nodes runs tile by tile: pull into the L1 scratch, interpolate its boundary links
    (links of tile t: ``tile_start[t]:tile_start[t + 1]``; an empty ``link_slot`` for halfway bounce-back), collide,
    store. ``link_mr`` (flat indices and weights of the multi-reflection terms, :func:`_apply_mr_links`) is empty
    for the linear schemes; ``link_state`` carries n⁻ of every multi-reflection link from step to step.
    ``link_aa``: the slot behind each linear link in a gather step (:func:`aa_link_slots`; empty without links):
    with IN_PLACE each link's value goes into its halfway slot before its tile collides (:func:`_aa_links_in`).
    """
    n_nodes = run_start[-1]
    g = 1.0 - 0.5 * omega[1]
    multi = link_mr[0].size > 0
    fuse = streaming != LEGACY
    fz = (force_lo, force_hi)
    b3 = (force[0], force[1], force[2])
    w2 = (omega[0], omega[1])
    n_chunks = (n_nodes + _CHUNK - 1) // _CHUNK
    in_place = streaming == IN_PLACE
    n_pairs = n_steps // 2 if in_place else 0  # AA step pairs; an odd last step pulls src -> dst
    mode = _CACHED if in_place else streaming
    # the local step as one regular run whose population q comes from row ō of the node itself: it collides through
    # the same compiled code as a pull step's regular runs
    local_start = np.array([0, n_nodes])
    local_offset = np.empty((1, 18), dtype=np.int64)
    for q in range(1, 19):
        local_offset[0, q - 1] = _OPP[q] * n_nodes
    aa_links = in_place and link_aa.size > 0
    own = np.empty(link_aa.size if aa_links else 0)  # each link node's outgoing p of the step before
    if aa_links:
        for t in range(tile_start.size - 1):
            _aa_links_own(src, t * _TILE, n_nodes, tile_start, link_slot, link_aa, True, own)
    for s in range(n_steps):
        aa = s < 2 * n_pairs
        local = aa and s % 2 == 1
        a, b = (src, dst) if s % 2 == 0 else (dst, src)
        if aa:
            a, b = src, src
        rs, ro = (local_start, local_offset) if local else (run_start, run_offset)
        keep = store and s == n_steps - 1
        for c in prange(n_chunks):
            f = np.zeros(19 * _TILE)  # zeros: the padding lanes of a short tile stay finite
            j = np.zeros(3 * _TILE if multi else 0)
            scratch = _scratch_view(f)
            n0, hi = c * _CHUNK, min(n_nodes, (c + 1) * _CHUNK)
            r = np.searchsorted(rs, n0, side="right") - 1
            while n0 < hi:
                cnt = min(_TILE, hi - n0)
                if aa and aa_links:
                    _aa_links_in(a, n0, n_nodes, tile_start, link_slot, link_b, link_c, link_aa, local, own)
                if aa and not local:
                    r = _gather_step(  # op is a literal here already (literally(op) below)
                        literally(with_aa), op, a, gather, rs, ro, run_base, r, n0, cnt, f, fz, b3, w2, rates
                    )
                    if aa_links:
                        _aa_links_own(a, n0, n_nodes, tile_start, link_slot, link_aa, False, own)
                    n0 += cnt
                    continue
                if local or (
                    fuse and not _has_links(n0, tile_start, link_slot) and _mostly_regular(rs, ro, r, n0, cnt)
                ):
                    r = _pull_collide(
                        literally(op),
                        a,
                        gather,
                        rs,
                        ro,
                        run_base,
                        r,
                        n0,
                        cnt,
                        f,
                        keep,
                        fz,
                        b3,
                        fields,
                        w2,
                        rates,
                    )
                else:
                    r = _load_tile(a, gather, run_start, run_offset, run_base, r, n0, cnt, f)
                    if multi:
                        _apply_mr_links(
                            f,
                            a,
                            n0,
                            cnt,
                            n_nodes,
                            tile_start,
                            link_slot,
                            link_b,
                            link_c,
                            link_mr,
                            link_state,
                            g,
                            j,
                        )
                    elif link_slot.size:
                        _apply_links(f, a, n0, n_nodes, tile_start, link_slot, link_b, link_c)
                    if keep:
                        _fields_tile(scratch, _ZERO, cnt, n0, force_lo, force_hi, b3, fields)
                    _collide(
                        literally(op), scratch, _ZERO, _lanes(cnt), n0, force_lo, force_hi, b3, w2, rates
                    )
                _store_tile(b, n0, cnt, n_nodes, f, mode)
                if aa and aa_links:
                    _aa_links_own(a, n0, n_nodes, tile_start, link_slot, link_aa, True, own)
                n0 += cnt
            if mode != STORE_CACHED:
                _store_fence()


#: where ``streaming`` sits among :func:`step`'s ``args`` (the step kernel's arguments after ``op`` and ``with_aa``)
_STREAMING_ARG = tuple(inspect.signature(_step.py_func).parameters).index("streaming") - 2


def step(op, with_aa, *args):
    """Run :func:`_step` for operator ``op`` (BGK, TRT, MRT) on ``args`` (its other arguments, in order), in the
    variant that can stream in place if ``with_aa`` (bool; the variant without it does not compile the in-place code
    and refuses ``IN_PLACE``).

    Calls the compiled kernel of the literal ``op`` directly: numba's dispatcher matches a plain int against no
    compiled signature (they all hold ``Literal[int](op)``), so each call from Python retyped the whole step kernel
    until ``literally`` asked for the literal, ~45 ms a call (an 8³ lattice steps in 0.02 ms). The first call of
    each variant in a process compiles or loads the literal signature itself (``Dispatcher.compile``): through the
    dispatcher it typed the whole kernel once more before ``literally`` asked (0.26–0.29 CPU-s on a warm cache).
    """
    with_aa = bool(with_aa)
    if args[_STREAMING_ARG] == IN_PLACE and not with_aa:
        raise ValueError("step: streaming IN_PLACE needs the kernel variant compiled with_aa")
    kernel = _step.pick(*args)
    signature = (types.literal(op), types.literal(with_aa), *(typeof(a) for a in args))
    compiled = kernel.overloads.get(signature)
    if compiled is None:  # load from the disk cache or compile, for the literals at once (no retyping first)
        kernel.compile(signature)
        compiled = kernel.overloads[signature]
    compiled.entry_point(op, with_aa, *args)


# -- reductions ---------------------------------------------------------------------------------------------------------
@by_threads(_SERIAL_MAX, cache=True)
def _finite_and_max_speed2(fields):
    """(all finite?, max |u|²) over the nodes of a (4, N) field array."""
    n = fields.shape[1]
    bad = 0
    vmax = 0.0
    for i in prange(n):
        u2 = fields[1, i] * fields[1, i] + fields[2, i] * fields[2, i] + fields[3, i] * fields[3, i]
        s = u2 + fields[0, i]
        if not np.isfinite(s):
            bad += 1
        else:
            vmax = max(vmax, u2)
    return bad == 0, vmax


@by_threads(_SERIAL_MAX, cache=True)
def _max_rel_change(new, old, floor):
    """max_n |new − old| / max(|new|, floor) (thesis Eq. 6.1.30 with a floor against division by ~0)."""
    best = 0.0
    for i in prange(new.size):
        den = max(abs(new[i]), floor)
        best = max(best, abs(new[i] - old[i]) / den)
    return best
