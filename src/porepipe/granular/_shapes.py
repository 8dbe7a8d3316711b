"""Particle shapes (Schinner 2001, §2.2.1, App. B.1.4, B.1.6, D): convex polygons and their mass properties.

Conventions: corners counter-clockwise, lengths in m, 2-D density in kg/m², angles in rad counter-clockwise
(gc2d turns clockwise for positive φ, Eq. 2.35; porepipe uses the mathematical sense, φ_gc2d = -φ).
"""

from __future__ import annotations

import enum
import math

import numpy as np

from porepipe._shared.errors import PorepipeError

#: relative tolerance of the convexity test (cross products below it count as collinear)
_CONVEX_RTOL = 1e-12
#: largest corner coordinate (m): the convexity test's cross products (~ L²) stay finite
_MAX_COORD_M = 1e100


class AngleMode(str, enum.Enum):
    """How the corners of a random particle are placed on its ellipse (App. B.1.6)."""

    regular = "REGULAR"  # phi_i = 2 pi i / N
    rand1 = "RAND1"  # phi_i uniform in [(i - 1/2) 2pi/N, (i + 1/2) 2pi/N]
    rand2 = "RAND2"  # phi_i uniform in [(i - 1) 2pi/N, (i + 1) 2pi/N]
    full = "FULL"  # phi_i uniform in [0, 2 pi), sorted
    special_rectangle = "SPECIAL_RECTANGLE"  # rectangle 2a x 2b with bevelled corners


class Dist(str, enum.Enum):
    """Distribution of a size, corner number or orientation (App. B.1.6)."""

    const = "CONST"
    equal = "EQUAL"  # uniform in [c (1 - I), c (1 + I)] (sizes) or [c - I, c + I] (corners, angles)
    gauss = "GAUSS"  # the thesis's truncated Gaussian mapped onto the same interval


def polygon_properties(vertices, density_kg_m2: float = 1.0, name: str = "polygon"):
    """Area, centroid, mass and moment of inertia of a convex polygon by triangle decomposition (Eqs. 2.10-2.12).

    Parameters
    ----------
    vertices : (N, 2) array_like
        Corners in m, N >= 3, in either orientation (returned counter-clockwise).
    density_kg_m2 : float
        2-D density rho in kg/m².
    name : str
        What to call the polygon in an error message (e.g. ``"particle 17"``).

    Returns
    -------
    dict
        ``area_m2``, ``centroid_m`` (2,), ``mass_kg``, ``inertia_kg_m2`` (about the centroid), ``vertices_m``
        (N, 2) counter-clockwise and centred on the centroid.

    Notes
    -----
    The polygon is cut into triangles (c, v_k, v_k+1) around its vertex mean c; m = rho sum f_k (2.10), the
    centroid x = sum x_k f_k / sum f_k (2.11); then each triangle's inertia about its own centroid
    f (|a|²+|b|²+|c|² - |a+b+c|²/3)/12 plus Steiner's term is summed (2.12).
    """
    v = check_convex(vertices, name)
    c = v.mean(axis=0)
    a, b = v - c, np.roll(v, -1, axis=0) - c
    f = 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    area = f.sum()
    tri_c = (a + b) / 3.0  # triangle centroids relative to c (third corner at c)
    centroid = (tri_c * f[:, None]).sum(axis=0) / area
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):  # huge or tiny: refused below
        # inertia of each triangle (0, a, b) about its own centroid, then Steiner to the polygon's centroid
        own = f * ((a * a).sum(1) + (b * b).sum(1) - ((a + b) ** 2).sum(1) / 3.0) / 12.0
        steiner = f * ((tri_c - centroid) ** 2).sum(1)
        inertia = density_kg_m2 * (own + steiner).sum()
    mass = density_kg_m2 * area
    if not (0.0 < mass < math.inf and 0.0 < inertia < math.inf):
        raise PorepipeError(
            f"{name}: mass {mass:.3g} kg and moment of inertia {inertia:.3g} kg m² must be positive finite numbers "
            f"(area {area:.3g} m², density {density_kg_m2:.3g} kg/m²: overflow or underflow); lengths are in metres"
        )
    return {
        "area_m2": float(area),
        "centroid_m": c + centroid,
        "mass_kg": float(mass),
        "inertia_kg_m2": float(inertia),
        "vertices_m": v - (c + centroid),
    }


def check_convex(vertices, name: str = "polygon") -> np.ndarray:
    """Return the corners as a counter-clockwise float array; raise if not a convex polygon with >= 3 corners.

    Parameters
    ----------
    vertices : (N, 2) array_like
        Corners in m.
    name : str
        Named in the error (``"particle 3"``, ``"wall floor"``).

    Raises
    ------
    PorepipeError
        Fewer than 3 corners, non-finite coordinates, zero area, a reflex or collinear corner, or a boundary that
        winds more than once.
    """
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
        raise PorepipeError(f"{name}: needs at least 3 corners as an (N, 2) array, got shape {v.shape}")
    if not np.isfinite(v).all():
        raise PorepipeError(f"{name}: corner coordinates must be finite")
    if np.abs(v).max() > _MAX_COORD_M:
        raise PorepipeError(
            f"{name}: corner coordinates reach {np.abs(v).max():.3g} m; allowed: |x|, |y| <= {_MAX_COORD_M:g} m "
            "(corners are in metres)"
        )
    area2 = float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    if area2 < 0:
        v = v[::-1].copy()
    d1 = np.roll(v, -1, axis=0) - v
    d2 = np.roll(d1, -1, axis=0)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    scale = np.abs(d1).max() ** 2
    if scale == 0.0:
        raise PorepipeError(f"{name}: all corners coincide")
    bad = np.nonzero(cross <= _CONVEX_RTOL * scale)[0]
    if area2 == 0 or bad.size:
        k = int((bad[0] + 1) % len(v)) if bad.size else 0
        raise PorepipeError(
            f"{name}: not a convex polygon (corner {k} at {v[k].tolist()} is reflex, collinear or "
            "repeated); gc2d needs convex particles with corners in order"
        )
    turning = np.arctan2(cross, (d1 * d2).sum(1)).sum()
    if turning > 2 * np.pi * (1 + 1e-9):
        raise PorepipeError(
            f"{name}: the boundary winds {turning / (2 * np.pi):.2f} times (self-intersecting)"
        )
    return v


def regular_polygon(n: int, radius_m: float, phase_rad: float = 0.0) -> np.ndarray:
    """Regular n-gon with circumradius ``radius_m`` (gc2d's disk, App. D.3); (n, 2) corners, CCW."""
    if int(n) < 3:
        raise PorepipeError(f"a regular polygon needs n >= 3 corners, got {n}")
    phi = phase_rad + 2.0 * np.pi * np.arange(int(n)) / int(n)
    return radius_m * np.column_stack([np.cos(phi), np.sin(phi)])


def rectangle(a_m: float, b_m: float, cut: float = 0.0, round_radius_m: float = 0.0, round_corners: int = 4):
    """Rectangle a x b centred at 0, plain, bevelled ("cut", App. D) or with rounded corners.

    Parameters
    ----------
    a_m, b_m : float
        Edge lengths in x and y (m).
    cut : float
        Bevel fraction c in [0, 0.5): the remaining straight edges are a(1 - 2c) and b(1 - 2c).
    round_radius_m : float
        Corner radius r (0 = sharp); each quarter circle gets ``round_corners`` corners.
    round_corners : int
        Corners per rounded quarter (>= 2).

    Returns
    -------
    (N, 2) ndarray
        Corners, counter-clockwise.
    """
    ha, hb = 0.5 * a_m, 0.5 * b_m
    if not (a_m > 0 and b_m > 0):
        raise PorepipeError(f"rectangle edges must be positive, got {a_m} x {b_m}")
    if not 0.0 <= cut < 0.5:
        raise PorepipeError(f"rectangle cut must be in [0, 0.5), got {cut}")
    if round_radius_m > 0:
        r = round_radius_m
        if r > min(ha, hb) or round_corners < 2:
            raise PorepipeError(
                f"round_radius_m = {r} must not exceed half the shorter edge; round_corners >= 2"
            )
        pts = []
        for q, (cx, cy) in enumerate(
            [(ha - r, hb - r), (-ha + r, hb - r), (-ha + r, -hb + r), (ha - r, -hb + r)]
        ):
            for t in np.linspace(0, 0.5 * np.pi, int(round_corners)):
                pts.append((cx + r * math.cos(t + q * 0.5 * np.pi), cy + r * math.sin(t + q * 0.5 * np.pi)))
        return _drop_duplicates(np.array(pts))
    if cut > 0:
        ca, cb = cut * a_m, cut * b_m
        return np.array(
            [
                (ha, -hb + cb),
                (ha, hb - cb),
                (ha - ca, hb),
                (-ha + ca, hb),
                (-ha, hb - cb),
                (-ha, -hb + cb),
                (-ha + ca, -hb),
                (ha - ca, -hb),
            ]
        )
    return np.array([(ha, -hb), (ha, hb), (-ha, hb), (-ha, -hb)])


def _drop_duplicates(v: np.ndarray) -> np.ndarray:
    keep = np.linalg.norm(v - np.roll(v, 1, axis=0), axis=1) > 1e-12 * np.abs(v).max()
    return v[keep]


def ellipse_polygon(n: int, a_m: float, b_m: float, mode: AngleMode, rng: np.random.Generator) -> np.ndarray:
    """Random convex particle with ``n`` corners on the ellipse x = a cos phi, y = b sin phi (Eqs. B.4-B.5).

    The sorted angles keep it convex. ``SPECIAL_RECTANGLE`` gives the bevelled rectangle 2a x 2b (cut 0.1).
    Corners that fall within 1e-9 rad of each other (possible in FULL/RAND2) are merged.
    """
    n = int(n)
    mode = AngleMode(mode)
    if mode is AngleMode.special_rectangle:
        return rectangle(2 * a_m, 2 * b_m, cut=0.1)
    if n < 3:
        raise PorepipeError(f"a particle needs at least 3 corners, got {n}")
    i = np.arange(n)
    step = 2.0 * np.pi / n
    if mode is AngleMode.regular:
        phi = i * step
    elif mode is AngleMode.rand1:
        phi = (i + rng.uniform(-0.5, 0.5, n)) * step
    elif mode is AngleMode.rand2:
        phi = (i + rng.uniform(-1.0, 1.0, n)) * step
    else:
        phi = rng.uniform(0.0, 2.0 * np.pi, n)
    phi = np.sort(np.mod(phi, 2.0 * np.pi))
    gap = np.diff(np.append(phi, phi[0] + 2.0 * np.pi))
    phi = phi[gap > 1e-9]
    if phi.size < 3 or np.max(np.diff(np.append(phi, phi[0] + 2 * np.pi))) >= np.pi:
        # all corners on one half of the ellipse: the centroid-free polygon would be a sliver; redraw regularly
        phi = i * step
    return np.column_stack([a_m * np.cos(phi), b_m * np.sin(phi)])


def truncated_unit_gauss(rng: np.random.Generator, size: int) -> np.ndarray:
    """The thesis's "special truncated Gaussian": mean 0.5, sigma 0.1 on [0, 1], outliers redrawn (App. B.1.6)."""
    out = rng.normal(0.5, 0.1, size)
    bad = (out < 0) | (out > 1)
    while bad.any():
        out[bad] = rng.normal(0.5, 0.1, int(bad.sum()))
        bad = (out < 0) | (out > 1)
    return out


def draw(
    dist: Dist, center: float, spread: float, rng: np.random.Generator, size: int, relative: bool = True
):
    """Draw ``size`` values of a CONST / EQUAL / GAUSS distribution (App. B.1.6).

    Parameters
    ----------
    dist : Dist
        Family.
    center : float
        c (size l, corner number N_E or orientation phi_0).
    spread : float
        I: relative (``relative=True``, sizes: interval [c(1-I), c(1+I)]) or absolute ([c-I, c+I]).
    rng : numpy.random.Generator
    size : int
    relative : bool

    Returns
    -------
    (size,) ndarray of float
    """
    half = center * spread if relative else spread
    dist = Dist(dist)
    if dist is Dist.const or half == 0:
        return np.full(size, float(center))
    u = rng.uniform(0.0, 1.0, size) if dist is Dist.equal else truncated_unit_gauss(rng, size)
    return center - half + 2.0 * half * u


def corner_numbers(dist: Dist, n_mean: int, n_spread: int, rng: np.random.Generator, size: int) -> np.ndarray:
    """Corner numbers N_E ± N_I (integers >= 3); EQUAL draws each integer of [N_E - N_I, N_E + N_I] alike."""
    dist = Dist(dist)
    if dist is Dist.equal and n_spread > 0:
        out = rng.integers(n_mean - n_spread, n_mean + n_spread + 1, size)
    else:
        out = np.rint(draw(dist, n_mean, n_spread + 0.5, rng, size, relative=False)).astype(np.int64)
        out = np.clip(out, n_mean - n_spread, n_mean + n_spread)
    if out.min(initial=3) < 3:
        raise PorepipeError(f"corner numbers {n_mean} ± {n_spread} reach below 3")
    return out.astype(np.int64)


def inscribed_radius(vertices) -> float:
    """Radius of the largest circle about the centroid inside the (centred) convex polygon (for Eq. 2.9)."""
    v = np.asarray(vertices, dtype=np.float64)
    e = np.roll(v, -1, axis=0) - v
    cross = v[:, 0] * e[:, 1] - v[:, 1] * e[:, 0]
    return float(np.min(cross / np.linalg.norm(e, axis=1)))
