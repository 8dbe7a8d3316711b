"""Numba kernels of the sparse D3Q19 solver: neighbour table, fused stream-collide steps, reductions.

Populations are stored zero-centred, f̃_i = f_i − w_i (ρ° = 1), in a flat array ``src[q * n + node]``
(structure of arrays) of float64 or float32; arithmetic is always float64. Streaming is a two-array pull:
node ``n`` gathers ``src[gather[q - 1, n]]``, where the gather index already encodes halfway bounce-back
(the index of the node's own opposite population when the upstream node is solid), so the hot loop has no
branch. Runs of nodes whose 18 sources all advance with the node (the open interior of the pore space, nearly the
whole of a dense box) stream by a constant offset per population instead: contiguous copies, no index traffic.
Each collision operator has its own step kernel; they share the gather/moment/store helpers.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.core import cgutils
from numba.extending import intrinsic

from porepipe._shared.numba_config import FASTMATH
from porepipe.lbm._lattice import OPPOSITE, C, W, dhumieres_matrix

_CX = C[:, 0].astype(np.float64)
_CY = C[:, 1].astype(np.float64)
_CZ = C[:, 2].astype(np.float64)
_W = W.copy()
_OPP = OPPOSITE.copy()
_M = dhumieres_matrix()
_M_NORM2 = (_M * _M).sum(axis=1)
#: nodes per work block of the parallel loop (scratch of 19 x _BLOCK float64 stays in L1/L2).
_BLOCK = 1024
#: population arrays larger than this (bytes, both buffers) are written with non-temporal stores: they cannot stay
#: in cache until the next step reads them, and bypassing the cache saves the read-for-ownership of every line.
STREAMING_BYTES = 16 * 2**20


def streams(src) -> bool:
    """Whether the step kernels should write ``src``'s populations (and its twin's) non-temporally."""
    return 2 * src.nbytes > STREAMING_BYTES


# -- non-temporal stores ------------------------------------------------------------------------------------------
@intrinsic
def _stream_store(typingctx, arr, idx, val):
    """``arr[idx] = val`` as a non-temporal store (no negative-index wrap; idx must be in range)."""
    sig = types.void(arr, idx, val)

    def codegen(context, builder, signature, args):
        arrty = signature.args[0]
        ary = context.make_array(arrty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, arrty, ary, [args[1]], wraparound=False)
        value = context.cast(builder, args[2], signature.args[2], arrty.dtype)
        store = builder.store(value, ptr)
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


@njit(cache=True, parallel=True)
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
def _runs(gather, min_run, start_out, offset_out):
    """Split the nodes into runs whose 18 pull sources all advance with the node (storage-order streaming).

    Within a run ``[start_out[r], start_out[r + 1])`` population q of node n comes from
    ``offset_out[r, q - 1] + n`` (a wall link pulls the node's own opposite population, which advances too), so
    the gather needs no index. Runs shorter than ``min_run`` are merged into irregular runs (offset −1: use the
    gather table). Returns the number of runs.
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
        if not regular and n_runs > 0 and offset_out[n_runs - 1, 0] < 0:
            n = m  # extends the previous irregular run
            continue
        start_out[n_runs] = n
        for q in range(18):
            offset_out[n_runs, q] = np.int64(gather[q, n]) - n if regular else -1
        n_runs += 1
        n = m
    start_out[n_runs] = n_nodes
    return n_runs


# -- block helpers: a block of up to _BLOCK nodes is processed population by population, so every inner loop
#    runs over contiguous nodes and vectorises; scratch arrays are allocated once per block of the prange.
@njit(cache=True, fastmath=FASTMATH)
def _gather_block(src, gather, run_start, run_offset, n0, cnt, fb):
    """Pull the populations arriving at nodes n0 … n0+cnt-1 into ``fb`` (19, _BLOCK) float64.

    Regular runs copy contiguous slices (no index traffic); irregular runs go through the gather table.
    """
    rest = src[n0:n0 + cnt]
    for i in range(cnt):
        fb[0, i] = rest[i]
    end = n0 + cnt
    r = np.searchsorted(run_start, n0, side="right") - 1
    while run_start[r] < end:
        a = max(run_start[r], n0)
        b = min(run_start[r + 1], end)
        # views with zero-based loop indices: numba's negative-index test folds away and the copies vectorise
        for q in range(1, 19):
            out = fb[q, a - n0:b - n0]
            if run_offset[r, 0] < 0:
                row = gather[q - 1, a:b]
                for i in range(b - a):
                    out[i] = src[row[i]]
            else:
                off = run_offset[r, q - 1]
                seg = src[off + a:off + b]
                for i in range(b - a):
                    out[i] = seg[i]
        r += 1


@njit(cache=True, fastmath=FASTMATH)
def _moments_block(fb, cnt, n0, force_lo, force_hi, mom):
    """Per node: mom = (δρ, j_x, j_y, j_z, ρ, 1/ρ, j², force on/off) of the gathered populations."""
    for i in range(cnt):
        mom[0, i] = 0.0
        mom[1, i] = 0.0
        mom[2, i] = 0.0
        mom[3, i] = 0.0
    for q in range(19):
        cx, cy, cz = _CX[q], _CY[q], _CZ[q]
        for i in range(cnt):
            v = fb[q, i]
            mom[0, i] += v
            mom[1, i] += cx * v
            mom[2, i] += cy * v
            mom[3, i] += cz * v
    for i in range(cnt):
        rho = 1.0 + mom[0, i]
        mom[4, i] = rho
        mom[5, i] = 1.0 / rho
        mom[6, i] = mom[1, i] * mom[1, i] + mom[2, i] * mom[2, i] + mom[3, i] * mom[3, i]
        n = n0 + i
        mom[7, i] = 1.0 * ((n >= force_lo) & (n < force_hi))


@njit(cache=True, fastmath=FASTMATH)
def _feq(q, i, mom):
    """Zero-centred equilibrium f̃^eq_q = w_q [δρ + 3 c·j + (9/2 (c·j)² − 3/2 j²)/ρ] (thesis Eq. 6.1.11)."""
    cj = _CX[q] * mom[1, i] + _CY[q] * mom[2, i] + _CZ[q] * mom[3, i]
    return _W[q] * (mom[0, i] + 3.0 * cj + (4.5 * cj * cj - 1.5 * mom[6, i]) * mom[5, i])


@njit(cache=True, fastmath=FASTMATH)
def _force_coefficient(q, force):
    """3 w_q (b·c_q): the body-force source is φ_q = this × ρ (thesis Eq. 6.1.20, h0 = h2 = 0)."""
    return 3.0 * _W[q] * (_CX[q] * force[0] + _CY[q] * force[1] + _CZ[q] * force[2])


@njit(cache=True, fastmath=FASTMATH)
def _store_block(dst, n0, cnt, n_nodes, fb, mom, fields, store, force, streaming):
    """Write the post-collision populations (non-temporal if ``streaming``); optionally δρ and u = (j + ρb/2)/ρ."""
    for q in range(19):
        out = dst[q * n_nodes + n0:q * n_nodes + n0 + cnt]  # a view: zero-based index, the copy vectorises
        if streaming:  # a pure copy loop: non-temporal stores would keep a compute loop from vectorising
            for i in range(cnt):
                _stream_store(out, i, fb[q, i])
        else:
            for i in range(cnt):
                out[i] = fb[q, i]
    if streaming:
        _store_fence()
    if store:
        for i in range(cnt):
            on = 0.5 * mom[7, i]
            fields[0, n0 + i] = mom[0, i]
            fields[1, n0 + i] = mom[1, i] * mom[5, i] + on * force[0]
            fields[2, n0 + i] = mom[2, i] * mom[5, i] + on * force[1]
            fields[3, n0 + i] = mom[3, i] * mom[5, i] + on * force[2]


# -- collision operators on a block (in place on the float64 scratch fb) -------------------------------------------
@njit(cache=True, fastmath=FASTMATH)
def _collide_bgk(fb, cnt, mom, force, omega):
    for q in range(19):
        fq = _force_coefficient(q, force)
        for i in range(cnt):
            fb[q, i] += omega * (_feq(q, i, mom) - fb[q, i]) + fq * mom[4, i] * mom[7, i]


@njit(cache=True, fastmath=FASTMATH)
def _collide_trt(fb, cnt, mom, force, omega_plus, omega_minus):
    for i in range(cnt):
        fb[0, i] += omega_plus * (_feq(0, i, mom) - fb[0, i])
    half_p = 0.5 * omega_plus
    half_m = 0.5 * omega_minus
    for p in range(1, 19, 2):
        r = p + 1
        fp = _force_coefficient(p, force)
        fr = _force_coefficient(r, force)
        for i in range(cnt):
            e_p = _feq(p, i, mom)
            e_r = _feq(r, i, mom)
            sym = half_p * (e_p + e_r - fb[p, i] - fb[r, i])
            anti = half_m * (e_p - e_r - fb[p, i] + fb[r, i])
            rho_on = mom[4, i] * mom[7, i]
            fb[p, i] += sym + anti + fp * rho_on
            fb[r, i] += sym - anti + fr * rho_on


@njit(cache=True, fastmath=FASTMATH)
def _collide_mrt(fb, cnt, mom, force, rates_scaled, mb):
    """d'Humières MRT: f ← f − M⁻¹ Š M (f − f^eq) + φ, with M⁻¹ = Mᵀ diag(1/|M_k|²) (rows orthogonal).

    ``rates_scaled[k] = s_k / |M_k|²``; ``mb`` (19, _BLOCK) is scratch for the moments.
    """
    for q in range(19):
        for i in range(cnt):
            fb[q, i] -= _feq(q, i, mom)
    for k in range(19):
        for i in range(cnt):
            mb[k, i] = 0.0
        if rates_scaled[k] == 0.0:
            continue
        for q in range(19):
            mkq = _M[k, q]
            if mkq == 0.0:
                continue
            for i in range(cnt):
                mb[k, i] += mkq * fb[q, i]
        s = rates_scaled[k]
        for i in range(cnt):
            mb[k, i] *= s
    for q in range(19):
        fq = _force_coefficient(q, force)
        for k in range(19):
            mkq = _M[k, q]
            if mkq == 0.0 or rates_scaled[k] == 0.0:
                continue
            for i in range(cnt):
                fb[q, i] -= mkq * mb[k, i]
        for i in range(cnt):
            fb[q, i] += _feq(q, i, mom) + fq * mom[4, i] * mom[7, i]


# -- step kernels: one per operator ---------------------------------------------------------------------------------
@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _step_bgk(src, dst, gather, run_start, run_offset, force_lo, force_hi, force, fields, store,
              n_steps, streaming, omega):
    """``n_steps`` BGK steps, alternating src -> dst -> src; fields of the last step if ``store``.

    ``streaming``: write the populations with non-temporal stores (see :data:`STREAMING_BYTES`).
    """
    n_nodes = gather.shape[1]
    n_blocks = (n_nodes + _BLOCK - 1) // _BLOCK
    for s in range(n_steps):
        a, b = (src, dst) if s % 2 == 0 else (dst, src)
        keep = store and s == n_steps - 1
        for blk in prange(n_blocks):
            fb = np.empty((19, _BLOCK))
            mom = np.empty((8, _BLOCK))
            n0 = blk * _BLOCK
            cnt = min(n_nodes, n0 + _BLOCK) - n0
            _gather_block(a, gather, run_start, run_offset, n0, cnt, fb)
            _moments_block(fb, cnt, n0, force_lo, force_hi, mom)
            _collide_bgk(fb, cnt, mom, force, omega)
            _store_block(b, n0, cnt, n_nodes, fb, mom, fields, keep, force, streaming)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _step_trt(src, dst, gather, run_start, run_offset, force_lo, force_hi, force, fields, store,
              n_steps, streaming, omega_plus, omega_minus):
    """``n_steps`` TRT steps (see :func:`_step_bgk`)."""
    n_nodes = gather.shape[1]
    n_blocks = (n_nodes + _BLOCK - 1) // _BLOCK
    for s in range(n_steps):
        a, b = (src, dst) if s % 2 == 0 else (dst, src)
        keep = store and s == n_steps - 1
        for blk in prange(n_blocks):
            fb = np.empty((19, _BLOCK))
            mom = np.empty((8, _BLOCK))
            n0 = blk * _BLOCK
            cnt = min(n_nodes, n0 + _BLOCK) - n0
            _gather_block(a, gather, run_start, run_offset, n0, cnt, fb)
            _moments_block(fb, cnt, n0, force_lo, force_hi, mom)
            _collide_trt(fb, cnt, mom, force, omega_plus, omega_minus)
            _store_block(b, n0, cnt, n_nodes, fb, mom, fields, keep, force, streaming)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _step_mrt(src, dst, gather, run_start, run_offset, force_lo, force_hi, force, fields, store,
              n_steps, streaming, rates_scaled):
    """``n_steps`` MRT steps (see :func:`_step_bgk`)."""
    n_nodes = gather.shape[1]
    n_blocks = (n_nodes + _BLOCK - 1) // _BLOCK
    for s in range(n_steps):
        a, b = (src, dst) if s % 2 == 0 else (dst, src)
        keep = store and s == n_steps - 1
        for blk in prange(n_blocks):
            fb = np.empty((19, _BLOCK))
            mom = np.empty((8, _BLOCK))
            mb = np.empty((19, _BLOCK))
            n0 = blk * _BLOCK
            cnt = min(n_nodes, n0 + _BLOCK) - n0
            _gather_block(a, gather, run_start, run_offset, n0, cnt, fb)
            _moments_block(fb, cnt, n0, force_lo, force_hi, mom)
            _collide_mrt(fb, cnt, mom, force, rates_scaled, mb)
            _store_block(b, n0, cnt, n_nodes, fb, mom, fields, keep, force, streaming)


# -- reductions ---------------------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True)
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


@njit(cache=True, parallel=True)
def _max_rel_change(new, old, floor):
    """max_n |new − old| / max(|new|, floor) (thesis Eq. 6.1.30 with a floor against division by ~0)."""
    best = 0.0
    for i in prange(new.size):
        den = max(abs(new[i]), floor)
        best = max(best, abs(new[i] - old[i]) / den)
    return best
