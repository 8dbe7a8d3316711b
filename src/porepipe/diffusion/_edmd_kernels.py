"""Numba kernels of the event-driven hard-sphere gas (Mahler 2001 §3.3-3.5, with the event calendar §7.4 asks for).

Particles are hard spheres against each other and points against the walls (thesis §2.1.5). Space is a grid of cubic
cells of edge ``h`` (the voxels, or sub-voxels of them), each pore (1) or solid (0); the outside of the grid is solid
except across periodic axes. Every particle carries its own clock ``tp[i]``: its position is stored at that time and
moved only when the particle takes part in an event, so one event costs O(log N) and not the thesis's O(N).

Events: each particle keeps two predictions, its next cell crossing ``tcross[i]`` and at most one pair collision
``tpair[i]`` with ``partner[i]`` (held by both partners, same time); the calendar is a tournament tree over the
particles keyed by min(tcross, tpair), O(log N) per change, no stale entries (the single-event scheme of
Lubachevsky 1991 and Donev, Torquato & Stillinger, J. Comput. Phys. 202, 737 (2005), with the cell crossing kept
apart so that a crossing keeps the pair event):

- pair collision (i, j): predicted exactly, one root test (spec §4.5: the thesis's two tests are one condition),
  against the 27 neighbour cells after a velocity change and against the 9 newly adjacent cells after a crossing
  (a pair that collides is adjacent then, and it became so at a velocity change or a crossing of one partner). A
  prediction is kept only when earlier than both partners' pair events; a particle whose partner takes another
  event, or changes velocity at a wall, is re-predicted over its 27 cells at once (counted as ``E_STALE``). Thus
  for every adjacent pair one of the two holds an event no later than the pair's own collision;
- cell crossing: the particle reaches a face of its cell; the next cell is pore (move the particle between
  the cell lists), solid or the closed outside (a wall hit: exact, no wall can be missed), or wraps periodically.

Simultaneous events run in particle order (the tree's left leaf wins a tie); a crossing runs before a pair collision
of the same particle at the same instant.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH as K_FASTMATH
from porepipe._shared.numba_config import NO_REFCOUNT
from porepipe.diffusion._kernels import (
    EXIT_HIGH,
    EXIT_LOW,
    _emit,
    _fly,
    _profile_add,
    _reflect,
    _speed,
    _stream_state,
    _uniform,
    _uniform_in_pore,
)

#: compile options of the event loop's helpers: no reference counting (with it, one pair scan paid 36 atomic
#: operations; see NO_REFCOUNT)
_BORROW = {"cache": True, **NO_REFCOUNT}

#: columns of the event tally (E_STALE: re-predictions of particles whose pair event was taken by another pair or
#: voided by the partner's wall hit; the key stays for the reports' ``stale_events``)
E_EVENTS, E_PAIRS, E_WALLS, E_CROSSINGS, E_STALE, E_REACTIONS = range(6)
N_ETALLY = 6


# ---------------------------------------------------------------------------------------------------------------------
# binary heap of events with lazy invalidation (the calendar of the adsorbing gas, _surface_kernels): time, i, j
# (-1 = no partner), counters of i and j at prediction time
@njit(**_BORROW)
def _heap_push(ht, hi, hj, hci, hcj, n, t, i, j, ci, cj):
    """Push one event; returns the new size (the caller guarantees room)."""
    k = n
    while k > 0:
        parent = (k - 1) >> 1
        if ht[parent] <= t:
            break
        ht[k], hi[k], hj[k], hci[k], hcj[k] = ht[parent], hi[parent], hj[parent], hci[parent], hcj[parent]
        k = parent
    ht[k], hi[k], hj[k], hci[k], hcj[k] = t, i, j, ci, cj
    return n + 1


@njit(**_BORROW)
def _heap_pop(ht, hi, hj, hci, hcj, n):
    """Remove the root (the earliest event); returns the new size."""
    n -= 1
    if n > 0:
        _sift_down(ht, hi, hj, hci, hcj, 0, n, ht[n], hi[n], hj[n], hci[n], hcj[n])
    return n


@njit(inline="always", **_BORROW)
def _sift_down(ht, hi, hj, hci, hcj, k, n, t, i, j, ci, cj):
    """Put the event (t, i, j, ci, cj) into the hole at ``k`` of a heap of size ``n``, below its earlier children."""
    while True:
        c = 2 * k + 1
        if c >= n:
            break
        if c + 1 < n and ht[c + 1] < ht[c]:
            c += 1
        if ht[c] >= t:
            break
        ht[k], hi[k], hj[k], hci[k], hcj[k] = ht[c], hi[c], hj[c], hci[c], hcj[c]
        k = c
    ht[k], hi[k], hj[k], hci[k], hcj[k] = t, i, j, ci, cj


@njit(cache=True)
def _heap_room(ht, hi, hj, hci, hcj, n, need, cnt):
    """Make room for ``need`` more events: drop stale ones (and re-heapify), grow the arrays if still short."""
    if n + need <= ht.shape[0]:
        return ht, hi, hj, hci, hcj, n
    m = 0
    for k in range(n):
        ok = hci[k] == cnt[hi[k]] and (hj[k] < 0 or hcj[k] == cnt[hj[k]])
        if ok:
            ht[m], hi[m], hj[m], hci[m], hcj[m] = ht[k], hi[k], hj[k], hci[k], hcj[k]
            m += 1
    cap = ht.shape[0]
    if m + need > cap // 2:
        cap = 2 * (m + need) + 1024
        ht2, hi2, hj2 = np.empty(cap), np.empty(cap, np.int64), np.empty(cap, np.int64)
        hci2, hcj2 = np.empty(cap, np.int64), np.empty(cap, np.int64)
        for k in range(m):  # element by element: a slice copy compiles its shape-error message (~4 CPU-s)
            ht2[k], hi2[k], hj2[k], hci2[k], hcj2[k] = ht[k], hi[k], hj[k], hci[k], hcj[k]
        ht, hi, hj, hci, hcj = ht2, hi2, hj2, hci2, hcj2
    # re-heapify the kept events (Floyd)
    for k in range((m - 2) // 2, -1, -1):
        _sift_down(ht, hi, hj, hci, hcj, k, m, ht[k], hi[k], hj[k], hci[k], hcj[k])
    return ht, hi, hj, hci, hcj, m


# ---------------------------------------------------------------------------------------------------------------------
# event calendar: one entry per particle, key = min(next crossing, next pair collision), in a tournament tree
@njit(cache=True)
def _tree_new(n_part):
    """Tournament tree over ``n_part`` leaves, all keys inf: (key per node, winning particle per node, leaf offset)."""
    m = 1
    while m < max(n_part, 1):
        m *= 2
    tt = np.full(2 * m, np.inf)
    ti = np.full(2 * m, -1, dtype=np.int64)
    for i in range(n_part):
        ti[m + i] = i
    for k in range(m - 1, 0, -1):
        ti[k] = ti[2 * k]
    return tt, ti, m


@njit(**_BORROW)
def _tree_set(tt, ti, m, i, t):
    """Leaf i gets key ``t``; the matches on its path to the root are replayed (O(log N)). Ties: the left leaf wins,
    so equal times run in particle order.
    """
    k = m + i
    tt[k] = t
    while k > 1:
        left = k & ~1
        w = left + 1 if tt[left + 1] < tt[left] else left
        k >>= 1
        if tt[k] == tt[w] and ti[k] == ti[w]:
            return  # this match and all above it are unchanged
        tt[k], ti[k] = tt[w], ti[w]


@njit(cache=True, inline="always")
def _rekey(sched, i):
    tt, ti, m, tcross, tpair = sched[0], sched[1], sched[2], sched[3], sched[4]
    _tree_set(tt, ti, m, i, min(tcross[i], tpair[i]))


@njit(**_BORROW)
def _drop(sched, q):
    """Particle q loses its pair event (its partner took another): no pair until its re-prediction from the stack."""
    tpair, partner, stack, top, mark = sched[4], sched[5], sched[6], sched[7], sched[8]
    partner[q] = -1
    tpair[q] = np.inf
    _rekey(sched, q)
    if mark[q] == 0:
        mark[q] = 1
        stack[top[0]] = q
        top[0] += 1


@njit(**_BORROW)
def _claim(sched, a, b, t):
    """Make (a, b) a's pair event at time ``t``; a's previous partner, if another one, is dropped."""
    tpair, partner = sched[4], sched[5]
    q = partner[a]
    if q >= 0 and q != b:
        _drop(sched, q)
    partner[a] = b
    tpair[a] = t
    _rekey(sched, a)


@njit(**_BORROW)
def _forget(sched, i):
    """Particle i changed velocity: its pair event and its partner's are void (the partner is re-predicted)."""
    tpair, partner = sched[4], sched[5]
    q = partner[i]
    if q >= 0:
        _drop(sched, q)
    partner[i] = -1
    tpair[i] = np.inf


# ---------------------------------------------------------------------------------------------------------------------
# collision physics
@njit(cache=True, inline="always")
def pair_time(dx, dy, dz, dvx, dvy, dvz, sigma):
    """Time until two spheres at separation r = (dx, dy, dz) (i minus j) with relative velocity dv touch at distance
    ``sigma``; inf if they do not. One root test (3.17): approaching (r·v < 0) and (r·v)² − v²(r² − σ²) > 0.

    The smaller root in the cancellation-free form (r² − σ²)/(−r·v + √disc); a pair already overlapping by
    round-off (r² < σ²) while approaching collides now (time 0).
    """
    b = dx * dvx + dy * dvy + dz * dvz
    if b >= 0.0:
        return np.inf
    v2 = dvx * dvx + dvy * dvy + dvz * dvz
    r2 = dx * dx + dy * dy + dz * dz
    c = r2 - sigma * sigma
    disc = b * b - v2 * c
    if disc <= 0.0:
        return np.inf
    if c <= 0.0:
        return 0.0
    return c / (-b + math.sqrt(disc))


@njit(cache=True)
def collide(vel, i, j, nx, ny, nz, mi, mj):
    """Elastic collision of spheres i and j along the unit normal n = (r_i − r_j)/|r_i − r_j| (3.21-3.24).

    Only the normal components change: u_iⁿ' = Δ_ij u_iⁿ + Λ_j u_jⁿ, u_jⁿ' = −Δ_ij u_jⁿ + Λ_i u_iⁿ, written as an
    impulse J = 2 m_i m_j/(m_i + m_j)·(u_jⁿ − u_iⁿ) so that momentum is conserved to round-off.
    """
    uin = vel[i, 0] * nx + vel[i, 1] * ny + vel[i, 2] * nz
    ujn = vel[j, 0] * nx + vel[j, 1] * ny + vel[j, 2] * nz
    jimp = 2.0 * mi * mj / (mi + mj) * (ujn - uin)
    ai, aj = jimp / mi, jimp / mj
    vel[i, 0] += ai * nx
    vel[i, 1] += ai * ny
    vel[i, 2] += ai * nz
    vel[j, 0] -= aj * nx
    vel[j, 1] -= aj * ny
    vel[j, 2] -= aj * nz


# ---------------------------------------------------------------------------------------------------------------------
# cells
@njit(cache=True, inline="always")
def _flat(c0, c1, c2, n1, n2):
    return (c0 * n1 + c1) * n2 + c2


@njit(**_BORROW)
def _link(head, nxt, prv, cell, i, c):
    cell[i] = c
    prv[i] = -1
    nxt[i] = head[c]
    if head[c] >= 0:
        prv[head[c]] = i
    head[c] = i


@njit(**_BORROW)
def _unlink(head, nxt, prv, cell, i):
    c = cell[i]
    if prv[i] >= 0:
        nxt[prv[i]] = nxt[i]
    else:
        head[c] = nxt[i]
    if nxt[i] >= 0:
        prv[nxt[i]] = prv[i]


@njit(cache=True)
def build_cells(pos, h, shape, head, nxt, prv, cell, cidx):
    """Put every particle into the linked list of its cell (``cidx[i]`` = its 3 cell indices)."""
    head[:] = -1
    for i in range(pos.shape[0]):
        for d in range(3):
            cidx[i, d] = min(max(np.int64(math.floor(pos[i, d] / h)), 0), shape[d] - 1)
        _link(head, nxt, prv, cell, i, _flat(cidx[i, 0], cidx[i, 1], cidx[i, 2], shape[1], shape[2]))


@njit(cache=True, inline="always")
def _min_image(d, ext, per):
    if per:
        if d > 0.5 * ext:
            return d - ext
        if d < -0.5 * ext:
            return d + ext
    return d


@njit(cache=True)
def first_overlap(pos, sp, radius, h, shape, periodic, head, nxt, cidx):
    """(i, j) of the first pair of spheres closer than r_i + r_j, or (-1, -1)."""
    e0, e1, e2 = shape[0] * h, shape[1] * h, shape[2] * h
    for i in range(pos.shape[0]):
        for a in range(-1, 2):
            for b in range(-1, 2):
                for c in range(-1, 2):
                    k0, k1, k2 = cidx[i, 0] + a, cidx[i, 1] + b, cidx[i, 2] + c
                    if not _wrap_ok(k0, shape[0], periodic[0]):
                        continue
                    if not _wrap_ok(k1, shape[1], periodic[1]):
                        continue
                    if not _wrap_ok(k2, shape[2], periodic[2]):
                        continue
                    j = head[_flat(k0 % shape[0], k1 % shape[1], k2 % shape[2], shape[1], shape[2])]
                    while j >= 0:
                        if j > i:
                            dx = _min_image(pos[i, 0] - pos[j, 0], e0, periodic[0])
                            dy = _min_image(pos[i, 1] - pos[j, 1], e1, periodic[1])
                            dz = _min_image(pos[i, 2] - pos[j, 2], e2, periodic[2])
                            s = radius[sp[i]] + radius[sp[j]]
                            if dx * dx + dy * dy + dz * dz < s * s:
                                return i, j
                        j = nxt[j]
    return -1, -1


@njit(cache=True, inline="always")
def _wrap_ok(k, n, per):
    return per or (0 <= k < n)


@njit(cache=True, inline="always")
def _wrap(k, n, per):
    """Cell index k in [-1, n] wrapped on a periodic axis of n cells, -1 if outside a closed one."""
    if k < 0:
        return n - 1 if per else -1
    if k >= n:
        return 0 if per else -1
    return k


# ---------------------------------------------------------------------------------------------------------------------
# predictions
@njit(**_BORROW)
def _crossing(pos, vel, cidx, h, i, t):
    """(absolute time, axis, step) of particle i's next cell-face crossing; its position is synchronised at ``t``."""
    best = np.inf
    axis = -1
    step = 0
    for d in range(3):
        v = vel[i, d]
        if v > 0.0:
            dt = ((cidx[i, d] + 1) * h - pos[i, d]) / v
        elif v < 0.0:
            dt = (cidx[i, d] * h - pos[i, d]) / v
        else:
            continue
        dt = max(dt, 0.0)
        if dt < best:
            best = dt
            axis = d
            step = 1 if v > 0.0 else -1
    return t + best, axis, step


@njit(**_BORROW)
def _scan(gas, sched, i, t, layer, step):
    """Pair collisions of i with the particles of its 27 neighbour cells (``layer`` >= 0: only the 9 cells at offset
    ``step`` along axis ``layer``, the ones a crossing has just made neighbours). A collision at T is kept when it is
    earlier than both partners' pair events (T < tpair[i] and T < tpair[j]): it then becomes the pair event of both.
    A pair rejected here is safe: the earlier event of i or j comes first, and whoever loses a pair event is
    re-predicted over all 27 cells at once (:func:`_drop`).
    """
    pos, vel, tp, rad, h, shape, periodic, head, nxt, cidx = gas
    tpair = sched[4]
    e0, e1, e2 = shape[0] * h, shape[1] * h, shape[2] * h
    xi = pos[i, 0] + (t - tp[i]) * vel[i, 0]
    yi = pos[i, 1] + (t - tp[i]) * vel[i, 1]
    zi = pos[i, 2] + (t - tp[i]) * vel[i, 2]
    ri = rad[i]
    n0, n1, n2 = shape[0], shape[1], shape[2]
    # minimum image only where it can act: a periodic axis with i in a boundary cell (or fewer than 5 cells);
    # elsewhere |separation| < 2h < extent/2 and the image correction is the identity
    m0 = periodic[0] and (n0 < 5 or cidx[i, 0] == 0 or cidx[i, 0] == n0 - 1)
    m1 = periodic[1] and (n1 < 5 or cidx[i, 1] == 0 or cidx[i, 1] == n1 - 1)
    m2 = periodic[2] and (n2 < 5 or cidx[i, 2] == 0 or cidx[i, 2] == n2 - 1)
    a0, a1 = (step, step) if layer == 0 else (-1, 1)
    b0, b1 = (step, step) if layer == 1 else (-1, 1)
    c0, c1 = (step, step) if layer == 2 else (-1, 1)
    for a in range(a0, a1 + 1):
        k0 = _wrap(cidx[i, 0] + a, n0, periodic[0])
        if k0 < 0:
            continue
        for b in range(b0, b1 + 1):
            k1 = _wrap(cidx[i, 1] + b, n1, periodic[1])
            if k1 < 0:
                continue
            row = (k0 * n1 + k1) * n2
            for c in range(c0, c1 + 1):
                k2 = _wrap(cidx[i, 2] + c, n2, periodic[2])
                if k2 < 0:
                    continue
                j = head[row + k2]
                while j >= 0:
                    if j != i:
                        dtj = t - tp[j]
                        dx = _min_image(xi - pos[j, 0] - dtj * vel[j, 0], e0, m0)
                        dy = _min_image(yi - pos[j, 1] - dtj * vel[j, 1], e1, m1)
                        dz = _min_image(zi - pos[j, 2] - dtj * vel[j, 2], e2, m2)
                        dt = pair_time(
                            dx,
                            dy,
                            dz,
                            vel[i, 0] - vel[j, 0],
                            vel[i, 1] - vel[j, 1],
                            vel[i, 2] - vel[j, 2],
                            ri + rad[j],
                        )
                        tc = t + dt
                        if tc < tpair[i] and tc < tpair[j]:
                            _claim(sched, i, j, tc)
                            _claim(sched, j, i, tc)
                    j = nxt[j]


@njit(**_BORROW)
def _settle(gas, sched, t, tally):
    """Re-predict (all 27 cells) every particle that lost its pair event, until none is left."""
    stack, top, mark = sched[6], sched[7], sched[8]
    while top[0] > 0:
        top[0] -= 1
        q = stack[top[0]]
        mark[q] = 0
        tally[E_STALE] += 1
        _scan(gas, sched, q, t, -1, 0)


@njit(**_BORROW)
def _new_crossing(gas, sched, i, t):
    pos, vel, cidx, h = gas[0], gas[1], gas[9], gas[4]
    tcross, cdir = sched[3], sched[9]
    tc, d, s = _crossing(pos, vel, cidx, h, i, t)
    tcross[i] = tc
    cdir[i] = 2 * d + (1 if s > 0 else 0)
    _rekey(sched, i)


@njit(**_BORROW)
def _sync(pos, vel, tp, i, t):
    for d in range(3):
        pos[i, d] += (t - tp[i]) * vel[i, d]
    tp[i] = t


# ---------------------------------------------------------------------------------------------------------------------
@njit(cache=True)
def advance(
    pos,
    vel,
    img,
    sp,
    radius,
    mass,
    vmean,
    pore,
    h,
    periodic,
    t_start,
    t_stop,
    pairs,
    law,
    mixed,
    wall_speed,
    alpha,
    react_w,
    react_to,
    state,
    tally,
    pair_counts,
    wall_counts,
):
    """Run the gas from ``t_start`` to ``t_stop`` (all positions synchronised at both ends).

    Parameters
    ----------
    pos, vel : (N, 3) float
        Positions (inside pore cells of ``pore``) and velocities; updated in place.
    img : (N, 3) int64
        Periodic wraps per axis (unwrapped position = pos + img·extent); updated.
    sp : (N,) int64
        Species index per particle (changed by a wall reaction).
    radius, mass, vmean : (S,) float
        Per species: hard-sphere radius, mass (any unit), mean thermal speed (for a thermal wall).
    pore : (n0, n1, n2) uint8
        Cell grid, 1 = pore; cells are cubes of edge ``h``.
    periodic : (3,) bool
        Axes that wrap (need >= 3 cells).
    pairs : bool
        Gas-gas collisions on (off: independent point particles, the Knudsen regime).
    law, mixed, wall_speed, alpha
        Wall law as in :func:`porepipe.diffusion._kernels._reflect`.
    react_w : (S,) float
        Probability that a wall hit turns species s into ``react_to[s]`` (all 0 = no reaction).
    state : uint64
        Random stream state (diffuse walls, reactions); the new state is returned.
    tally : (N_ETALLY,) float
        Event counts (added to).
    pair_counts : (S, S) int64
        Pair collisions by species pair (added to; both orders).
    wall_counts : (S,) int64
        Wall hits by species (added to).
    """
    n_part = pos.shape[0]
    shape = np.array(pore.shape, dtype=np.int64)
    n1, n2 = shape[1], shape[2]
    ext = np.array([shape[0] * h, shape[1] * h, shape[2] * h])
    flat = pore.reshape(pore.size)
    head = np.empty(pore.size, dtype=np.int64)
    nxt = np.empty(n_part, dtype=np.int64)
    prv = np.empty(n_part, dtype=np.int64)
    cell = np.empty(n_part, dtype=np.int64)
    cidx = np.empty((n_part, 3), dtype=np.int64)
    tp = np.full(n_part, t_start)
    build_cells(pos, h, shape, head, nxt, prv, cell, cidx)
    rad = np.empty(n_part)  # radius per particle (one load less per candidate than radius[sp[j]])
    for i in range(n_part):
        rad[i] = radius[sp[i]]
    gas = (pos, vel, tp, rad, h, shape, periodic, head, nxt, cidx)
    tt, ti, m = _tree_new(n_part)
    sched = (
        tt,
        ti,
        m,
        np.full(n_part, np.inf),  # tcross: next cell-face crossing
        np.full(n_part, np.inf),  # tpair: pair event (the same time in both partners)
        np.full(n_part, -1, dtype=np.int64),  # partner (symmetric), -1 = none
        np.empty(n_part, dtype=np.int64),  # stack of particles to re-predict
        np.zeros(1, dtype=np.int64),  # its size
        np.zeros(n_part, dtype=np.uint8),  # on the stack
        np.zeros(n_part, dtype=np.int64),  # face of the next crossing: 2 axis + (1 if upward)
    )
    tcross, tpair, partner = sched[3], sched[4], sched[5]
    for i in range(n_part):
        _new_crossing(gas, sched, i, t_start)
    if pairs:
        for i in range(n_part):
            _scan(gas, sched, i, t_start, -1, 0)
    u = np.empty(3)
    react = False
    for s in range(react_w.shape[0]):
        react = react or react_w[s] > 0.0
    while True:
        t, i = tt[1], ti[1]
        if not t <= t_stop or t == np.inf:  # (inf: nothing moves any more)
            break
        tally[E_EVENTS] += 1
        if tpair[i] < tcross[i]:  # pair collision
            j = partner[i]
            _sync(pos, vel, tp, i, t)
            _sync(pos, vel, tp, j, t)
            dx = _min_image(pos[i, 0] - pos[j, 0], ext[0], periodic[0])
            dy = _min_image(pos[i, 1] - pos[j, 1], ext[1], periodic[1])
            dz = _min_image(pos[i, 2] - pos[j, 2], ext[2], periodic[2])
            r = math.sqrt(dx * dx + dy * dy + dz * dz)
            collide(vel, i, j, dx / r, dy / r, dz / r, mass[sp[i]], mass[sp[j]])
            tally[E_PAIRS] += 1
            pair_counts[sp[i], sp[j]] += 1
            pair_counts[sp[j], sp[i]] += 1
            for k in (i, j):  # partners of each other: no third particle loses its event
                partner[k] = -1
                tpair[k] = np.inf
            _new_crossing(gas, sched, i, t)
            _new_crossing(gas, sched, j, t)
            _scan(gas, sched, i, t, -1, 0)
            _scan(gas, sched, j, t, -1, 0)
            _settle(gas, sched, t, tally)
            continue
        # crossing of a face of i's cell
        _sync(pos, vel, tp, i, t)
        d = sched[9][i] >> 1
        s = 1 if sched[9][i] & 1 else -1
        k = cidx[i, d] + s
        face = (cidx[i, d] + (1 if s > 0 else 0)) * h
        wall = False
        wrapped = False
        if k < 0 or k >= shape[d]:
            if periodic[d]:
                k = k % shape[d]
                wrapped = True
            else:
                wall = True
        if not wall:
            c0 = k if d == 0 else cidx[i, 0]  # (scalars: a row view of cidx would cost a reference count)
            c1 = k if d == 1 else cidx[i, 1]
            c2 = k if d == 2 else cidx[i, 2]
            if flat[_flat(c0, c1, c2, n1, n2)] == 0:
                wall = True
        pos[i, d] = face
        if wall:
            speed = math.sqrt(vel[i, 0] ** 2 + vel[i, 1] ** 2 + vel[i, 2] ** 2)
            for q in range(3):
                u[q] = vel[i, q] / speed
            ev = 2 * d + (1 if s > 0 else 0)
            if react and react_w[sp[i]] > 0.0:
                x, state = _uniform(state)
                if x <= react_w[sp[i]]:
                    sp[i] = react_to[sp[i]]
                    rad[i] = radius[sp[i]]
                    tally[E_REACTIONS] += 1
            speed, state = _reflect(law, mixed, wall_speed, ev, u, speed, vmean[sp[i]], alpha, state)
            for q in range(3):
                vel[i, q] = u[q] * speed
            tally[E_WALLS] += 1
            wall_counts[sp[i]] += 1
            _forget(sched, i)
            _new_crossing(gas, sched, i, t)
            if pairs:
                _scan(gas, sched, i, t, -1, 0)
                _settle(gas, sched, t, tally)
            continue
        if wrapped:
            pos[i, d] -= s * ext[d]
            img[i, d] += s
        _unlink(head, nxt, prv, cell, i)
        cidx[i, d] = k
        _link(head, nxt, prv, cell, i, _flat(cidx[i, 0], cidx[i, 1], cidx[i, 2], n1, n2))
        tally[E_CROSSINGS] += 1
        _new_crossing(gas, sched, i, t)
        if pairs:
            _scan(gas, sched, i, t, d, s)
            _settle(gas, sched, t, tally)
    for i in range(n_part):
        _sync(pos, vel, tp, i, t_stop)
    return state


@njit(cache=True)
def insert_spheres(cells, h, shape, periodic, sp, radius, pos, state, tries):
    """Random sequential insertion: each particle uniform in a random pore cell of ``cells`` ((m, 3) int64), redrawn
    while it overlaps an earlier one; returns (number placed, state). Cells must be at least the largest r_i + r_j.
    """
    n_part = pos.shape[0]
    head = np.full(shape[0] * shape[1] * shape[2], -1, dtype=np.int64)
    nxt = np.empty(n_part, dtype=np.int64)
    e0, e1, e2 = shape[0] * h, shape[1] * h, shape[2] * h
    for i in range(n_part):
        placed = False
        for _ in range(tries):
            x, state = _uniform(state)
            m = min(int(x * cells.shape[0]), cells.shape[0] - 1)
            for d in range(3):
                y, state = _uniform(state)
                pos[i, d] = (cells[m, d] + 1.0 - y) * h
                pos[i, d] = min(pos[i, d], (cells[m, d] + 1.0) * h * (1.0 - 1e-15))
            ok = True
            for a in range(-1, 2):
                for b in range(-1, 2):
                    for c in range(-1, 2):
                        k0, k1, k2 = cells[m, 0] + a, cells[m, 1] + b, cells[m, 2] + c
                        if not (
                            _wrap_ok(k0, shape[0], periodic[0])
                            and _wrap_ok(k1, shape[1], periodic[1])
                            and _wrap_ok(k2, shape[2], periodic[2])
                        ):
                            continue
                        j = head[_flat(k0 % shape[0], k1 % shape[1], k2 % shape[2], shape[1], shape[2])]
                        while j >= 0 and ok:
                            dx = _min_image(pos[i, 0] - pos[j, 0], e0, periodic[0])
                            dy = _min_image(pos[i, 1] - pos[j, 1], e1, periodic[1])
                            dz = _min_image(pos[i, 2] - pos[j, 2], e2, periodic[2])
                            s = radius[sp[i]] + radius[sp[j]]
                            ok = dx * dx + dy * dy + dz * dz >= s * s
                            j = nxt[j]
            if ok:
                c = _flat(cells[m, 0], cells[m, 1], cells[m, 2], shape[1], shape[2])
                nxt[i] = head[c]
                head[c] = i
                placed = True
                break
        if not placed:
            return i, state
    return n_part, state


# ---------------------------------------------------------------------------------------------------------------------
# wall reactions in the Knudsen regime (thesis §4.1): one-face feed, specular back wall (RUECKWAND)
#: columns of the per-batch reaction tally
R_PARTICLES, R_OUT_A, R_OUT_P, R_OUT_S, R_TRUNC, R_HITS, R_TIME, R_REACT, R_FOLLOW, R_REVERSE, R_BACKWALL = (
    range(11)
)
R_ADSORB, R_ADS_TIME = 11, 12
N_RTALLY = 13
_RCACHE: dict = {}


def make_reactive_kernel(
    wall: tuple,
    inlet_law: int,
    inlet_speed: int,
    reverse: bool,
    follow: bool,
    zmap: bool,
    sites: bool = False,
    adsorb: bool = False,
):
    """Kernel of the one-face-fed pore with reactive walls; each effect is compiled in only when named.

    A particle enters as reactant A at the low face of the axis (a uniform point of an open inlet pixel, direction
    ``inlet_law``, speed ``inlet_speed``), flies with the Knudsen engine's exact flights, and is reflected
    specularly at the high face (the closed back wall, RUECKWAND, not a reactive wall). At each wall hit A turns
    into P with probability ``w[0]``; with ``reverse`` P turns back into A with ``w[1]``; with ``follow`` P turns
    into S with ``w[2]`` (A → P → S). Leaving through the inlet ends the history: A = REFLEX (R_OUT_A), P or S =
    FLUSS products (R_OUT_P, R_OUT_S). In steady state with N particles in the pore each entering particle is one
    history, so rates per particle-time are counts over R_TIME. ``zmap``: per axial bin ``zhist[b, 0]`` the reactive
    hits A → P, ``zhist[b, 1]`` the time spent there as A and ``zhist[b, 2]`` by all species (the total density is
    uniform, so their ratio is the reactant profile c_A/c₀ of (4.11)). ``sites``: every reaction probability at a
    wall hit is multiplied by ``site_w`` of the pore voxel hit (an active-site distribution, thesis §4.1); when
    ``site_count`` has one layer per batch, the reactions A → P per voxel are counted into it (for poisoning).
    ``adsorb``: after the reaction step a wall hit adsorbs the particle with probability ``w[3]`` for a residence
    time ``w[4]`` (fixed) or drawn from an exponential law of that mean (``w[5]`` = 1); it then desorbs by the wall
    law. The residence time counts in the particle time (R_TIME) and in R_ADS_TIME.
    """
    key = (
        *wall,
        int(inlet_law),
        int(inlet_speed),
        bool(reverse),
        bool(follow),
        bool(zmap),
        bool(sites),
        bool(adsorb),
    )
    if key in _RCACHE:
        return _RCACHE[key]
    LAW, MIXED, WSPEED, INLET, INSPEED, REVERSE, FOLLOW, ZMAP, SITES, ADSORB = key

    @njit(cache=True, fastmath=K_FASTMATH, parallel=True)
    def _reactive(
        geom,
        h,
        periodic,
        axis,
        inlet_cells,
        seed,
        first,
        per_batch,
        max_hits,
        vmean,
        alpha,
        w,
        site_w,
        site_count,
        tally,
        zhist,
    ):
        n_batches = tally.shape[0]
        length_ax = geom.shape[axis] * h[axis]
        bin_w = length_ax / zhist.shape[2]
        for b in prange(n_batches):
            pos = np.empty(3)
            u = np.empty(3)
            idx = np.empty(3, dtype=np.int64)
            img = np.zeros(3, dtype=np.int64)
            acc = np.zeros(4 * N_RTALLY)
            for q in range(per_batch):
                state = _stream_state(seed, first + b * per_batch + q)
                state = _uniform_in_pore(inlet_cells, h, pos, idx, state)
                pos[axis] = 0.0
                state = _emit(INLET, axis, 1.0, u, state)
                speed, state = _speed(INSPEED, vmean, state)
                species = 0
                hits = 0
                t_now = 0.0
                while True:
                    p_ax = pos[axis]
                    ev, ln, _ = _fly(geom, h, periodic, axis, pos, idx, u, img)
                    t_now += ln / speed
                    if ZMAP:
                        _profile_add(zhist[b, 2], p_ax, u[axis], ln, speed, bin_w)
                        if species == 0:
                            _profile_add(zhist[b, 1], p_ax, u[axis], ln, speed, bin_w)
                    if ev == EXIT_HIGH:
                        u[axis] = -u[axis]
                        acc[R_BACKWALL] += 1
                        continue
                    if ev == EXIT_LOW:
                        acc[R_OUT_A + species] += 1
                        break
                    hits += 1
                    x, state = _uniform(state)
                    f = site_w[idx[0], idx[1], idx[2]] if SITES else 1.0  # active-site factor of this voxel
                    if species == 0:
                        if x < f * w[0]:
                            species = 1
                            acc[R_REACT] += 1
                            if SITES and site_count.shape[0] == n_batches:  # poisoning: reactions per voxel
                                site_count[b, idx[0], idx[1], idx[2]] += 1
                            if ZMAP:
                                zhist[b, 0, min(int(pos[axis] / bin_w), zhist.shape[2] - 1)] += 1
                    elif species == 1:
                        if REVERSE and x < f * w[1]:
                            species = 0
                            acc[R_REVERSE] += 1
                        elif FOLLOW and x >= 1.0 - f * w[2]:
                            species = 2
                            acc[R_FOLLOW] += 1
                    if ADSORB:
                        y, state = _uniform(state)
                        if y < w[3]:
                            stay = w[4]
                            if w[5] > 0.0:
                                z, state = _uniform(state)
                                stay = -w[4] * math.log(z)
                            t_now += stay
                            acc[R_ADSORB] += 1
                            acc[R_ADS_TIME] += stay
                    if hits >= max_hits:
                        acc[R_TRUNC] += 1
                        break
                    speed, state = _reflect(LAW, MIXED, WSPEED, ev, u, speed, vmean, alpha, state)
                acc[R_PARTICLES] += 1
                acc[R_HITS] += hits
                acc[R_TIME] += t_now
            for c in range(N_RTALLY):
                tally[b, c] = acc[c]

    _RCACHE[key] = _reactive
    return _reactive
