"""Numba kernels: grey values (6³ sample points per voxel in the matrix) of a union of spheres and convex polyhedra.

Sample point k (0..5) of voxel i along an axis sits at ``(6*i + k + 0.5) * (a/6)`` (the foundation's
:func:`porepipe._shared.sample_points.sample_coord`). A point p is in polyhedral grain g (centre c) when
``(n0*dx + n1*dy) + n2*dz <= d`` for every plane (n, d) of g, with dx = p_x - c_x etc., in exactly this order of
operations; in a sphere when ``(dx*dx + dy*dy) + dz*dz <= r*r`` (as in the foundation).

Boundary-only classification of a voxel against a plane: over the 6 sample coordinates of an axis, the products
n0*dx take their extremes at the first and last sample point (IEEE rounding is monotone), and so does the rounded sum;
so max_p f(p) over the voxel's 216 points is bounded by the same sum of the per-axis maxima. A voxel with this bound
<= d - margin for every plane is wholly inside, one with the minimum > d + margin for some plane wholly outside; all
others are sampled point by point, with the same expression as brute force: the grey values are bit-identical.
"""

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH
from porepipe._shared.sample_points import (
    FULL,
    MARGIN,
    PARTIAL,
    SUB,
    UNTOUCHED,
    WORDS,
    axis_range,
    grey_from_status,
    hull_gap,
    or_row,
    plane_candidates,
    sample_coord,
)

KIND_SPHERE = 0
KIND_POLYHEDRON = 1


@njit(cache=True, fastmath=FASTMATH)
def _sphere_points(words, i, j, k, cx, cy, cz, r2, h, skip_rows, scratch):
    """OR into ``words`` the sample points of voxel (i, j, k) inside the ball (c, r²)."""
    for s in range(SUB):
        dx = sample_coord(i, s, h) - cx
        dy = sample_coord(j, s, h) - cy
        dz = sample_coord(k, s, h) - cz
        scratch[0, s] = dx * dx
        scratch[1, s] = dy * dy
        scratch[2, s] = dz * dz
    for sx in range(SUB):
        for sy in range(SUB):
            dxy = scratch[0, sx] + scratch[1, sy]
            if skip_rows and dxy > r2:
                continue
            row = 0
            for sz in range(SUB):
                if dxy + scratch[2, sz] <= r2:
                    row |= 1 << sz
            or_row(words, sx, sy, row)


@njit(cache=True, fastmath=FASTMATH)
def _poly_points(words, i, j, k, cx, cy, cz, planes, active, n_active, h, partial):
    """OR into ``words`` the sample points of voxel (i, j, k) inside every plane ``planes[active[:n_active]]`` about c."""
    for sx in range(SUB):
        dx = sample_coord(i, sx, h) - cx
        for sy in range(SUB):
            dy = sample_coord(j, sy, h) - cy
            for t in range(n_active):
                p = active[t]
                partial[t] = planes[p, 0] * dx + planes[p, 1] * dy
            row = 0
            for sz in range(SUB):
                dz = sample_coord(k, sz, h) - cz
                inside = True
                for t in range(n_active):
                    p = active[t]
                    if partial[t] + planes[p, 2] * dz > planes[p, 3]:
                        inside = False
                        break
                if inside:
                    row |= 1 << sz
            or_row(words, sx, sy, row)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _extremes(n, lo, hi):
    """(min, max) of n*lo and n*hi."""
    a = n * lo
    b = n * hi
    return (a, b) if a <= b else (b, a)


@njit(cache=True, fastmath=FASTMATH)
def _xy_bounds(i, j, cx, cy, planes, p0, p1, h, xy):
    """Per plane t = p - p0 of the grain: xy[t, 0] = min, xy[t, 1] = max of (n0*dx + n1*dy) bound over the sample hull
    of column (i, j), summed in the kernels' order.
    """
    dxl = sample_coord(i, 0, h) - cx
    dxh = sample_coord(i, SUB - 1, h) - cx
    dyl = sample_coord(j, 0, h) - cy
    dyh = sample_coord(j, SUB - 1, h) - cy
    for p in range(p0, p1):
        xl, xh = _extremes(planes[p, 0], dxl, dxh)
        yl, yh = _extremes(planes[p, 1], dyl, dyh)
        xy[p - p0, 0] = xl + yl
        xy[p - p0, 1] = xh + yh


@njit(cache=True, fastmath=FASTMATH)
def _classify_poly(k, cz, planes, p0, p1, h, margin, xy, active):
    """(UNTOUCHED, 0) if the voxel's sample hull is outside some plane, (FULL, 0) if inside all, else (PARTIAL, m)
    with ``active[:m]`` the planes the hull crosses: every sample point satisfies the others, so only these are
    tested point by point. ``xy`` comes from :func:`_xy_bounds` for the voxel's column.
    """
    dzl = sample_coord(k, 0, h) - cz
    dzh = sample_coord(k, SUB - 1, h) - cz
    m = 0
    for p in range(p0, p1):
        zl, zh = _extremes(planes[p, 2], dzl, dzh)
        if xy[p - p0, 0] + zl > planes[p, 3] + margin:
            return UNTOUCHED, 0
        if xy[p - p0, 1] + zh > planes[p, 3] - margin:
            active[m] = p
            m += 1
    return (FULL, 0) if m == 0 else (PARTIAL, m)


@njit(cache=True, fastmath=FASTMATH)
def _classify_sphere(i, j, k, cx, cy, cz, r2, h):
    nx_, fx_ = hull_gap(cx, i, h)
    ny_, fy_ = hull_gap(cy, j, h)
    nz_, fz_ = hull_gap(cz, k, h)
    if nx_ * nx_ + ny_ * ny_ + nz_ * nz_ > r2 * (1.0 + MARGIN):
        return UNTOUCHED
    if fx_ * fx_ + fy_ * fy_ + fz_ * fz_ <= r2 * (1.0 - MARGIN):
        return FULL
    return PARTIAL


@njit(cache=True, fastmath=FASTMATH)
def _grain_plane(
    i,
    img_pos,
    img_grain,
    order,
    xmin_sorted,
    hx_max,
    kind,
    radius,
    plane_ptr,
    planes,
    h,
    ny,
    nz,
    boundary_only,
    status,
    mask,
    scratch,
    partial,
    active,
    xy,
    words,
    out,
):
    """Grey values of voxel plane x = i into ``out`` (ny, nz); the other arrays are this thread's buffers."""
    status[:, :] = UNTOUCHED
    plane_lo, first, last = plane_candidates(i, h, xmin_sorted, hx_max)
    for q in range(first, last):
        s = order[q]
        cx, cy, cz = img_pos[s, 0], img_pos[s, 1], img_pos[s, 2]
        if cx + img_pos[s, 3] < plane_lo:
            continue
        g = img_grain[s]
        r = radius[g]
        r2 = r * r
        p0, p1 = plane_ptr[g], plane_ptr[g + 1]
        margin = MARGIN * (r + SUB * h)
        j0, j1 = axis_range(cy, img_pos[s, 4], h, ny)
        k0, k1 = axis_range(cz, img_pos[s, 5], h, nz)
        for j in range(j0, j1):
            if boundary_only and kind[g] == KIND_POLYHEDRON:
                _xy_bounds(i, j, cx, cy, planes, p0, p1, h, xy)
            for k in range(k0, k1):
                if status[j, k] == FULL:
                    continue
                n_active = p1 - p0
                if boundary_only:
                    if kind[g] == KIND_SPHERE:
                        cls = _classify_sphere(i, j, k, cx, cy, cz, r2, h)
                    else:
                        cls, n_active = _classify_poly(k, cz, planes, p0, p1, h, margin, xy, active)
                    if cls == UNTOUCHED:
                        continue
                    if cls == FULL:
                        status[j, k] = FULL
                        continue
                if status[j, k] == UNTOUCHED:
                    for w in range(WORDS):
                        mask[j, k, w] = 0
                    status[j, k] = PARTIAL
                for w in range(WORDS):
                    words[w] = 0
                if kind[g] == KIND_SPHERE:
                    _sphere_points(words, i, j, k, cx, cy, cz, r2, h, boundary_only, scratch)
                else:
                    if not boundary_only:
                        for t in range(n_active):
                            active[t] = p0 + t
                    _poly_points(words, i, j, k, cx, cy, cz, planes, active, n_active, h, partial)
                for w in range(WORDS):
                    mask[j, k, w] |= words[w]
    grey_from_status(status, mask, out)


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _voxelize_grains_slab(
    i0,
    i1,
    img_pos,
    img_grain,
    order,
    xmin_sorted,
    hx_max,
    kind,
    radius,
    plane_ptr,
    planes,
    max_planes,
    h,
    ny,
    nz,
    boundary_only,
    out,
):
    """Grey values of planes i0..i1-1 into ``out`` (i1 - i0, ny, nz), parallel over planes."""
    nplanes = i1 - i0
    nthreads = min(nplanes, 64)
    per = (nplanes + nthreads - 1) // nthreads
    for t in prange(nthreads):
        status = np.empty((ny, nz), dtype=np.uint8)
        mask = np.empty((ny, nz, WORDS), dtype=np.uint64)
        scratch = np.empty((3, SUB))
        partial = np.empty(max(max_planes, 1))
        active = np.empty(max(max_planes, 1), dtype=np.int64)
        xy = np.empty((max(max_planes, 1), 2))
        words = np.empty(WORDS, dtype=np.uint64)
        for p in range(t * per, min((t + 1) * per, nplanes)):
            _grain_plane(
                i0 + p,
                img_pos,
                img_grain,
                order,
                xmin_sorted,
                hx_max,
                kind,
                radius,
                plane_ptr,
                planes,
                h,
                ny,
                nz,
                boundary_only,
                status,
                mask,
                scratch,
                partial,
                active,
                xy,
                words,
                out[p],
            )


@njit(cache=True, fastmath=FASTMATH)
def _point_hits(points, q, centre, kind, radius, plane_ptr, planes, grain_ids):
    """Number of the grains ``grain_ids`` (centre[t] for grain_ids[t], no periodic wrap) containing points[q].

    A point beyond a grain's circumscribed sphere (radius[g], widened by 1e-9 against rounding) is outside it: the
    plane tests, which decide, run only inside that sphere.
    """
    n = 0
    for t in range(grain_ids.shape[0]):
        g = grain_ids[t]
        dx = points[q, 0] - centre[t, 0]
        dy = points[q, 1] - centre[t, 1]
        dz = points[q, 2] - centre[t, 2]
        d2 = (dx * dx + dy * dy) + dz * dz
        if kind[g] == KIND_SPHERE:
            inside = d2 <= radius[g] * radius[g]
        elif d2 > radius[g] * radius[g] * (1.0 + 1e-9):
            inside = False
        else:
            inside = True
            for p in range(plane_ptr[g], plane_ptr[g + 1]):
                if (planes[p, 0] * dx + planes[p, 1] * dy) + planes[p, 2] * dz > planes[p, 3]:
                    inside = False
                    break
        if inside:
            n += 1
    return n


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _points_inside(points, centre, kind, radius, plane_ptr, planes, grain_ids, out):
    """out[q] = number of the grains ``grain_ids`` containing points[q] (see :func:`_point_hits`), parallel."""
    # np.int64: the parallel loop's index may be unsigned, which would compile _point_hits a second time
    for q in prange(points.shape[0]):
        out[q] = _point_hits(points, np.int64(q), centre, kind, radius, plane_ptr, planes, grain_ids)


@njit(cache=True, fastmath=FASTMATH)
def _points_inside_serial(points, centre, kind, radius, plane_ptr, planes, grain_ids, out):
    """:func:`_points_inside` in one thread: for the minimiser's many small calls, where starting threads costs more."""
    for q in range(points.shape[0]):
        out[q] = _point_hits(points, q, centre, kind, radius, plane_ptr, planes, grain_ids)
