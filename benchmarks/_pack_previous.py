# ruff: noqa: SIM102  (nested ifs as in the kernels copied here: src/porepipe/*/_kernels.py)
"""The packing step kernels before issue 22's last rewrite, kept only as the benchmark's baselines.

``benchmarks/pack.py`` times them beside the current kernel in the same process (and checks their forces against
it), so each speed-up is measured under one machine load:

- ``original``: the full neighbour list, each pair evaluated from both ends (commit 7cfc08a);
- ``previous``: the half list with Newton's third law in three colours of slabs (commit c5e211a, main at 9f27cb0),
  one pass per pair with its scattered updates interleaved (not vectorised).

Both take the arguments of :func:`porepipe.packing._kernels.make_step_kernel`'s kernel; ``original`` takes the full
list (``nbr_start, nbr_idx``) where the others take the half list and the slabs.
"""

import math

from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH
from porepipe.packing._kernels import (
    _NEG_INF,
    _min_image,
    _pair_force_over_dist,
    _sphere_aux,
    _tie_axis,
    _uniform,
    _wrap,
)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _owner_pairs_previous(
    i,
    x_old,
    r,
    types,
    ids,
    frozen,
    half_start,
    half_idx,
    box,
    periodic,
    kpair,
    hcoef,
    sigp,
    cut,
    f_new,
    sig_max,
    conv,
    freeze,
    walls,
):
    """Every pair (i, j) of sphere i's half list, evaluated once and applied to both ends (Newton's third law).

    Adds the pair force to f_new[i] (summed over the list first) and its negative to f_new[j] (both ends see
    bitwise-negated differences), raises sig_max of both to sigma_ij (one division, a max: no branch) and sets
    conv of both to 1 when the partner is within reach (the flag the step's stochastic forces read). The caller
    runs spheres that share a partner in one thread, in a fixed order.
    """
    ti = types[i]
    ri = r[i]
    fro_i = False
    if freeze:
        fro_i = frozen[i] != 0
    fx = 0.0
    fy = 0.0
    fz = 0.0
    smax = sig_max[i]
    reach_any = 0
    for p in range(half_start[i], half_start[i + 1]):
        j = half_idx[p]
        tj = types[j]
        rj = r[j]
        if walls:
            dx0 = _min_image(x_old[i, 0] - x_old[j, 0], box[0], periodic[0])
            dx1 = _min_image(x_old[i, 1] - x_old[j, 1], box[1], periodic[1])
            dx2 = _min_image(x_old[i, 2] - x_old[j, 2], box[2], periodic[2])
        else:
            dx0 = _min_image(x_old[i, 0] - x_old[j, 0], box[0], True)
            dx1 = _min_image(x_old[i, 1] - x_old[j, 1], box[1], True)
            dx2 = _min_image(x_old[i, 2] - x_old[j, 2], box[2], True)
        dist = math.sqrt(dx0 * dx0 + dx1 * dx1 + dx2 * dx2)
        rsum = ri + rj
        rmin2 = rsum - abs(ri - rj)
        sig_ij = (rsum - dist) / rmin2
        smax = max(smax, sig_ij)
        sig_max[j] = max(sig_max[j], sig_ij)
        fro_j = False
        if freeze:
            fro_j = frozen[j] != 0
            if fro_i and fro_j:
                continue
        dxeq = rsum - 0.5 * sigp[ti, tj] * rmin2
        in_reach = dist <= cut * dxeq
        if dist > 0.0:
            g = _pair_force_over_dist(dist, dxeq, kpair[ti, tj], hcoef[ti, tj])
            g = g if in_reach else 0.0  # a select, not a branch: skin-region partners cost the same
            c0 = g * dx0
            c1 = g * dx1
            c2 = g * dx2
        elif in_reach:
            f = hcoef[ti, tj] / dxeq
            c0 = f * _tie_axis(ids[i], ids[j], 0)
            c1 = f * _tie_axis(ids[i], ids[j], 1)
            c2 = f * _tie_axis(ids[i], ids[j], 2)
        else:
            continue  # coincident centres out of reach: no force
        reach_any |= in_reach
        conv[j] |= in_reach
        if not fro_i:
            fx += c0
            fy += c1
            fz += c2
        if not fro_j:
            f_new[j, 0] -= c0
            f_new[j, 1] -= c1
            f_new[j, 2] -= c2
    f_new[i, 0] += fx
    f_new[i, 1] += fy
    f_new[i, 2] += fz
    sig_max[i] = smax
    if reach_any:
        conv[i] = 1


_CACHE: dict = {}


def make_kernel(which: str, freeze: bool, stochastic: bool, walls: bool):
    """The ``original`` or ``previous`` step kernel compiled with the given effects (see the module doc)."""
    key = (which, bool(freeze), bool(stochastic), bool(walls))
    if key in _CACHE:
        return _CACHE[key]
    FREEZE, STOCH, WALLS = key[1:]
    if which == "original":

        @njit(cache=True, fastmath=FASTMATH, parallel=True)
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
            nbr_start,
            nbr_idx,
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
        ):
            n = x_old.shape[0]
            half_dt2_m = 0.5 * dt * dt / mass
            for i in prange(n):
                ti = types[i]
                ri = r[i]
                is_frozen = False
                if FREEZE:
                    is_frozen = frozen[i] != 0
                fx = 0.0
                fy = 0.0
                fz = 0.0
                smax = _NEG_INF
                nforce = 0
                for p in range(nbr_start[i], nbr_start[i + 1]):
                    j = nbr_idx[p]
                    tj = types[j]
                    rj = r[j]
                    if WALLS:
                        dx0 = _min_image(x_old[i, 0] - x_old[j, 0], box[0], periodic[0])
                        dx1 = _min_image(x_old[i, 1] - x_old[j, 1], box[1], periodic[1])
                        dx2 = _min_image(x_old[i, 2] - x_old[j, 2], box[2], periodic[2])
                    else:
                        dx0 = _min_image(x_old[i, 0] - x_old[j, 0], box[0], True)
                        dx1 = _min_image(x_old[i, 1] - x_old[j, 1], box[1], True)
                        dx2 = _min_image(x_old[i, 2] - x_old[j, 2], box[2], True)
                    dist = math.sqrt(dx0 * dx0 + dx1 * dx1 + dx2 * dx2)
                    rsum = ri + rj
                    rmin2 = rsum - abs(ri - rj)
                    if rsum - dist > smax * rmin2:  # sigma_ij > smax, tested without a division (rmin2 > 0)
                        smax = (rsum - dist) / rmin2
                    if FREEZE:
                        if is_frozen:
                            continue
                    dxeq = rsum - 0.5 * sigp[ti, tj] * rmin2
                    in_reach = dist <= cut * dxeq
                    nforce += in_reach
                    if dist > 0.0:
                        g = _pair_force_over_dist(dist, dxeq, kpair[ti, tj], hcoef[ti, tj])
                        g = (
                            g if in_reach else 0.0
                        )  # a select, not a branch: skin-region partners cost the same
                        fx += g * dx0
                        fy += g * dx1
                        fz += g * dx2
                    elif in_reach:
                        f = hcoef[ti, tj] / dxeq
                        fx += f * _tie_axis(ids[i], ids[j], 0)
                        fy += f * _tie_axis(ids[i], ids[j], 1)
                        fz += f * _tie_axis(ids[i], ids[j], 2)
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
                decay = cm / cp_t[ti]
                kick = dt / (2.0 * mass * cp_t[ti])
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

        _CACHE[key] = _step
        return _step

    @njit(cache=True, fastmath=FASTMATH, parallel=True)
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
    ):
        n = x_old.shape[0]
        for i in prange(n):
            for a in range(3):
                f_new[i, a] = 0.0
            sig_max[i] = _NEG_INF
            conv[i] = 0
        # forces: each pair once, from its owner's half list, applied to both ends. The spheres sit in slabs at
        # least one pair reach wide, so a pair spans two neighbouring slabs at most; slabs of one colour (slab
        # number mod 3) share no sphere and run in parallel, each in sphere order: the same sums for any thread
        # count
        nslab = slab_start.size - 1
        for colour in range(min(nslab, 3)):
            for k in prange((nslab - colour + 2) // 3):
                s = colour + 3 * k
                for m in range(slab_start[s], slab_start[s + 1]):
                    _owner_pairs_previous(
                        slab_items[m],
                        x_old,
                        r,
                        types,
                        ids,
                        frozen,
                        half_start,
                        half_idx,
                        box,
                        periodic,
                        kpair,
                        hcoef,
                        sigp,
                        cut,
                        f_new,
                        sig_max,
                        conv,
                        FREEZE,
                        WALLS,
                    )
        half_dt2_m = 0.5 * dt * dt / mass
        for i in prange(n):
            ti = types[i]
            ri = r[i]
            is_frozen = False
            if FREEZE:
                is_frozen = frozen[i] != 0
            fx = f_new[i, 0]
            fy = f_new[i, 1]
            fz = f_new[i, 2]
            nforce = conv[i]
            smax = sig_max[i]
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
            decay = cm / cp_t[ti]
            kick = dt / (2.0 * mass * cp_t[ti])
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

    _CACHE[key] = _step
    return _step
