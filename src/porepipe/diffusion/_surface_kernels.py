"""Numba kernel of the Knudsen gas with an explicit adsorbed layer (Mahler 2001 §4.3-4.4, beyond the thesis).

Every wall face of a pore voxel (a pore-solid voxel face, thesis §4.4: surface element = voxel face) is split into
``s × s`` adsorption sites; a site holds at most one particle. Gas particles fly as in the Knudsen engine (points,
exact voxel traversal, no gas-gas collisions) and all of them advance together through one event calendar (binary
heap, one pending event per particle, lazy invalidation by a per-particle counter), because adsorbed particles
couple them. Events:

- wall hit of a gas particle of species X on site s, one uniform number deciding between the reactions open on
  this hit (their probabilities add, thesis §4.3.1):
  Eley-Rideal (X is the mechanism's gas partner and s holds its adsorbed partner: ``er_w``), its reverse (4.18:
  X is the ER product and s is active and empty: ``er_reverse_w``; X turns into the gas reactant, which leaves,
  and the adsorbed reactant appears on s), a side reaction (4.20-4.22: X → ``side_to[X]`` with ``side_w[X]``,
  then a diffuse reflection); else adsorption (s active and empty: with probability ``ads[X]``), else a diffuse
  reflection;
- desorption of an adsorbed particle after its residence time (fixed or exponential of mean ``tau[X]``), emitted
  by the wall law with a thermal (flux-weighted Maxwell-Boltzmann) speed;
- surface hop (rate ``hop[X]``): to one of the 4 neighbour sites, rejected when it is occupied, inactive or
  missing (a symmetric exclusion process: it leaves the Langmuir occupation measure unchanged).

Arrival of a particle at a site (by adsorption or by a hop), in this order:

- side reaction on the surface (``surf_side_w[X]``, one try): X turns into ``surf_side_to[X]`` on that site;
- Langmuir-Hinshelwood: a particle of species A or B tries each neighbour site holding the other partner with
  probability ``lh_w`` (the reactive distance is one site spacing, h/s); on success both leave the surface and the
  product enters the gas from the arrival site;
- reverse Langmuir-Hinshelwood: the product tries each empty active neighbour with ``lh_reverse_w``; on success it
  becomes A on its site and a spare slot becomes B on that neighbour (neither tries Langmuir-Hinshelwood now).

The arrival path with the side reaction and the reverse reaction (:func:`_arrive`) runs only for a species that has
one of them; every other arrival takes the inline Langmuir-Hinshelwood path of the kernel loop.

Slots: particle ``i`` keeps its index for the whole run; a reaction turns one reactant slot into the product and
removes the other (state GONE); a reverse reaction takes a GONE slot back (one spare slot per starting product
particle keeps the stack from running dry). With ``replenish`` the product is counted and the two reactant slots are put back
into the gas, uniform in the pore with an isotropic direction and a Maxwell-Boltzmann speed (stoichiometric
replenishment, thesis §4.3.1: the totals of A and B stay constant, so the system reaches a steady state).

The wall law, the residence law, replenishment and the mechanisms are run-time options (``opts``, the species
arrays; a mechanism whose species index is -1 is off): one compiled kernel serves every scene, at the cost of a
few untaken branches per event.

Walls re-emit with a thermal speed (flux-weighted MB): then the mean time between wall hits of every particle is
4V/(v̄S) whatever its history, so reactions that consume fast particles first cannot bias the rate laws.

The arrays travel in a few tuples (heterogeneous tuples of arrays). Passing or unpacking a tuple costs a reference
count per member, so the kernel unpacks them once and runs the common events (reflection, adsorption, desorption,
hop, Langmuir-Hinshelwood tries) on those names with helpers that take their few arrays one by one; only the
reactions, rarer, call helpers on the tuples (per-event tuple passing had halved the speed):

- ``geo = (codes, h, periodic, cells, face_of, site_face, active, s, nbr)``: the pore, its sites and their
  neighbour table (``nbr[site, k]``, k = +a, −a, +b, −b, -1 = none: in-face only or across voxel edges, see
  :mod:`porepipe.diffusion._surface_sites`) (read only);
- ``kin = (opts, vmean, ads, tau, hop)``: run options and per-species data (read only);
- ``mech = (lh_spec, er_spec, w, side_to, side_w, surf_side_to, surf_side_w)``: mechanism species (a, b, product;
  -1 = off), ``w = [lh_w, er_w, er_reverse_w, lh_reverse_w]`` and per species the side-reaction product (-1 = none)
  and probability at a gas wall hit and on arrival at a site;
- ``pt = (sp, st, site, t_des, cnt, pos, idx, u, speed, tev)``: the particle slots;
- ``surf = (occ, n_gas, n_ads, free)``: site occupation, the live counts per species and the stack of GONE slots
  (``free[0]`` = its height);
- ``heap = (ht, hi, hj, hci, hcj)``: the event calendar (its size ``nh`` travels beside it).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from porepipe._shared import numba_config  # noqa: F401  (the package-wide cache stamp, before any kernel)
from porepipe.diffusion._edmd_kernels import _heap_pop, _heap_push, _heap_room
from porepipe.diffusion._kernels import (
    SPEED_FLUX,
    SPEED_MAXWELL,
    _emit,
    _fly,
    _isotropic,
    _speed,
    _stream_state,
    _uniform,
    _uniform_in_pore,
)

GAS, ADSORBED, GONE = 0, 1, 2
#: per-species columns of the block tally (S_SIDE: side reactions at gas wall hits, S_SURF_SIDE: on the surface)
S_HITS, S_ADS, S_DES, S_HOP_TRY, S_HOP_OK, S_GAS_T, S_ADS_T, S_SIDE, S_SURF_SIDE = range(9)
N_STALLY = 9
#: reaction columns of the block tally
X_LH, X_ER, X_ER_REV, X_LH_REV = range(4)
N_XTALLY = 4
#: entries of the options array: wall law, exponential residence (1) or fixed (0), replenishment (1)
O_LAW, O_REXP, O_REPL = range(3)
#: entries of the mechanism probabilities
W_LH, W_ER, W_REV, W_LH_REV = range(4)
#: start site of a spare slot (GONE at the start: room for the B that a reverse Eley-Rideal reaction puts back)
SPARE = -2
#: ``_fly``'s exit axis for closed geometries: no exit. An int64, not the literal -1 (which numba compiles as a
#: specialisation of its own, ~7 CPU-s): the type the event-driven gas's kernel passes its exit axis as
_NO_EXIT = np.int64(-1)


# ---------------------------------------------------------------------------------------------------------------------
# hot helpers: every event runs them, so they take the few arrays they need one by one (a tuple passed or unpacked per
# event costs a reference count per member: the kernel ran at half speed when these took the tuples)
@njit(cache=True)
def _site_of_hit(face_of, shape, h, s, pos, idx, ev):
    """Site index of a wall hit at ``pos`` on face ``ev`` of voxel ``idx`` (-1 if the face is not a wall face)."""
    f = face_of[((idx[0] * shape[1] + idx[1]) * shape[2] + idx[2]) * 6 + ev]
    if f < 0:
        return -1
    ax = ev >> 1
    a, b = (ax + 1) % 3, (ax + 2) % 3
    ia = min(max(int((pos[a] / h[a] - idx[a]) * s), 0), s - 1)
    ib = min(max(int((pos[b] / h[b] - idx[b]) * s), 0), s - 1)
    return (f * s + ia) * s + ib


@njit(cache=True)
def _site_point(site_face, h, s, site, pos, idx):
    """Put ``pos``/``idx`` at the centre of ``site`` (on its face plane); returns the face event (0..5)."""
    f = site // (s * s)
    ia = (site // s) % s
    ib = site % s
    ev = site_face[f, 3]
    ax = ev >> 1
    a, b = (ax + 1) % 3, (ax + 2) % 3
    for d in range(3):
        idx[d] = site_face[f, d]
    pos[ax] = (idx[ax] + (ev & 1)) * h[ax]
    pos[a] = (idx[a] + (ia + 0.5) / s) * h[a]
    pos[b] = (idx[b] + (ib + 0.5) / s) * h[b]
    return ev


@njit(cache=True)
def _residence(tau, law_exp, state):
    if not law_exp or not math.isfinite(tau):
        return tau, state
    x, state = _uniform(state)
    return -tau * math.log(x), state


@njit(cache=True)
def _next_surface_time(t, t_des, hop, state):
    """Next event of an adsorbed particle: min(desorption, next hop); returns (time, is_hop, state)."""
    if hop > 0.0:
        x, state = _uniform(state)
        th = t - math.log(x) / hop
        if th < t_des:
            return th, True, state
    return t_des, False, state


@njit(cache=True)
def _flight(codes, h, periodic, law, ev, vmean, pos, idx, u, state):
    """Diffuse emission from the wall face ``ev`` at ``pos`` (direction into ``u``), thermal speed, flight to the next
    hit; returns (flight time, speed, face event of that hit, state).
    """
    sign = -1.0 if (ev & 1) else 1.0
    state = _emit(law, ev >> 1, sign, u, state)
    v, state = _speed(SPEED_FLUX, vmean, state)
    img = np.zeros(3, dtype=np.int64)
    e2, ln, _ = _fly(codes, h, periodic, _NO_EXIT, pos, idx, u, img)
    return ln / v, v, e2, state


@njit(cache=True)
def _lh_partner(nbr, occ, sp, lh_spec, w_lh, si, x, state):
    """Langmuir-Hinshelwood tries of species ``x`` just arrived on site ``si``: each neighbour holding its partner
    reacts with ``w_lh``; returns (partner slot or -1, its site, state).
    """
    if lh_spec[0] < 0 or w_lh <= 0.0 or (x != lh_spec[0] and x != lh_spec[1]):
        return -1, -1, state
    partner = lh_spec[1] if x == lh_spec[0] else lh_spec[0]
    for k in range(4):
        nb = nbr[si, k]
        if nb < 0:
            continue
        j = occ[nb]
        if j < 0 or sp[j] != partner:
            continue
        y, state = _uniform(state)
        if y < w_lh:
            return j, nb, state
    return -1, -1, state


@njit(cache=True)
def _tally_time(tally, t_last, t, t_warm, blk_len, n_gas, n_ads):
    """Add the gas and adsorbed count integrals over (t_last, t] to the time blocks after ``t_warm``."""
    n_blk = tally.shape[0]
    a0 = max(t_last, t_warm)
    while a0 < t:
        bk = min(int((a0 - t_warm) / blk_len), n_blk - 1)
        while bk < n_blk - 1 and t_warm + (bk + 1) * blk_len <= a0:
            bk += 1  # a0 on a block's end that the division rounded below it (else a1 = a0 for ever)
        a1 = min(t, t_warm + (bk + 1) * blk_len) if bk < n_blk - 1 else t
        for x in range(n_gas.shape[0]):
            tally[bk, x, S_GAS_T] += n_gas[x] * (a1 - a0)
            tally[bk, x, S_ADS_T] += n_ads[x] * (a1 - a0)
        a0 = a1


@njit(cache=True)
def _sample(series, k, n_gas, n_ads):
    for x in range(n_gas.shape[0]):
        series[k, x, 0] = n_gas[x]
        series[k, x, 1] = n_ads[x]


@njit(cache=True)
def _wall_odds(er_spec, w, free, sp, occ, active, x, si):
    """Probabilities of Eley-Rideal and of its reverse at a hit of species ``x`` on site ``si``."""
    if er_spec[0] < 0 or si < 0:
        return 0.0, 0.0
    if x == er_spec[0] and occ[si] >= 0 and sp[occ[si]] == er_spec[1]:
        return w[W_ER], 0.0
    if x == er_spec[2] and w[W_REV] > 0.0 and active[si] and occ[si] < 0 and free[0] > 0:
        return 0.0, w[W_REV]
    return 0.0, 0.0


# ---------------------------------------------------------------------------------------------------------------------
@njit(cache=True)
def surface_kernel(
    geo,
    kin,
    mech,
    sp0,
    site0,
    seed,
    t_end,
    t_warm,
    t_samples,
    tally,
    rtally,
    series,
    final_species,
    final_state,
):
    """Run to ``t_end``; tallies per time block after ``t_warm``; ``series[k, X, 0/1]`` = gas / adsorbed counts
    of species X at ``t_samples[k]``. ``site0[i]`` >= 0 starts particle i adsorbed there (``SPARE``: a spare slot).
    Returns the number of events. The common events (reflection, adsorption, desorption, hop) run here on local
    names; the reactions call helpers that take the tuples.
    """
    codes, h, periodic, _, face_of, site_face, active, s, nbr = geo
    opts, vmean, ads, tau, hop = kin
    lh_spec, er_spec, w, _, side_w, _, surf_side_w = mech
    law = opts[O_LAW]
    rexp = opts[O_REXP] == 1
    n = sp0.shape[0]
    n_sp = vmean.shape[0]
    n_blk = tally.shape[0]
    blk_len = (t_end - t_warm) / n_blk
    pt = (
        sp0.copy(),
        np.zeros(n, dtype=np.int64),  # st
        np.full(n, -1, dtype=np.int64),  # site
        np.zeros(n),  # t_des
        np.zeros(n, dtype=np.int64),  # cnt
        np.zeros((n, 3)),  # pos
        np.zeros((n, 3), dtype=np.int64),  # idx
        np.zeros((n, 3)),  # u
        np.ones(n),  # speed
        np.zeros(n, dtype=np.int64),  # tev: face event of the pending wall hit
    )
    sp, st, site, t_des, cnt, pos, idx, u, speed, tev = pt
    surf = (
        np.full(active.shape[0], -1, dtype=np.int64),
        np.zeros(n_sp),
        np.zeros(n_sp),
        np.zeros(n + 1, np.int64),
    )
    occ, n_gas, n_ads, free = surf
    cap = 2 * n + 16
    heap = (np.empty(cap), np.empty(cap, np.int64), np.empty(cap, np.int64))
    heap = heap + (np.empty(cap, np.int64), np.empty(cap, np.int64))
    ht, hi, hj, hci, hcj = heap
    nh = 0
    state = _stream_state(seed, 0)
    # start: gas particles in equilibrium, adsorbed ones on their sites, spare slots on the free stack
    for i in range(n):
        if site0[i] == SPARE:
            st[i] = GONE
            free[0] += 1
            free[free[0]] = i
            continue
        if site0[i] >= 0:
            st[i] = ADSORBED
            site[i] = site0[i]
            occ[site0[i]] = i
            _site_point(site_face, h, s, site0[i], pos[i], idx[i])
            tau_i, state = _residence(tau[sp[i]], rexp, state)
            t_des[i] = tau_i
            te, _, state = _next_surface_time(0.0, t_des[i], hop[sp[i]], state)
            n_ads[sp[i]] += 1
        else:
            te, state = _insert_gas(geo, pt, i, 0.0, vmean[sp[i]], state)
            n_gas[sp[i]] += 1
        nh = _heap_push(ht, hi, hj, hci, hcj, nh, te, i, -1, cnt[i], 0)
    t_last = 0.0
    k_sample = 0
    events = 0
    while nh > 0:
        t = ht[0]
        i = hi[0]
        c_i = hci[0]
        nh = _heap_pop(ht, hi, hj, hci, hcj, nh)
        if c_i != cnt[i]:
            continue
        if t > t_end:
            t = t_end
        # time integrals and samples up to t
        while k_sample < t_samples.shape[0] and t_samples[k_sample] <= t:
            _sample(series, k_sample, n_gas, n_ads)
            k_sample += 1
        _tally_time(tally, t_last, t, t_warm, blk_len, n_gas, n_ads)
        t_last = t
        if t >= t_end:
            break
        events += 1
        bk = min(int((t - t_warm) / blk_len), n_blk - 1) if t >= t_warm else -1
        x = sp[i]
        emit_ev = -1  # >= 0: particle i leaves the wall face emit_ev into the gas
        arrived = False  # particle i has just taken a site
        if st[i] == GAS:
            # ---- wall hit: Eley-Rideal, its reverse or a side reaction (one uniform number), else adsorption, else
            # a diffuse reflection
            ev = tev[i]
            si = _site_of_hit(face_of, codes.shape, h, s, pos[i], idx[i], ev)
            if bk >= 0:
                tally[bk, x, S_HITS] += 1
            p_er, p_rev = _wall_odds(er_spec, w, free, sp, occ, active, x, si)
            reacted = False
            if p_er + p_rev + side_w[x] > 0.0:
                y, state = _uniform(state)
                reacted = y < p_er + p_rev + side_w[x]
                if y < p_er:
                    nh, state = _er_forward(
                        geo, kin, mech, pt, surf, heap, nh, rtally, i, si, t, ev, bk, state
                    )
                elif y < p_er + p_rev:
                    nh, state = _er_reverse(
                        geo, kin, mech, pt, surf, heap, nh, tally, rtally, i, si, t, ev, bk, state
                    )
                elif reacted:
                    nh, state = _side_reaction(geo, kin, mech, pt, surf, heap, nh, tally, i, t, ev, bk, state)
            if not reacted:
                emit_ev = ev
                if si >= 0 and ads[x] > 0.0 and active[si] and occ[si] < 0:
                    y, state = _uniform(state)
                    if y < ads[x]:
                        emit_ev = -1
                        arrived = True
                        st[i] = ADSORBED
                        site[i] = si
                        occ[si] = i
                        n_gas[x] -= 1
                        n_ads[x] += 1
                        if bk >= 0:
                            tally[bk, x, S_ADS] += 1
                        tau_i, state = _residence(tau[x], rexp, state)
                        t_des[i] = t + tau_i
        elif t >= t_des[i]:
            # ---- desorption
            si = site[i]
            occ[si] = -1
            site[i] = -1
            st[i] = GAS
            n_ads[x] -= 1
            n_gas[x] += 1
            if bk >= 0:
                tally[bk, x, S_DES] += 1
            emit_ev = _site_point(site_face, h, s, si, pos[i], idx[i])
        else:
            # ---- hop try to a neighbour site
            si = site[i]
            if bk >= 0:
                tally[bk, x, S_HOP_TRY] += 1
            y, state = _uniform(state)
            target = nbr[si, min(int(y * 4.0), 3)]
            if target >= 0 and active[target] and occ[target] < 0:
                occ[si] = -1
                occ[target] = i
                site[i] = target
                _site_point(site_face, h, s, target, pos[i], idx[i])
                if bk >= 0:
                    tally[bk, x, S_HOP_OK] += 1
                arrived = True
            else:
                te, _, state = _next_surface_time(t, t_des[i], hop[x], state)
                cnt[i] += 1
                nh = _heap_push(ht, hi, hj, hci, hcj, nh, te, i, -1, cnt[i], 0)
        if emit_ev >= 0:
            dt, speed[i], tev[i], state = _flight(
                codes, h, periodic, law, emit_ev, vmean[x], pos[i], idx[i], u[i], state
            )
            cnt[i] += 1
            nh = _heap_push(ht, hi, hj, hci, hcj, nh, t + dt, i, -1, cnt[i], 0)
        if arrived:
            cnt[i] += 1
            if surf_side_w[x] > 0.0 or (x == lh_spec[2] and w[W_LH_REV] > 0.0):
                # rarer: a surface side reaction or the reverse Langmuir-Hinshelwood reaction is open to x
                nh, state = _arrive(geo, kin, mech, pt, surf, heap, nh, tally, rtally, i, t, bk, state)
            else:
                # Langmuir-Hinshelwood with the neighbours, else the next surface event
                j, nb, state = _lh_partner(nbr, occ, sp, lh_spec, w[W_LH], site[i], x, state)
                if j >= 0:
                    nh, state = _lh_react(geo, kin, mech, pt, surf, heap, nh, rtally, i, j, nb, t, bk, state)
                else:
                    te, _, state = _next_surface_time(t, t_des[i], hop[x], state)
                    nh = _heap_push(ht, hi, hj, hci, hcj, nh, te, i, -1, cnt[i], 0)
        if nh + 4 > ht.shape[0]:
            ht, hi, hj, hci, hcj, nh = _heap_room(ht, hi, hj, hci, hcj, nh, 4, cnt)
            heap = (ht, hi, hj, hci, hcj)
    while k_sample < t_samples.shape[0]:
        _sample(series, k_sample, n_gas, n_ads)
        k_sample += 1
    # element by element: a slice copy compiles its shape-error message (~4 CPU-s)
    for i in range(sp.shape[0]):
        final_species[i] = sp[i]
        final_state[i] = st[i]
    return events


# ---------------------------------------------------------------------------------------------------------------------
# reactions: rarer events, helpers on the tuples
@njit(cache=True)
def _emit_slot(geo, law, pt, i, t, ev, vmean, state):
    """Slot ``i`` leaves the wall face ``ev`` it sits on (see :func:`_flight`); returns its next hit time."""
    pos, idx, u, speed, tev = pt[5], pt[6], pt[7], pt[8], pt[9]
    dt, speed[i], tev[i], state = _flight(geo[0], geo[1], geo[2], law, ev, vmean, pos[i], idx[i], u[i], state)
    return t + dt, state


@njit(cache=True)
def _insert_gas(geo, pt, i, t, vmean, state):
    """Slot ``i`` as a fresh equilibrium gas particle (uniform, isotropic, Maxwell speed); returns its hit time."""
    codes, h, periodic, cells = geo[0], geo[1], geo[2], geo[3]
    pos, idx, u, speed, tev = pt[5], pt[6], pt[7], pt[8], pt[9]
    p = pos[i]
    q = idx[i]
    d = u[i]
    state = _uniform_in_pore(cells, h, p, q, state)
    state = _isotropic(d, state)
    v, state = _speed(SPEED_MAXWELL, vmean, state)
    img = np.zeros(3, dtype=np.int64)
    e2, ln, _ = _fly(codes, h, periodic, _NO_EXIT, p, q, d, img)
    speed[i] = v
    tev[i] = e2
    return t + ln / v, state


@njit(cache=True)
def _push(heap, nh, cnt, i, t):
    """Schedule slot ``i``'s next event at ``t`` under its current counter (a time < 0 = nothing to schedule)."""
    if t < 0.0:
        return nh
    ht, hi, hj, hci, hcj = heap
    return _heap_push(ht, hi, hj, hci, hcj, nh, t, i, -1, cnt[i], 0)


@njit(cache=True)
def _react(geo, kin, pt, surf, i, j, xj, product, t, ev, state):
    """Slots i (at a wall point, face ``ev``) and j (already off the counts) react: i becomes the product and
    leaves the wall into the gas, j is gone; with opts[O_REPL] both are put back as fresh gas reactants instead.
    Returns the next event times of i and j (-1: none) and the state.
    """
    opts, vmean = kin[0], kin[1]
    sp, st, site, cnt = pt[0], pt[1], pt[2], pt[4]
    n_gas, free = surf[1], surf[3]
    xi = sp[i]
    cnt[i] += 1
    cnt[j] += 1
    site[i] = -1
    site[j] = -1
    if opts[O_REPL] == 1:
        st[i] = GAS
        st[j] = GAS
        sp[j] = xj
        n_gas[xi] += 1
        n_gas[xj] += 1
        ti, state = _insert_gas(geo, pt, i, t, vmean[xi], state)
        tj, state = _insert_gas(geo, pt, j, t, vmean[xj], state)
        return ti, tj, state
    st[i] = GAS
    st[j] = GONE
    free[0] += 1
    free[free[0]] = j
    sp[i] = product
    n_gas[product] += 1
    ti, state = _emit_slot(geo, opts[O_LAW], pt, i, t, ev, vmean[product], state)
    return ti, -1.0, state


@njit(cache=True)
def _er_forward(geo, kin, mech, pt, surf, heap, nh, rtally, i, si, t, ev, bk, state):
    """Eley-Rideal at the hit of gas ``i`` on site ``si``, which holds its adsorbed partner."""
    sp, cnt = pt[0], pt[4]
    occ, n_gas, n_ads = surf[0], surf[1], surf[2]
    j = occ[si]
    occ[si] = -1
    n_ads[sp[j]] -= 1
    n_gas[sp[i]] -= 1
    if bk >= 0:
        rtally[bk, X_ER] += 1
    ti, tj, state = _react(geo, kin, pt, surf, i, j, sp[j], mech[1][2], t, ev, state)
    nh = _push(heap, nh, cnt, i, ti)
    return _push(heap, nh, cnt, j, tj), state


@njit(cache=True)
def _lh_react(geo, kin, mech, pt, surf, heap, nh, rtally, i, j, nb, t, bk, state):
    """Langmuir-Hinshelwood of ``i`` (just arrived on its site) with ``j`` on the neighbour site ``nb``."""
    sp, site, cnt, pos, idx = pt[0], pt[2], pt[4], pt[5], pt[6]
    occ, n_ads = surf[0], surf[2]
    si = site[i]
    x, partner = sp[i], sp[j]
    occ[si] = -1
    occ[nb] = -1
    n_ads[x] -= 1
    n_ads[partner] -= 1
    if bk >= 0:
        rtally[bk, X_LH] += 1
    ev = _site_point(geo[5], geo[1], geo[7], si, pos[i], idx[i])
    ti, tj, state = _react(geo, kin, pt, surf, i, j, partner, mech[0][2], t, ev, state)
    nh = _push(heap, nh, cnt, i, ti)
    return _push(heap, nh, cnt, j, tj), state


@njit(cache=True)
def _arrive(geo, kin, mech, pt, surf, heap, nh, tally, rtally, i, t, bk, state):
    """Slot ``i`` has just taken its site (``cnt[i]`` already bumped): its surface side reaction (one try), else
    Langmuir-Hinshelwood with a neighbour partner, else (``i`` the LH product) the reverse LH reaction with an empty
    neighbour, else its next surface event.
    """
    sp, site, t_des, cnt = pt[0], pt[2], pt[3], pt[4]
    lh_spec, w, surf_side_w = mech[0], mech[2], mech[6]
    x = sp[i]
    if surf_side_w[x] > 0.0:
        y, state = _uniform(state)
        if y < surf_side_w[x]:
            return _surface_side(kin, mech, pt, surf, heap, nh, tally, i, t, bk, state)
    j, nb, state = _lh_partner(geo[8], surf[0], sp, lh_spec, w[W_LH], site[i], x, state)
    if j >= 0:
        return _lh_react(geo, kin, mech, pt, surf, heap, nh, rtally, i, j, nb, t, bk, state)
    if x == lh_spec[2] and w[W_LH_REV] > 0.0 and surf[3][0] > 0:
        nb, state = _empty_neighbour(geo[8], surf[0], geo[6], w[W_LH_REV], site[i], state)
        if nb >= 0:
            return _lh_reverse(geo, kin, mech, pt, surf, heap, nh, rtally, i, nb, t, bk, state)
    te, _, state = _next_surface_time(t, t_des[i], kin[4][x], state)
    return _push(heap, nh, cnt, i, te), state


@njit(cache=True)
def _empty_neighbour(nbr, occ, active, w_rev, si, state):
    """Reverse Langmuir-Hinshelwood tries from site ``si``: each empty active neighbour with ``w_rev`` (the order of
    :func:`_lh_partner`); returns (that site or -1, state).
    """
    for k in range(4):
        nb = nbr[si, k]
        if nb < 0 or not active[nb] or occ[nb] >= 0:
            continue
        y, state = _uniform(state)
        if y < w_rev:
            return nb, state
    return -1, state


@njit(cache=True)
def _place(kin, pt, surf, j, x, si, t, state):
    """Slot ``j`` (GONE, or on ``si`` already, off the counts) becomes species ``x`` adsorbed on ``si`` (its position
    set by the caller) with a fresh residence time and a bumped counter.
    """
    sp, st, site, t_des, cnt = pt[0], pt[1], pt[2], pt[3], pt[4]
    occ, n_ads = surf[0], surf[2]
    sp[j] = x
    st[j] = ADSORBED
    site[j] = si
    occ[si] = j
    n_ads[x] += 1
    tau_j, state = _residence(kin[3][x], kin[0][O_REXP] == 1, state)
    t_des[j] = t + tau_j
    cnt[j] += 1
    return state


@njit(cache=True)
def _adsorb_slot(kin, pt, surf, j, x, si, t, state):
    """:func:`_place`, then the next surface event time (no Langmuir-Hinshelwood try: the slot did not arrive)."""
    state = _place(kin, pt, surf, j, x, si, t, state)
    te, _, state = _next_surface_time(t, pt[3][j], kin[4][x], state)
    return te, state


@njit(cache=True)
def _lh_reverse(geo, kin, mech, pt, surf, heap, nh, rtally, i, nb, t, bk, state):
    """Reverse Langmuir-Hinshelwood (thesis §4.3.2): the product ``i``, just arrived on its site, splits into the
    reactant ``a`` on that site and ``b`` (a spare slot) on the empty active neighbour ``nb``. Neither tries a
    Langmuir-Hinshelwood reaction now (they would re-form the product they came from); both get fresh residence
    times and their next surface events.
    """
    x_a, x_b, x_p = mech[0][0], mech[0][1], mech[0][2]
    pos, idx = pt[5], pt[6]
    n_ads, free = surf[2], surf[3]
    if bk >= 0:
        rtally[bk, X_LH_REV] += 1
    n_ads[x_p] -= 1
    ti, state = _adsorb_slot(kin, pt, surf, i, x_a, pt[2][i], t, state)
    j = free[free[0]]
    free[0] -= 1
    _site_point(geo[5], geo[1], geo[7], nb, pos[j], idx[j])
    tj, state = _adsorb_slot(kin, pt, surf, j, x_b, nb, t, state)
    nh = _push(heap, nh, pt[4], i, ti)
    return _push(heap, nh, pt[4], j, tj), state


@njit(cache=True)
def _surface_side(kin, mech, pt, surf, heap, nh, tally, i, t, bk, state):
    """Side reaction on the surface (thesis §4.3.2, by-products of adsorbed species): ``i``, just arrived on its
    site, turns into its by-product there, which gets a fresh residence time and its next surface event.
    """
    x = pt[0][i]
    if bk >= 0:
        tally[bk, x, S_SURF_SIDE] += 1
    surf[2][x] -= 1
    te, state = _adsorb_slot(kin, pt, surf, i, mech[5][x], pt[2][i], t, state)
    return _push(heap, nh, pt[4], i, te), state


@njit(cache=True)
def _er_reverse(geo, kin, mech, pt, surf, heap, nh, tally, rtally, i, si, t, ev, bk, state):
    """Reverse Eley-Rideal (thesis 4.18) at the hit of product ``i`` on the empty active site ``si``: ``i`` turns
    into the gas reactant and leaves the wall, a spare slot becomes the adsorbed reactant on ``si`` (and arrives
    there: it may react by Langmuir-Hinshelwood at once).
    """
    opts, vmean = kin[0], kin[1]
    x_a, x_b, x_p = mech[1][0], mech[1][1], mech[1][2]
    sp, cnt, pos, idx = pt[0], pt[4], pt[5], pt[6]
    n_gas, free = surf[1], surf[3]
    if bk >= 0:
        rtally[bk, X_ER_REV] += 1
    n_gas[x_p] -= 1
    n_gas[x_a] += 1
    sp[i] = x_a
    te, state = _emit_slot(geo, opts[O_LAW], pt, i, t, ev, vmean[x_a], state)
    cnt[i] += 1
    nh = _push(heap, nh, cnt, i, te)
    j = free[free[0]]
    free[0] -= 1
    _site_point(geo[5], geo[1], geo[7], si, pos[j], idx[j])
    state = _place(kin, pt, surf, j, x_b, si, t, state)
    return _arrive(geo, kin, mech, pt, surf, heap, nh, tally, rtally, j, t, bk, state)


@njit(cache=True)
def _side_reaction(geo, kin, mech, pt, surf, heap, nh, tally, i, t, ev, bk, state):
    """Side reaction (thesis 4.20-4.22) at a wall hit of gas particle ``i``: it turns into its by-product and is
    reflected diffusely with the by-product's thermal speed.
    """
    opts, vmean = kin[0], kin[1]
    sp, cnt = pt[0], pt[4]
    n_gas = surf[1]
    x = sp[i]
    y = mech[3][x]
    if bk >= 0:
        tally[bk, x, S_SIDE] += 1
    n_gas[x] -= 1
    n_gas[y] += 1
    sp[i] = y
    te, state = _emit_slot(geo, opts[O_LAW], pt, i, t, ev, vmean[y], state)
    cnt[i] += 1
    return _push(heap, nh, cnt, i, te), state
