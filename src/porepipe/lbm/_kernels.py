"""Numba kernels of the sparse D3Q19 solver: neighbour table, fused stream-collide steps, reductions.

Populations are stored zero-centred, f̃_i = f_i − w_i (ρ° = 1), in a flat array ``src[q * n + node]``
(structure of arrays) of float64 or float32; arithmetic is always float64. Streaming is a two-array pull:
node ``n`` gathers ``src[gather[q - 1, n]]``, where the gather index already encodes halfway bounce-back
(the index of the node's own opposite population when the upstream node is solid), so the hot loop has no
branch. Each collision operator has its own step kernel; they share the gather/moment/store helpers.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH
from porepipe.lbm._lattice import C, OPPOSITE, W, dhumieres_matrix

_CX = C[:, 0].astype(np.float64)
_CY = C[:, 1].astype(np.float64)
_CZ = C[:, 2].astype(np.float64)
_W = W.copy()
_OPP = OPPOSITE.copy()
_M = dhumieres_matrix()
_M_NORM2 = (_M * _M).sum(axis=1)
#: nodes per work block of the parallel loop (one scratch buffer per block).
_BLOCK = 2048


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


# -- per-node helpers ---------------------------------------------------------------------------------------------------
@njit(cache=True, fastmath=FASTMATH)
def _load(src, gather, n, n_nodes, f):
    """Pull the 19 populations arriving at node ``n`` into ``f`` (float64)."""
    f[0] = src[n]
    for q in range(1, 19):
        f[q] = src[gather[q - 1, n]]


@njit(cache=True, fastmath=FASTMATH)
def _moments(f):
    """Density deviation δρ = Σ f̃ and momentum j = Σ f̃ c of one node."""
    d = 0.0
    jx = 0.0
    jy = 0.0
    jz = 0.0
    for q in range(19):
        d += f[q]
        jx += f[q] * _CX[q]
        jy += f[q] * _CY[q]
        jz += f[q] * _CZ[q]
    return d, jx, jy, jz


@njit(cache=True, fastmath=FASTMATH)
def _equilibrium(q, d, jx, jy, jz, inv_rho, jj):
    """Zero-centred equilibrium f̃^eq_q = w_q [δρ + 3 c·j + 9/2 (c·j)²/ρ − 3/2 j²/ρ] (thesis Eq. 6.1.11)."""
    cj = _CX[q] * jx + _CY[q] * jy + _CZ[q] * jz
    return _W[q] * (d + 3.0 * cj + (4.5 * cj * cj - 1.5 * jj) * inv_rho)


@njit(cache=True, fastmath=FASTMATH)
def _force_term(q, rho, bx, by, bz):
    """Body-force source φ_q = 3 w_q ρ (b·c_q) (thesis Eq. 6.1.20, h0 = h2 = 0)."""
    return 3.0 * _W[q] * rho * (_CX[q] * bx + _CY[q] * by + _CZ[q] * bz)


@njit(cache=True, fastmath=FASTMATH)
def _store(dst, n, n_nodes, f, fields, store, d, jx, jy, jz, bx, by, bz):
    """Write the post-collision populations; optionally δρ and the velocity u = (j + ρb/2)/ρ."""
    for q in range(19):
        dst[q * n_nodes + n] = f[q]
    if store:
        rho = 1.0 + d
        fields[0, n] = d
        fields[1, n] = jx / rho + 0.5 * bx
        fields[2, n] = jy / rho + 0.5 * by
        fields[3, n] = jz / rho + 0.5 * bz


# -- collision operators (in place on the float64 scratch f) -------------------------------------------------------
@njit(cache=True, fastmath=FASTMATH)
def _collide_bgk(f, d, jx, jy, jz, bx, by, bz, omega):
    rho = 1.0 + d
    inv_rho = 1.0 / rho
    jj = jx * jx + jy * jy + jz * jz
    for q in range(19):
        feq = _equilibrium(q, d, jx, jy, jz, inv_rho, jj)
        f[q] += omega * (feq - f[q]) + _force_term(q, rho, bx, by, bz)


@njit(cache=True, fastmath=FASTMATH)
def _collide_trt(f, d, jx, jy, jz, bx, by, bz, omega_plus, omega_minus):
    rho = 1.0 + d
    inv_rho = 1.0 / rho
    jj = jx * jx + jy * jy + jz * jz
    f[0] += omega_plus * (_equilibrium(0, d, jx, jy, jz, inv_rho, jj) - f[0])
    for p in range(1, 19, 2):
        r = p + 1
        e_p = _equilibrium(p, d, jx, jy, jz, inv_rho, jj)
        e_r = _equilibrium(r, d, jx, jy, jz, inv_rho, jj)
        sym = 0.5 * omega_plus * (e_p + e_r - f[p] - f[r])
        anti = 0.5 * omega_minus * (e_p - e_r - f[p] + f[r])
        f[p] += sym + anti + _force_term(p, rho, bx, by, bz)
        f[r] += sym - anti + _force_term(r, rho, bx, by, bz)


@njit(cache=True, fastmath=FASTMATH)
def _collide_mrt(f, d, jx, jy, jz, bx, by, bz, rates_scaled, m):
    """d'Humières MRT: f ← f − M⁻¹ Š M (f − f^eq) + φ, with M⁻¹ = Mᵀ diag(1/|M_k|²) (rows orthogonal).

    ``rates_scaled[k] = s_k / |M_k|²``; ``m`` is a 19-element scratch for the moments.
    """
    rho = 1.0 + d
    inv_rho = 1.0 / rho
    jj = jx * jx + jy * jy + jz * jz
    for q in range(19):
        f[q] -= _equilibrium(q, d, jx, jy, jz, inv_rho, jj)
    for k in range(19):
        acc = 0.0
        for q in range(19):
            acc += _M[k, q] * f[q]
        m[k] = acc * rates_scaled[k]
    for q in range(19):
        acc = 0.0
        for k in range(19):
            acc += _M[k, q] * m[k]
        f[q] += _equilibrium(q, d, jx, jy, jz, inv_rho, jj) - acc + _force_term(q, rho, bx, by, bz)


# -- step kernels: one per operator ---------------------------------------------------------------------------------
@njit(cache=True, fastmath=FASTMATH)
def _node_force(n, force_lo, force_hi, force):
    """Body force of node ``n``: ``force`` inside the node range [force_lo, force_hi), else zero (no branch)."""
    on = 1.0 * ((n >= force_lo) & (n < force_hi))
    return on * force[0], on * force[1], on * force[2]


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _step_bgk(src, dst, gather, force_lo, force_hi, force, fields, store, n_steps, omega):
    """``n_steps`` BGK steps, alternating src -> dst -> src; fields of the last step if ``store``."""
    n_nodes = gather.shape[1]
    n_blocks = (n_nodes + _BLOCK - 1) // _BLOCK
    for s in range(n_steps):
        a, b = (src, dst) if s % 2 == 0 else (dst, src)
        keep = store and s == n_steps - 1
        for blk in prange(n_blocks):
            f = np.empty(19)
            for n in range(blk * _BLOCK, min(n_nodes, (blk + 1) * _BLOCK)):
                _load(a, gather, n, n_nodes, f)
                d, jx, jy, jz = _moments(f)
                bx, by, bz = _node_force(n, force_lo, force_hi, force)
                _collide_bgk(f, d, jx, jy, jz, bx, by, bz, omega)
                _store(b, n, n_nodes, f, fields, keep, d, jx, jy, jz, bx, by, bz)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _step_trt(src, dst, gather, force_lo, force_hi, force, fields, store, n_steps, omega_plus, omega_minus):
    """``n_steps`` TRT steps (see :func:`_step_bgk`)."""
    n_nodes = gather.shape[1]
    n_blocks = (n_nodes + _BLOCK - 1) // _BLOCK
    for s in range(n_steps):
        a, b = (src, dst) if s % 2 == 0 else (dst, src)
        keep = store and s == n_steps - 1
        for blk in prange(n_blocks):
            f = np.empty(19)
            for n in range(blk * _BLOCK, min(n_nodes, (blk + 1) * _BLOCK)):
                _load(a, gather, n, n_nodes, f)
                d, jx, jy, jz = _moments(f)
                bx, by, bz = _node_force(n, force_lo, force_hi, force)
                _collide_trt(f, d, jx, jy, jz, bx, by, bz, omega_plus, omega_minus)
                _store(b, n, n_nodes, f, fields, keep, d, jx, jy, jz, bx, by, bz)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _step_mrt(src, dst, gather, force_lo, force_hi, force, fields, store, n_steps, rates_scaled):
    """``n_steps`` MRT steps (see :func:`_step_bgk`)."""
    n_nodes = gather.shape[1]
    n_blocks = (n_nodes + _BLOCK - 1) // _BLOCK
    for s in range(n_steps):
        a, b = (src, dst) if s % 2 == 0 else (dst, src)
        keep = store and s == n_steps - 1
        for blk in prange(n_blocks):
            f = np.empty(19)
            m = np.empty(19)
            for n in range(blk * _BLOCK, min(n_nodes, (blk + 1) * _BLOCK)):
                _load(a, gather, n, n_nodes, f)
                d, jx, jy, jz = _moments(f)
                bx, by, bz = _node_force(n, force_lo, force_hi, force)
                _collide_mrt(f, d, jx, jy, jz, bx, by, bz, rates_scaled, m)
                _store(b, n, n_nodes, f, fields, keep, d, jx, jy, jz, bx, by, bz)


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
