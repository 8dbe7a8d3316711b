"""Slow, obviously-right references for the granular stage (numpy, no numba)."""

import numpy as np


def _inside(pt, poly, tol=1e-12):
    """Point in (or on) a CCW convex polygon."""
    e = np.roll(poly, -1, axis=0) - poly
    d = pt - poly
    return bool(np.all(e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0] >= -tol))


def _seg_intersections(p, q):
    out = []
    for a, b in zip(p, np.roll(p, -1, axis=0), strict=True):
        for c, d in zip(q, np.roll(q, -1, axis=0), strict=True):
            r, s = b - a, d - c
            den = r[0] * s[1] - r[1] * s[0]
            if abs(den) < 1e-15:
                continue
            t = ((c - a)[0] * s[1] - (c - a)[1] * s[0]) / den
            u = ((c - a)[0] * r[1] - (c - a)[1] * r[0]) / den
            if 0 <= t <= 1 and 0 <= u <= 1:
                out.append(a + t * r)
    return np.array(out).reshape(-1, 2)


def _cross2(a, b):
    return a[0] * b[1] - a[1] * b[0]


def _hull(points):
    pts = sorted(map(tuple, points))
    if len(pts) < 3:
        return np.array(pts)

    def half(seq):
        h = []
        for p in seq:
            while len(h) >= 2 and _cross2(np.subtract(h[-1], h[-2]), np.subtract(p, h[-2])) <= 0:
                h.pop()
            h.append(p)
        return h

    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def overlap(p, q):
    """Area of the intersection of two CCW convex polygons, and their boundary crossing points.

    The intersection is the convex hull of p's corners inside q, q's corners inside p and all edge-edge
    crossings; the crossings are found by testing every edge pair.
    """
    cross = _seg_intersections(p, q)
    pts = [v for v in p if _inside(v, q)] + [v for v in q if _inside(v, p)] + list(cross)
    if len(pts) < 3:
        return 0.0, cross
    h = _hull(np.array(pts))
    if len(h) < 3:
        return 0.0, cross
    x, y = h[:, 0], h[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)), cross


def square(a):
    h = 0.5 * a
    return [(-h, -h), (h, -h), (h, h), (-h, h)]


def simulation(particles, walls=(), **settings):
    """A Simulation of explicitly given particles and walls (no gravity unless given)."""
    from porepipe.granular import Settings, Simulation

    settings.setdefault("gravity_m_s2", (0.0, 0.0))
    s = Settings.model_validate(dict(particles=list(particles), walls=list(walls), **settings))
    return Simulation(s, seed=0)


def floor(width=1.0, top=0.0, depth=0.1):
    return {
        "name": "floor",
        "vertices_m": [(-width, top - depth), (width, top - depth), (width, top), (-width, top)],
    }
