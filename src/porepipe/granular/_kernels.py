"""numba kernels of the granular stage: the time-step loop, built by a factory from the scene's effect set.

Only ``_``-prefixed kernels and the factory live here: arrays in, preallocated arrays out, no validation.

Body arrays hold the mobile particles first (indices < n_mob) and the walls after them. Gear state
``G[n, i, d]`` holds the scaled derivatives r_n = dt^n/n! d^n q/dt^n of q = (x, y, phi) (Eq. F.10); velocity
Verlet uses G[0..2] with the same scaling. Candidate pairs (i < j, i mobile) are a CSR list by i, sorted by j;
their per-contact state (tangential spring ``ft`` in N and previous overlap ``aold`` in m²) is pair-indexed.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_cache import key_closure_kernels_by_name
from porepipe._shared.numba_config import FASTMATH, NO_REFCOUNT
from porepipe.granular._contact import _contact_frame, _overlap_geometry_inlined

#: Tab. F.1, p = 2 (second-order ODE), six values: corrector coefficients c_0..c_5
GEAR_C = (3.0 / 20.0, 251.0 / 360.0, 1.0, 11.0 / 18.0, 1.0 / 6.0, 1.0 / 60.0)
#: particles per work block of the parallel pair loop (each block owns its clipping buffers)
BLOCK = 32
#: columns of the per-pair output array
POUT = ("fx_N", "fy_N", "torque_i_Nm", "torque_j_Nm", "sx_m", "sy_m", "fn_N", "ft_N", "area_m2", "length_m")
#: return codes of the step loop
DONE, REBUILD, GUARD_OVERLAP, GUARD_NAN, GUARD_MOVE = 0, 1, 2, 3, 4

G0, G1, G2, G3, G4, G5 = GEAR_C


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _place(body, nc, x, y, phi, wv, aabb, i, scale=1.0):
    """World corners (scaled about the centroid, CCW rotation by phi, then shift) and bounding box of body i."""
    c = math.cos(phi) * scale
    s = math.sin(phi) * scale
    lox = 1e300
    hix = -1e300
    loy = 1e300
    hiy = -1e300
    for k in range(nc[i]):
        bx = body[i, k, 0]
        by = body[i, k, 1]
        wx = x + c * bx - s * by
        wy = y + s * bx + c * by
        wv[i, k, 0] = wx
        wv[i, k, 1] = wy
        lox = min(lox, wx)
        hix = max(hix, wx)
        loy = min(loy, wy)
        hiy = max(hiy, wy)
    aabb[i, 0] = lox
    aabb[i, 1] = hix
    aabb[i, 2] = loy
    aabb[i, 3] = hiy


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _part(p, ft, aold, pout):
    """Pair p does not touch: clear its spring, previous overlap and output row, unless they are clear already.

    A touching pair writes its whole row and an aold > 0, so aold = 0 means a zero row and spring (also after a
    list build or a restore: the row travels with aold). Touching pairs thus skip the clearing, and a pair that
    stays apart clears once.
    """
    if aold[p] != 0.0:
        ft[p] = 0.0
        aold[p] = 0.0
        for c in range(10):
            pout[p, c] = 0.0


@njit(cache=True, fastmath=FASTMATH)
def _vibration(kind, amp, freq, t):
    """Wall offset A(t) and its rate dA/dt (App. B.1.5.2): 1 COSINUS, 2 SAWTOOTH, 3 TAPPING, 4 TRIANGLE."""
    w = 2.0 * math.pi * freq
    if kind == 1:
        return amp * 0.5 * (1.0 - math.cos(w * t)), amp * 0.5 * w * math.sin(w * t)
    if kind == 2:
        return amp * ((t * freq) % 1.0), amp * freq
    if kind == 3:
        s = math.sin(w * t)
        return amp * s**30, amp * 30.0 * s**29 * math.cos(w * t) * w
    if kind == 4:
        a = (t * freq) % 1.0
        if a < 0.5:
            return 2.0 * amp * a, 2.0 * amp * freq
        return 2.0 * amp * (1.0 - a), -2.0 * amp * freq
    return 0.0, 0.0


@njit(cache=True, fastmath=FASTMATH)
def _gravity_scale(gp, t):
    """g(t)/g of App. B.1.2.2: gp = (kind, g1, g2, t1, t2, steps, ramp); 0 CONSTANT, 1 LINEAR, 2 STEP, 3 SMOOTH."""
    kind = int(gp[0])
    g1 = gp[1]
    g2 = gp[2]
    if kind == 0:
        return g1
    t1 = gp[3]
    t2 = gp[4]
    if t <= t1:
        return g1
    if t >= t2:
        return g2
    u = (t - t1) / (t2 - t1)
    if kind == 1:
        return g1 + (g2 - g1) * u
    n = max(gp[5], 1.0)
    ramp = gp[6] if kind == 3 else 0.0
    k = math.floor(u * n)
    f = u * n - k  # position within step k
    level = k
    if ramp > 0.0 and f > 1.0 - ramp:
        level = k + (f - (1.0 - ramp)) / ramp
    return g1 + (g2 - g1) * min(level / n, 1.0)


@njit(cache=True, fastmath=FASTMATH)
def _size_scale(hp, t):
    """s(t) = 1 + a (1/2 - 1/2 tanh(S cos(2 pi f t))) of Eq. B.1, t clamped to [t1, t2]; hp = (a, f, S, t1, t2)."""
    tt = min(max(t, hp[3]), hp[4])
    return 1.0 + hp[0] * (0.5 - 0.5 * math.tanh(hp[2] * math.cos(2.0 * math.pi * hp[1] * tt)))


#: columns of the piston array: flag, direction (x, y), force N, 1/mass, v_max, displacement s, speed, s at build
PISTON_COLS = 9

_STEPPERS: dict = {}


def make_stepper(
    cohesion: bool,
    weakening: bool,
    vibration: bool,
    variable_gravity: bool,
    drag: bool,
    surface_velocity: bool,
    piston: bool = False,
    size_change: bool = False,
    *,
    trim: bool = True,
):
    """Return the step-loop kernel compiled with exactly the requested effects (closure constants).

    The integrator (Gear or velocity Verlet) is a run-time argument ``gear`` of the kernel: it is not an effect,
    and its branch per particle costs nothing next to the contacts.

    Parameters
    ----------
    cohesion : bool
        Cohesive force k_coh x contact-line length (Eq. 2.28).
    weakening : bool
        Velocity-weakening friction mu (|v_t| / 1 m/s)^(-1/10) F_n (Eq. 2.25), |v_t| floored at v_min.
    vibration : bool
        Walls move by a prescribed waveform (App. B.1.5.2).
    variable_gravity : bool
        g(t) of App. B.1.2.2 instead of a constant vector.
    drag : bool
        Drag springs on particles (App. B.1.4.2).
    surface_velocity : bool
        Walls with a tangential surface velocity (conveyor belt, drum).
    piston : bool
        Force-controlled piston walls (App. B.1.5.1), integrated by symplectic Euler with a speed cap.
    size_change : bool
        Global particle size s(t) (Eqs. 2.30-2.32): corners x s, l x s, moment of inertia x s².
    trim : bool
        Narrow phase: True (the default) cuts each polygon to its facing chain before clipping (see
        :func:`porepipe.granular._contact._clip_polygons`; 1.1x per CPU-s on the benchmark's pile, equal to the
        whole-polygon clipping to round-off: tests/unit/granular/test_narrow_phase.py). False clips the whole
        polygon (the reference). Round-off changes a dense pile's realisation, so the slow silo tests compare
        with the thesis within tolerances that allow the seed-to-seed scatter (tests/unit/granular/
        test_shaped_silos.py).

    Returns
    -------
    callable
        ``_steps(...) -> (steps_done, code)``; see :func:`porepipe.granular._api.Simulation` for its arguments.
    """
    key = (
        bool(cohesion),
        bool(weakening),
        bool(vibration),
        bool(variable_gravity),
        bool(drag),
        bool(surface_velocity),
        bool(piston),
        bool(size_change),
        bool(trim),
    )
    if key in _STEPPERS:
        return _STEPPERS[key]
    COH, WEAK, VIB, VARG, DRAG, SURF, PIST, SIZE, TRIM = key

    @njit(cache=True, fastmath=FASTMATH, **NO_REFCOUNT)
    def _block_contacts(
        blk,
        G,
        nc,
        wv,
        aabb,
        inv_m,
        inv_I,
        inv_r,
        active,
        n_mob,
        surf,
        nb_start,
        nb_j,
        ft,
        aold,
        hint,
        pout,
        scratch,
        bufs_a,
        bufs_b,
        tags_a,
        tags_b,
        sides,
        geos,
        wall_vel,
        mat,
        dt,
        sc,
        isc2,
    ):
        """The contacts of the pairs owned by block blk's particles (section 2 of the step): a helper without
        reference counting, so that its views and the narrow phase inlined into it cost no atomic operations.
        """
        E = mat[0]
        gam = mat[1]
        mu = mat[2]
        gam_t = mat[3]
        kcoh = mat[4]
        vmin = mat[5]
        centroid = mat[8] != 0.0  # force at the overlap centroid instead of the midpoint of c1c2
        kt = 2.0 / 7.0 * E
        sqE = math.sqrt(E)
        buf_a = bufs_a[blk]
        buf_b = bufs_b[blk]
        tag_a = tags_a[blk]
        tag_b = tags_b[blk]
        side = sides[blk]
        geo = geos[blk]
        for i in range(blk * BLOCK, min((blk + 1) * BLOCK, n_mob)):
            for p in range(nb_start[i], nb_start[i + 1]):
                j = nb_j[p]
                if (
                    active[i] == 0
                    or active[j] == 0
                    or aabb[i, 1] < aabb[j, 0]
                    or aabb[j, 1] < aabb[i, 0]
                    or aabb[i, 3] < aabb[j, 2]
                    or aabb[j, 3] < aabb[i, 2]
                ):
                    _part(p, ft, aold, pout)
                    continue
                xi = G[0, i, 0]
                yi = G[0, i, 1]
                xj = G[0, j, 0]
                yj = G[0, j, 1]
                _overlap_geometry_inlined(
                    wv,
                    i,
                    nc[i],
                    j,
                    nc[j],
                    xi,
                    yi,
                    xj,
                    yj,
                    buf_a,
                    tag_a,
                    buf_b,
                    tag_b,
                    side,
                    geo,
                    TRIM,
                    hint,
                    p,
                )
                A = geo[0]
                if A <= 0.0:
                    _part(p, ft, aold, pout)
                    continue
                wall = j >= n_mob
                nx, ny, L = _contact_frame(geo, xi, yi, xj, yj, wall, buf_a)
                tx = -ny
                ty = nx
                if centroid:
                    sx = geo[7]
                    sy = geo[8]
                else:
                    sx = geo[5]
                    sy = geo[6]
                rix = sx - xi
                riy = sy - yi
                rjx = sx - xj
                rjy = sy - yj
                wi = G[1, i, 2] / dt
                vix = G[1, i, 0] / dt - wi * riy
                viy = G[1, i, 1] / dt + wi * rix
                if wall:
                    vjx = wall_vel[j, 0]
                    vjy = wall_vel[j, 1]
                    if SURF:
                        vjx -= surf[j] * tx
                        vjy -= surf[j] * ty
                else:
                    wj = G[1, j, 2] / dt
                    vjx = G[1, j, 0] / dt - wj * rjy
                    vjy = G[1, j, 1] / dt + wj * rjx
                vt = (vix - vjx) * tx + (viy - vjy) * ty
                ell = 1.0 / (inv_r[i] + inv_r[j])
                if SIZE:
                    ell *= sc
                fel = E * A / ell
                m_n = 1.0 / (inv_m[i] + inv_m[j])
                damp = gam * sqE * math.sqrt(m_n) * (A - aold[p]) / (ell * dt)
                fn = fel + max(damp, -fel)
                if COH:
                    fn -= kcoh * L
                # tangential: Cundall-Strack spring 2/7 E, damping sqrt(2/7 E m_t), Coulomb cap
                ai = rix * nx + riy * ny  # lever arm of a tangential force: r x t = r . n
                aj = rjx * nx + rjy * ny
                m_t = 1.0 / (inv_m[i] + inv_m[j] + (ai * ai * inv_I[i] + aj * aj * inv_I[j]) * isc2)
                cap = mu * fel
                if WEAK:
                    cap *= max(abs(vt), vmin) ** -0.1
                spring = ft[p] + kt * vt * dt
                dtan = gam_t * math.sqrt(kt * m_t) * vt
                f_t = spring + dtan
                if abs(f_t) > cap:
                    f_t = math.copysign(cap, f_t)
                    spring = f_t
                ft[p] = spring
                aold[p] = A
                fx = -fn * nx - f_t * tx
                fy = -fn * ny - f_t * ty
                pout[p, 0] = fx
                pout[p, 1] = fy
                pout[p, 2] = rix * fy - riy * fx
                pout[p, 3] = -(rjx * fy - rjy * fx)
                pout[p, 4] = sx
                pout[p, 5] = sy
                pout[p, 6] = fn
                pout[p, 7] = f_t
                pout[p, 8] = A
                pout[p, 9] = L
                ov = A * max(inv_r[i], inv_r[j]) ** 2 * isc2  # overlap relative to the smaller one
                scratch[i, 4] = max(scratch[i, 4], ov)

    @njit(cache=True, fastmath=FASTMATH, parallel=True)
    def _steps(
        G,
        body,
        nc,
        wv,
        aabb,
        inv_m,
        inv_I,
        inv_r,
        area,
        active,
        n_mob,
        wall_base,
        wall_vib,
        surf,
        nb_start,
        nb_j,
        tr_start,
        tr_p,
        ft,
        aold,
        hint,
        pout,
        x_build,
        scratch,
        mat,
        gvec,
        gpar,
        drag_par,
        t0,
        dt,
        nsteps,
        skin_half,
        gear,
        diag,
        piston,
        heat,
    ):
        n_body = nc.shape[0]
        guard_ov = mat[6]
        guard_move = mat[7]
        n_blocks = (n_mob + BLOCK - 1) // BLOCK
        kmax = body.shape[1]
        half_dt2 = 0.5 * dt * dt
        # clipping buffers of each work block, allocated once per call (not per block and step)
        bufs_a = np.empty((n_blocks, 2 * kmax + 4, 2))
        bufs_b = np.empty((n_blocks, 2 * kmax + 4, 2))
        tags_a = np.empty((n_blocks, 2 * kmax + 4), np.int64)
        tags_b = np.empty((n_blocks, 2 * kmax + 4), np.int64)
        sides = np.empty((n_blocks, 2 * kmax + 4))
        geos = np.empty((n_blocks, 11))
        wall_vel = np.zeros((n_body, 2))
        if PIST:
            for w in range(n_mob, n_body):
                wall_vel[w, 0] = piston[w, 7] * piston[w, 1]
                wall_vel[w, 1] = piston[w, 7] * piston[w, 2]
        for step in range(nsteps):
            t = t0 + (step + 1) * dt  # time of the state being computed
            gx = gvec[0]
            gy = gvec[1]
            sc = 1.0
            isc2 = 1.0
            if SIZE:
                sc = _size_scale(heat, t)
                isc2 = 1.0 / (sc * sc)
            if VARG:
                gs = _gravity_scale(gpar, t)
                gx *= gs
                gy *= gs
            # 1. predictor and placement of the mobile particles
            for i in prange(n_mob):
                if active[i] == 0:
                    continue
                if gear:
                    for d in range(3):
                        r0 = G[0, i, d]
                        r1 = G[1, i, d]
                        r2 = G[2, i, d]
                        r3 = G[3, i, d]
                        r4 = G[4, i, d]
                        r5 = G[5, i, d]
                        G[0, i, d] = r0 + r1 + r2 + r3 + r4 + r5
                        G[1, i, d] = r1 + 2.0 * r2 + 3.0 * r3 + 4.0 * r4 + 5.0 * r5
                        G[2, i, d] = r2 + 3.0 * r3 + 6.0 * r4 + 10.0 * r5
                        G[3, i, d] = r3 + 4.0 * r4 + 10.0 * r5
                        G[4, i, d] = r4 + 5.0 * r5
                else:
                    for d in range(3):
                        G[0, i, d] += G[1, i, d] + G[2, i, d]
                        G[1, i, d] += G[2, i, d]  # v(t + dt/2) dt
                if SIZE:
                    _place(body, nc, G[0, i, 0], G[0, i, 1], G[0, i, 2], wv, aabb, i, sc)
                else:
                    _place(body, nc, G[0, i, 0], G[0, i, 1], G[0, i, 2], wv, aabb, i)
            if VIB:
                for w in range(n_mob, n_body):
                    kind = int(wall_vib[w, 0])
                    if kind == 0:
                        continue
                    tt = min(max(t, wall_vib[w, 5]), wall_vib[w, 6]) - wall_vib[w, 5]
                    a, da = _vibration(kind, wall_vib[w, 1], wall_vib[w, 2], tt)
                    if t < wall_vib[w, 5] or t > wall_vib[w, 6]:
                        da = 0.0
                    G[0, w, 0] = wall_base[w, 0] + a * wall_vib[w, 3]
                    G[0, w, 1] = wall_base[w, 1] + a * wall_vib[w, 4]
                    wall_vel[w, 0] = da * wall_vib[w, 3]
                    wall_vel[w, 1] = da * wall_vib[w, 4]
                    _place(body, nc, G[0, w, 0], G[0, w, 1], G[0, w, 2], wv, aabb, w)
            # 2. contacts, pair by pair (each pair owned by its lower index i)
            # np.int64: the parallel loop's index may be unsigned, which compiled _block_contacts twice (~20 CPU-s)
            for blk in prange(n_blocks):
                _block_contacts(
                    np.int64(blk),
                    G,
                    nc,
                    wv,
                    aabb,
                    inv_m,
                    inv_I,
                    inv_r,
                    active,
                    n_mob,
                    surf,
                    nb_start,
                    nb_j,
                    ft,
                    aold,
                    hint,
                    pout,
                    scratch,
                    bufs_a,
                    bufs_b,
                    tags_a,
                    tags_b,
                    sides,
                    geos,
                    wall_vel,
                    mat,
                    dt,
                    sc,
                    isc2,
                )
            # 3. forces on each particle (fixed summation order: own pairs, then pairs where it is j), corrector
            if DRAG:
                for s in range(drag_par.shape[0]):
                    k = int(drag_par[s, 0])
                    c = math.cos(G[0, k, 2])
                    sn = math.sin(G[0, k, 2])
                    ax = G[0, k, 0] + c * drag_par[s, 1] - sn * drag_par[s, 2]
                    ay = G[0, k, 1] + sn * drag_par[s, 1] + c * drag_par[s, 2]
                    tt = min(max(t, drag_par[s, 7]), drag_par[s, 8]) - drag_par[s, 7]
                    ex = drag_par[s, 3] + drag_par[s, 5] * tt
                    ey = drag_par[s, 4] + drag_par[s, 6] * tt
                    fx = drag_par[s, 9] * (ex - ax)
                    fy = drag_par[s, 9] * (ey - ay)
                    scratch[k, 0] += fx
                    scratch[k, 1] += fy
                    scratch[k, 2] += (ax - G[0, k, 0]) * fy - (ay - G[0, k, 1]) * fx
            if PIST:
                far_w = 0.0
                for w in range(n_mob, n_body):
                    if piston[w, 0] == 0.0:
                        continue
                    f = piston[w, 3]
                    for i in range(n_mob):  # the wall's pairs close each row (walls have the top indices)
                        p = nb_start[i + 1] - 1
                        while p >= nb_start[i] and nb_j[p] >= n_mob:
                            if nb_j[p] == w:
                                f -= pout[p, 0] * piston[w, 1] + pout[p, 1] * piston[w, 2]
                            p -= 1
                    v = piston[w, 7] + f * piston[w, 4] * dt
                    v = min(max(v, -piston[w, 5]), piston[w, 5])
                    piston[w, 7] = v
                    piston[w, 6] += v * dt
                    far_w = max(far_w, abs(piston[w, 6] - piston[w, 8]))
                    G[0, w, 0] = wall_base[w, 0] + piston[w, 6] * piston[w, 1]
                    G[0, w, 1] = wall_base[w, 1] + piston[w, 6] * piston[w, 2]
                    wall_vel[w, 0] = v * piston[w, 1]
                    wall_vel[w, 1] = v * piston[w, 2]
                    _place(body, nc, G[0, w, 0], G[0, w, 1], G[0, w, 2], wv, aabb, w)
            for i in prange(n_mob):
                if active[i] == 0:
                    continue
                fx = scratch[i, 0]
                fy = scratch[i, 1]
                tq = scratch[i, 2]
                for p in range(nb_start[i], nb_start[i + 1]):
                    fx += pout[p, 0]
                    fy += pout[p, 1]
                    tq += pout[p, 2]
                for q in range(tr_start[i], tr_start[i + 1]):
                    p = tr_p[q]
                    fx -= pout[p, 0]
                    fy -= pout[p, 1]
                    tq += pout[p, 3]
                acc0 = half_dt2 * (fx * inv_m[i] + gx)
                acc1 = half_dt2 * (fy * inv_m[i] + gy)
                acc2 = half_dt2 * tq * inv_I[i] * isc2
                for d in range(3):
                    a = acc0 if d == 0 else (acc1 if d == 1 else acc2)
                    if gear:
                        corr = a - G[2, i, d]
                        G[0, i, d] += G0 * corr
                        G[1, i, d] += G1 * corr
                        G[2, i, d] = a
                        G[3, i, d] += G3 * corr
                        G[4, i, d] += G4 * corr
                        G[5, i, d] += G5 * corr
                    else:
                        G[1, i, d] += a
                        G[2, i, d] = a
                dx = G[0, i, 0] - x_build[i, 0]
                dy = G[0, i, 1] - x_build[i, 1]
                scratch[i, 3] = dx * dx + dy * dy
                mv = abs(G[1, i, 0]) + abs(G[1, i, 1]) + abs(G[1, i, 2]) * math.sqrt(area[i] / math.pi)
                scratch[i, 5] = mv
                for c in range(3):
                    scratch[i, c] = 0.0
            # 4. guards and the rebuild test (serial reductions)
            worst_ov = 0.0
            worst_mv = 0.0
            far = 0.0
            bad = -1
            wi_ov = -1
            wi_mv = -1
            for i in range(n_mob):
                if active[i] == 0:
                    continue
                v = G[0, i, 0] + G[0, i, 1] + G[0, i, 2] + G[1, i, 0] + G[1, i, 1] + G[1, i, 2]
                if not math.isfinite(v):
                    bad = i
                if scratch[i, 4] > worst_ov:
                    worst_ov = scratch[i, 4]
                    wi_ov = i
                if scratch[i, 5] > worst_mv:
                    worst_mv = scratch[i, 5]
                    wi_mv = i
                far = max(far, scratch[i, 3])
                scratch[i, 4] = 0.0
            diag[0] = step + 1
            diag[3] = max(diag[3], worst_ov)
            if bad >= 0:
                diag[1] = bad
                return step + 1, GUARD_NAN
            if worst_ov > guard_ov:
                diag[1] = wi_ov
                diag[2] = worst_ov
                return step + 1, GUARD_OVERLAP
            if worst_mv > guard_move:
                diag[1] = wi_mv
                diag[2] = worst_mv
                return step + 1, GUARD_MOVE
            if far > skin_half * skin_half:
                return step + 1, REBUILD
            if PIST:
                if far_w > skin_half:  # the wall boxes are padded by skin/2 for the piston's travel
                    return step + 1, REBUILD
        return nsteps, DONE

    _STEPPERS[key] = key_closure_kernels_by_name(_steps)  # it captures _block_contacts
    return _STEPPERS[key]
