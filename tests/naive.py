"""Slow, obviously-right references for the fast kernels (test oracles only)."""

import itertools

import numpy as np


def grey_values_naive(centres, radii, box, a, periodic=True):
    """Grey values by evaluating every one of the 216 sample points of every voxel against every sphere image."""
    box = np.asarray(box, dtype=np.float64)
    n = np.rint(box / a).astype(int)
    h = a / 6.0
    axes = [(np.arange(6 * n[d]) + 0.5) * h for d in range(3)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    inside = np.zeros(x.shape, dtype=bool)
    shifts = itertools.product((-1, 0, 1), repeat=3) if periodic else [(0, 0, 0)]
    for s in shifts:
        for c, r in zip(centres + np.asarray(s) * box, radii):
            dx = x - c[0]
            dy = y - c[1]
            dz = z - c[2]
            inside |= dx * dx + dy * dy + dz * dz <= r * r
    return inside.reshape(n[0], 6, n[1], 6, n[2], 6).sum(axis=(1, 3, 5)).astype(np.uint8)


def lens_volume(r1, r2, d):
    """Volume of the intersection of two balls of radii r1, r2 at centre distance d (|r1 - r2| < d < r1 + r2)."""
    return (
        np.pi
        * (r1 + r2 - d) ** 2
        * (d * d + 2 * d * r2 - 3 * r2 * r2 + 2 * d * r1 + 6 * r1 * r2 - 3 * r1 * r1)
        / (12 * d)
    )


def lens_area_removed(r1, r2, d):
    """Surface area of the two caps hidden inside the lens: 2π r1 h1 + 2π r2 h2."""
    h1 = (r2 - r1 + d) * (r2 + r1 - d) / (2 * d)
    h2 = (r1 - r2 + d) * (r1 + r2 - d) / (2 * d)
    return 2 * np.pi * (r1 * h1 + r2 * h2)


def spheres_with_known_union(box, n_target, r_min, r_max, seed):
    """Isolated spheres and isolated overlapping pairs in a periodic box; returns centres, radii, volume, surface.

    No sphere touches any other except its pair partner, so the union volume and surface are closed-form:
    Σ 4/3 π r³ − Σ lens volumes and Σ 4 π r² − Σ hidden cap areas.
    """
    rng = np.random.default_rng(seed)
    centres, radii, pairs = [], [], []
    for _ in range(200 * n_target):
        if len(radii) >= n_target:
            break
        r1, r2 = rng.uniform(r_min, r_max, 2)
        c1 = rng.uniform(0, box, 3)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        d = rng.uniform(abs(r1 - r2) + 0.3 * min(r1, r2), r1 + r2 - 0.2 * min(r1, r2))
        cand = [(c1, r1), ((c1 + u * d) % box, r2)] if rng.random() < 0.5 else [(c1, r1)]
        clear = True
        for c, r in cand:
            if radii:
                dist = np.linalg.norm((np.array(centres) - c + box / 2) % box - box / 2, axis=1)
                clear &= bool(np.all(dist > np.array(radii) + r + 0.05 * r_min))
        if clear:
            if len(cand) == 2:
                pairs.append((r1, r2, d))
            for c, r in cand:
                centres.append(c)
                radii.append(r)
    radii = np.array(radii)
    volume = (4 / 3 * np.pi * radii**3).sum() - sum(lens_volume(*p) for p in pairs)
    surface = (4 * np.pi * radii**2).sum() - sum(lens_area_removed(*p) for p in pairs)
    return np.array(centres), radii, volume, surface
