"""Slow, obviously-right references for the diffusion kernels (test oracles only)."""

from collections import deque

import numpy as np
from scipy import ndimage


def flight_naive(pore, h, pos, u, t_max=1e6):
    """First solid (or outside) voxel on the ray pos + t u: (hit time, face event 2*axis + (u>0)) or None.

    Collects every voxel-plane crossing time of the ray, sorts them and looks up the voxel of each interval's
    midpoint: no incremental state, so it shares nothing with the DDA but the geometry.
    """
    pore = np.asarray(pore)
    n = np.array(pore.shape)
    times, axes = [0.0], [-1]
    for d in range(3):
        if u[d] == 0:
            continue
        k = np.arange(0, n[d] + 1) * h[d]
        t = (k - pos[d]) / u[d]
        keep = (t > 1e-12) & (t < t_max)
        times += list(t[keep])
        axes += [d] * int(keep.sum())
    order = np.argsort(times, kind="stable")
    times = np.array(times)[order]
    axes = np.array(axes)[order]
    for m in range(len(times) - 1):
        if times[m + 1] - times[m] <= 1e-12:
            continue
        mid = pos + 0.5 * (times[m] + times[m + 1]) * u
        idx = np.floor(mid / h).astype(int)
        outside = np.any(idx < 0) or np.any(idx >= n)
        if outside or pore[tuple(idx)] == 0:
            d = axes[m]
            return times[m], 2 * d + int(u[d] > 0)
    return None


def chessboard_naive(pore):
    """Distance codes by scipy's chessboard transform on a solid-padded copy, saturated at 255."""
    padded = np.pad(np.asarray(pore) > 0, 1, constant_values=False)
    dist = ndimage.distance_transform_cdt(padded, metric="chessboard")[1:-1, 1:-1, 1:-1]
    return np.minimum(dist, 255).astype(np.uint8)


def largest_spanning_naive(pore, axis):
    """Largest 6-connected cluster touching both end layers of ``axis`` by breadth-first search (None if none)."""
    pore = np.asarray(pore) > 0
    seen = np.zeros(pore.shape, dtype=int)
    best, best_size, label = None, 0, 0
    n = pore.shape
    for start in zip(*np.nonzero(pore)):
        if seen[start]:
            continue
        label += 1
        seen[start] = label
        queue, members = deque([start]), [start]
        while queue:
            c = queue.popleft()
            for d in range(3):
                for s in (-1, 1):
                    nb = list(c)
                    nb[d] += s
                    nb = tuple(nb)
                    if 0 <= nb[d] < n[d] and pore[nb] and not seen[nb]:
                        seen[nb] = label
                        queue.append(nb)
                        members.append(nb)
        ends = {m[axis] for m in members}
        if 0 in ends and n[axis] - 1 in ends and len(members) > best_size:
            best, best_size = label, len(members)
    return None if best is None else (seen == best)


def wall_area_naive(pore, h, periodic=(False, False, False), open_axis=None):
    """Count pore-solid faces voxel by voxel (outside solid unless periodic or the open axis)."""
    pore = np.asarray(pore) > 0
    n = pore.shape
    area = 0.0
    for c in zip(*np.nonzero(pore)):
        for d in range(3):
            face = np.prod([h[e] for e in range(3) if e != d])
            for s in (-1, 1):
                nb = list(c)
                nb[d] += s
                if not 0 <= nb[d] < n[d]:
                    if periodic[d]:
                        nb[d] %= n[d]
                    else:
                        area += 0.0 if d == open_axis else face
                        continue
                if not pore[tuple(nb)]:
                    area += face
    return area


def _cos_theta_naive(law, u):
    return {"lambert": np.sqrt(u), "isotropic": u, "cosine_dtheta": np.sqrt(1 - (1 - u) ** 2)}[law]


def _inlet_directions(rng, n, law):
    """``n`` unit directions into the duct (+z), cos θ drawn by ``law``, azimuth uniform."""
    c = _cos_theta_naive(law, rng.random(n))
    s, phi = np.sqrt(1 - c * c), 2 * np.pi * rng.random(n)
    return np.column_stack([s * np.cos(phi), s * np.sin(phi), c])


def rect_channel_w_naive(a, b, length, wall="lambert", inlet="lambert", n=100000, seed=0, max_hits=100000):
    """Transmission probability of a continuous a x b x length duct (no voxels): vectorised numpy Monte Carlo with
    analytic ray-plane intersections, particles entering at z = 0. Returns (W, binomial standard error)."""
    rng = np.random.default_rng(seed)
    box = np.array([a, b])
    pos = np.column_stack([rng.random(n) * a, rng.random(n) * b, np.zeros(n)])
    u = _inlet_directions(rng, n, inlet)
    alive = np.ones(n, bool)
    through = np.zeros(n, bool)
    for _ in range(max_hits):
        idx = np.nonzero(alive)[0]
        if idx.size == 0:
            break
        p, v = pos[idx], u[idx]
        with np.errstate(divide="ignore", invalid="ignore"):
            t_lat = np.where(
                v[:, :2] > 0,
                (box - p[:, :2]) / v[:, :2],
                np.where(v[:, :2] < 0, -p[:, :2] / v[:, :2], np.inf),
            )
            t_z = np.where(
                v[:, 2] > 0, (length - p[:, 2]) / v[:, 2], np.where(v[:, 2] < 0, -p[:, 2] / v[:, 2], np.inf)
            )
        t_all = np.column_stack([t_lat, t_z])
        k = np.argmin(t_all, axis=1)
        t = t_all[np.arange(idx.size), k]
        p = p + t[:, None] * v
        ends = k == 2
        through[idx[ends & (v[:, 2] > 0)]] = True
        alive[idx[ends]] = False
        wall_i = idx[~ends]
        kk = k[~ends]
        pos[wall_i] = p[~ends]
        m = wall_i.size
        cw = _cos_theta_naive(wall, rng.random(m))
        sw, pw = np.sqrt(1 - cw * cw), 2 * np.pi * rng.random(m)
        sign = np.where(u[wall_i, kk] > 0, -1.0, 1.0)
        other = 1 - kk  # the other lateral axis
        new = np.empty((m, 3))
        new[np.arange(m), kk] = sign * cw
        new[np.arange(m), other] = sw * np.cos(pw)
        new[:, 2] = sw * np.sin(pw)
        u[wall_i] = new
    w = through.mean()
    return w, np.sqrt(w * (1 - w) / n)


def _disk_to_disk(z):
    """View factor between two coaxial unit disks a distance z apart (fraction of a Lambert inlet flux that passes)."""
    return 1 + z * z / 2 - z * np.sqrt(z * z + 4) / 2


def _first_wall_hit(z):
    """Density in z of the first wall hits of a Lambert flux entering a unit tube at z = 0 (= -d/dz of the above)."""
    return (z * z + 2) / np.sqrt(z * z + 4) - z


def _ring_to_ring(x):
    """Density of the wall hits at axial distance x of a Lambert emission from a wall ring of a unit tube."""
    x = np.abs(x)
    return 0.5 * (1 - (x**3 + 6 * x) / (x * x + 4) ** 1.5)


def clausing_w(length_over_radius, panels=100, order=8):
    """Clausing's W of a circular tube (Lambert walls and inlet) from his integral equation, solved numerically.

    The wall-emission density n(z) of a unit tube of length L solves n(z) = h(z) + ∫ K(z - z') n(z') dz' (h: first
    hits from the inlet, K: ring-to-ring hits), and W = F(L) + ½ ∫ n(z) h(L - z) dz (F: disk-to-disk view factor);
    Clausing 1932, in the form of Berman 1965 (J. Appl. Phys. 36, 3365). Nyström on ``panels`` Gauss-Legendre panels
    with the kernel's kink at z = z' subtracted (∫ K is exact): W changes by < 1e-6 from 25 to 100 panels for L/R <= 40.
    """
    length = float(length_over_radius)
    g, gw = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(0.0, length, panels + 1)
    half = (edges[1:, None] - edges[:-1, None]) / 2
    z = ((edges[:-1, None] + edges[1:, None]) / 2 + half * g).ravel()
    w = (half * gw).ravel()
    kw = _ring_to_ring(z[:, None] - z[None, :]) * w[None, :]
    exact_row = 1 - (_first_wall_hit(z) + _first_wall_hit(length - z)) / 2  # ∫_0^L K(z - z') dz'
    n = np.linalg.solve(np.diag(1 - exact_row + kw.sum(axis=1)) - kw, _first_wall_hit(z))
    return float(_disk_to_disk(length) + 0.5 * np.sum(w * n * _first_wall_hit(length - z)))


def cylinder_w_naive(radius, length, n=100000, seed=0, max_hits=100000):
    """Transmission probability of a continuous circular tube (no voxels): Lambert inlet over the disk, Lambert
    walls, analytic ray-cylinder intersections, vectorised numpy. Returns (W, binomial standard error)."""
    rng = np.random.default_rng(seed)
    r0, a0 = radius * np.sqrt(rng.random(n)), 2 * np.pi * rng.random(n)
    pos = np.column_stack([r0 * np.cos(a0), r0 * np.sin(a0), np.zeros(n)])
    u = _inlet_directions(rng, n, "lambert")
    alive = np.ones(n, bool)
    through = np.zeros(n, bool)
    for _ in range(max_hits):
        idx = np.nonzero(alive)[0]
        if idx.size == 0:
            break
        p, v = pos[idx], u[idx]
        a = v[:, 0] ** 2 + v[:, 1] ** 2
        b = 2 * (p[:, 0] * v[:, 0] + p[:, 1] * v[:, 1])
        cc = np.minimum(p[:, 0] ** 2 + p[:, 1] ** 2 - radius * radius, 0.0)
        root = np.sqrt(b * b - 4 * a * cc)
        with np.errstate(divide="ignore", invalid="ignore"):
            # the positive root of a t² + b t + cc = 0 (cc <= 0), in the form without cancellation
            t_wall = np.where(a > 0, np.where(b <= 0, (-b + root) / (2 * a), 2 * cc / (-b - root)), np.inf)
            t_z = np.where(
                v[:, 2] > 0, (length - p[:, 2]) / v[:, 2], np.where(v[:, 2] < 0, -p[:, 2] / v[:, 2], np.inf)
            )
        ends = t_z <= t_wall
        through[idx[ends & (v[:, 2] > 0)]] = True
        alive[idx[ends]] = False
        wall_i, hit = idx[~ends], ~ends
        q = p[hit] + t_wall[hit, None] * v[hit]
        m = wall_i.size
        inward = -q[:, :2] / np.hypot(q[:, 0], q[:, 1])[:, None]
        along = np.column_stack([-inward[:, 1], inward[:, 0]])
        cw = _cos_theta_naive("lambert", rng.random(m))
        sw, pw = np.sqrt(1 - cw * cw), 2 * np.pi * rng.random(m)
        new = np.empty((m, 3))
        new[:, :2] = cw[:, None] * inward + (sw * np.cos(pw))[:, None] * along
        new[:, 2] = sw * np.sin(pw)
        q[:, :2] = -inward * radius  # back onto the circle (round-off)
        pos[wall_i] = q
        u[wall_i] = new
    w = through.mean()
    return w, np.sqrt(w * (1 - w) / n)
