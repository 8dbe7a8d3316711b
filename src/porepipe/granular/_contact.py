"""Narrow phase and contact law of gc2d (Schinner 2001, §2.2.2, Fig. 2.4): numba helpers, no validation.

Overlap of two convex polygons by Sutherland-Hodgman clipping with edge tags: every edge of the working polygon
remembers whether it lies on the boundary of P (tag < 0) or on edge k of Q (tag k >= 0); a vertex whose incoming
and outgoing edges belong to different polygons is a boundary crossing point. Two crossings c1, c2 give the
contact line of Fig. 2.4.

With ``trim``, only the chains of P and Q that face each other along the centre line take part: the
facing corner of each polygon is found by climbing from the previous step's (a per-pair hint), P is cut to its
corners beyond Q's lowest one and clipped by Q's edges below P's highest one. In a dense pile that is 3-5
corners against 3-4 edges instead of 9 against 4-5. This is the default; without it, all of P is clipped by Q's
facing chain (the reference, equal to round-off: tests/unit/granular/test_narrow_phase.py).
"""

from __future__ import annotations

import math

from numba import njit

from porepipe._shared.numba_config import FASTMATH, NO_REFCOUNT

#: contact line shorter than this fraction of the overlap's extent counts as degenerate (fall-back normal)
_LINE_EPS = 1e-9


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _proj(ux, uy, V, k):
    return ux * V[k, 0] + uy * V[k, 1]


@njit(cache=True, fastmath=FASTMATH, inline="always", **NO_REFCOUNT)
def _clip_by_edge(src, stag, m, qx, qy, ex, ey, k, dst, dtag, side):
    """One Sutherland-Hodgman pass: the m corners of src (edge tags stag) cut by the line through (qx, qy) along
    (ex, ey), keeping its left side; the result goes to dst / dtag (count returned), the new edge gets tag k. Returns
    -1 (nothing written) when every corner is already on the left side.
    """
    lo = 0.0
    for v in range(m):
        dv = _cross(ex, ey, src[v, 0] - qx, src[v, 1] - qy)
        side[v] = dv
        lo = min(lo, dv)
    if lo >= 0.0:
        return -1
    out = 0
    ax = src[m - 1, 0]
    ay = src[m - 1, 1]
    ta = stag[m - 1]
    da = side[m - 1]
    for v in range(m):
        bx = src[v, 0]
        by = src[v, 1]
        db = side[v]
        if da >= 0.0:
            dst[out, 0] = ax
            dst[out, 1] = ay
            dtag[out] = ta
            out += 1
            if db < 0.0:
                t = da / (da - db)
                dst[out, 0] = ax + t * (bx - ax)
                dst[out, 1] = ay + t * (by - ay)
                dtag[out] = k
                out += 1
        elif db >= 0.0:
            t = da / (da - db)
            dst[out, 0] = ax + t * (bx - ax)
            dst[out, 1] = ay + t * (by - ay)
            dtag[out] = ta
            out += 1
        ax = bx
        ay = by
        ta = stag[v]
        da = db
    return out


@njit(cache=True, fastmath=FASTMATH, inline="always", **NO_REFCOUNT)
def _climb(ux, uy, V, n, k, sign):
    """Corner of convex V with the largest sign * u.x, found by climbing from corner k.

    The projections of a convex polygon's corners rise to one maximum and fall again, so a corner with no higher
    neighbour is the maximum; from the previous step's corner (the contact moved little) that takes 2-3
    projections instead of n. Of two tied corners (an edge across u) the lower index is returned, as a scan with
    a strict comparison would: the result does not depend on the starting corner.
    """
    if k < 0 or k >= n:
        k = 0
    d = sign * _proj(ux, uy, V, k)
    kn = k + 1 if k + 1 < n else 0
    dn = sign * _proj(ux, uy, V, kn)
    step = 1
    if not dn > d:
        kn = k - 1 if k > 0 else n - 1
        dn = sign * _proj(ux, uy, V, kn)
        step = -1
        if not dn > d:  # k is a maximum; its other neighbour may tie
            kp = k + 1 if k + 1 < n else 0
            if sign * _proj(ux, uy, V, kp) == d and kp < k:
                k = kp
            if dn == d and kn < k:
                k = kn
            return k
    for _ in range(n):
        k = kn
        d = dn
        kn = k + step
        if kn >= n:
            kn = 0
        elif kn < 0:
            kn = n - 1
        dn = sign * _proj(ux, uy, V, kn)
        if not dn > d:
            break
    if dn == d and kn < k:
        k = kn
    return k


@njit(cache=True, fastmath=FASTMATH, inline="always", **NO_REFCOUNT)
def _facing_run(ux, uy, V, n, start, level, sign):
    """The corners of convex V whose projection on u is on the far side of ``level`` (sign = +1: >= level, -1:
    <= level), grown from corner ``start`` (which is one of them), plus the one corner beyond each end: returns
    (first, count), the corners first, first + 1, ... (mod n). count = n when every corner is taken.
    """
    s = start
    cnt = 1
    while cnt < n:
        s = s - 1 if s > 0 else n - 1
        cnt += 1
        if sign * (_proj(ux, uy, V, s) - level) < 0.0:
            break
    e = start
    while cnt < n:
        e = e + 1 if e + 1 < n else 0
        cnt += 1
        if sign * (_proj(ux, uy, V, e) - level) < 0.0:
            break
    return s, cnt


@njit(cache=True, fastmath=FASTMATH, inline="always", **NO_REFCOUNT)
def _clip_polygons(P, n_p, Q, n_q, cqx, cqy, cpx, cpy, buf_a, tag_a, buf_b, tag_b, side, trim, hint):
    """Clip convex P (CCW, n_p corners) by convex Q (CCW); the result (count returned) is in buf_a / tag_a.

    Only the two facing chains take part. With u = cQ - cP, h = max over P of u.x and l = min over Q of u.x:
    if l > h the centre line separates them (no overlap, no clip). P n Q lies in the slab l <= u.x <= h. There Q
    equals the intersection of the half-planes of the edges with a corner at u.x <= h (the chain of Q facing P;
    the chain's two end edges leave the slab, so the others add nothing), so P n Q = P clipped by that chain.
    With ``trim``, P itself is first cut to its corners at u.x >= l plus one beyond each end (the closing chord
    lies at u.x < l, outside Q, and is clipped away whole; no new corner is made): for the small overlaps of a
    dense pile the working polygon shrinks from n_p corners to 3-5. Without it (the reference), all of P is
    clipped. The edges of Q are taken in order from Q's lowest corner, so the first one cuts P down first.
    """
    ux = cqx - cpx
    uy = cqy - cpy
    if trim:
        kh = _climb(ux, uy, P, n_p, hint[0], 1.0)
        kmin = _climb(ux, uy, Q, n_q, hint[1], -1.0)
        hint[0] = kh
        hint[1] = kmin
        h = _proj(ux, uy, P, kh)
        low = _proj(ux, uy, Q, kmin)
    else:
        h = -1e300
        kh = 0
        for k in range(n_p):
            d = _proj(ux, uy, P, k)
            if d > h:
                h = d
                kh = k
        low = 1e300
        kmin = 0
        for k in range(n_q):
            d = _proj(ux, uy, Q, k)
            if d < low:
                low = d
                kmin = k
    if low > h:
        return 0
    first, m = _facing_run(ux, uy, P, n_p, kh, low, 1.0) if trim else (0, n_p)
    for v in range(m):
        k = first + v
        if k >= n_p:
            k -= n_p
        buf_a[v, 0] = P[k, 0]
        buf_a[v, 1] = P[k, 1]
        tag_a[v] = -1 - k
    # Q's facing chain: corners qs, qs + 1, ... (nq of them), edges between them, in order from kmin
    qs, nq = _facing_run(ux, uy, Q, n_q, kmin, h, -1.0)
    last = qs + nq - 1 if qs + nq - 1 < n_q else qs + nq - 1 - n_q
    n_edges = nq - 1 if _proj(ux, uy, Q, qs) > h and _proj(ux, uy, Q, last) > h else nq  # closing edge far?
    off = kmin - qs if kmin >= qs else kmin + n_q - qs
    src, stag, dst, dtag = buf_a, tag_a, buf_b, tag_b
    for kk in range(n_edges):
        e = off + kk
        if e >= n_edges:
            e -= n_edges
        k = qs + e
        if k >= n_q:
            k -= n_q
        k1 = k + 1 if k + 1 < n_q else 0
        qx = Q[k, 0]
        qy = Q[k, 1]
        out = _clip_by_edge(src, stag, m, qx, qy, Q[k1, 0] - qx, Q[k1, 1] - qy, k, dst, dtag, side)
        if out < 0:
            continue  # the whole working polygon is inside this edge: nothing to clip, nothing to copy
        m = out
        src, stag, dst, dtag = dst, dtag, src, stag
        if m < 3:
            return 0
    if src is not buf_a:
        for v in range(m):
            buf_a[v, 0] = src[v, 0]
            buf_a[v, 1] = src[v, 1]
            tag_a[v] = stag[v]
    return m


@njit(cache=True, fastmath=FASTMATH, **NO_REFCOUNT)
def _overlap_geometry(
    W, i, n_p, j, n_q, cpx, cpy, cqx, cqy, buf_a, tag_a, buf_b, tag_b, side, out, trim, hints, p
):
    """Overlap of convex polygons P and Q: fills out = (A, c1x, c1y, c2x, c2y, sx, sy, gx, gy, ok_line, m).

    A is the overlap area (0 if they do not overlap), c1/c2 the two boundary crossings that are farthest apart,
    s their midpoint (the application point), g the overlap centroid, ok_line = 1 if c1c2 is a proper line
    (two crossings, not coincident) and 0 otherwise (one polygon inside the other, coincident polygons);
    out[10] = number of corners of the overlap polygon (left in buf_a). P = W[i] and Q = W[j] (world corners,
    n_p and n_q of them); ``trim`` selects the facing-chain clipping, ``hints[p]`` is the pair's search start,
    updated in place.
    """
    P = W[i]  # views made here, in a helper without reference counting, cost no atomic operations
    Q = W[j]
    m = _clip_polygons(P, n_p, Q, n_q, cqx, cqy, cpx, cpy, buf_a, tag_a, buf_b, tag_b, side, trim, hints[p])
    for k in range(11):
        out[k] = 0.0
    if m < 3:
        return
    out[10] = m
    ox = buf_a[0, 0]
    oy = buf_a[0, 1]
    a2 = 0.0
    gx = 0.0
    gy = 0.0
    for v in range(1, m - 1):
        x1 = buf_a[v, 0] - ox
        y1 = buf_a[v, 1] - oy
        x2 = buf_a[v + 1, 0] - ox
        y2 = buf_a[v + 1, 1] - oy
        c = x1 * y2 - x2 * y1
        a2 += c
        gx += c * (x1 + x2)
        gy += c * (y1 + y2)
    if a2 <= 0.0:
        return
    out[0] = 0.5 * a2
    out[7] = ox + gx / (3.0 * a2)
    out[8] = oy + gy / (3.0 * a2)
    # boundary crossings: incoming and outgoing edge tags from different polygons; keep the farthest pair (the
    # crossings met so far are listed in tag_b, free after the clipping: usually two in all)
    best = -1.0
    ext = 0.0
    n_cross = 0
    for v in range(m):
        tin = tag_a[v - 1] if v > 0 else tag_a[m - 1]
        dx = buf_a[v, 0] - out[7]
        dy = buf_a[v, 1] - out[8]
        ext = max(ext, dx * dx + dy * dy)
        if (tin < 0) == (tag_a[v] < 0):
            continue
        tag_b[n_cross] = v
        n_cross += 1
        for c in range(n_cross - 1):
            w = tag_b[c]
            dx = buf_a[v, 0] - buf_a[w, 0]
            dy = buf_a[v, 1] - buf_a[w, 1]
            d2 = dx * dx + dy * dy
            if d2 > best:
                best = d2
                out[1] = buf_a[w, 0]
                out[2] = buf_a[w, 1]
                out[3] = buf_a[v, 0]
                out[4] = buf_a[v, 1]
    if best > _LINE_EPS * _LINE_EPS * ext and best > 0.0:
        out[5] = 0.5 * (out[1] + out[3])
        out[6] = 0.5 * (out[2] + out[4])
        out[9] = 1.0
    else:
        out[5] = out[7]
        out[6] = out[8]


@njit(cache=True, fastmath=FASTMATH, **NO_REFCOUNT)
def _contact_frame(geo, xi, yi, xj, yj, j_is_wall, buf):
    """Normal n (from i to j), tangent t = n rotated by +90 deg, and contact-line length L; returns (nx, ny, L).

    With a proper contact line, n is perpendicular to c1c2. Otherwise (containment, coincident polygons) n is
    the centroid direction (or +y for coincident centroids) and L the overlap's width across n.
    """
    sx = geo[5]
    sy = geo[6]
    if geo[9] > 0.0:
        tx = geo[3] - geo[1]
        ty = geo[4] - geo[2]
        L = math.sqrt(tx * tx + ty * ty)
        nx = ty / L
        ny = -tx / L
        if j_is_wall:
            s = nx * (sx - xi) + ny * (sy - yi)
        else:
            s = nx * (xj - xi) + ny * (yj - yi)
        if s < 0.0:
            nx = -nx
            ny = -ny
        return nx, ny, L
    dx = xj - xi
    dy = yj - yi
    d = math.sqrt(dx * dx + dy * dy)
    if j_is_wall or d == 0.0:
        dx = sx - xi
        dy = sy - yi
        d = math.sqrt(dx * dx + dy * dy)
    if d > 0.0:
        nx = dx / d
        ny = dy / d
    else:
        nx = 0.0
        ny = 1.0
    lo = 1e300
    hi = -1e300
    for v in range(int(geo[10])):
        p = -ny * buf[v, 0] + nx * buf[v, 1]
        lo = min(lo, p)
        hi = max(hi, p)
    return nx, ny, max(hi - lo, 0.0)


def _inlined(kernel):
    """``kernel`` compiled once more, to be inlined into its caller at numba IR level: for the step kernel's
    contact helper, which has no reference counting either, so that nothing is passed per pair.
    """
    return njit(cache=True, fastmath=FASTMATH, inline="always", **NO_REFCOUNT)(kernel.py_func)


_overlap_geometry_inlined = _inlined(_overlap_geometry)
