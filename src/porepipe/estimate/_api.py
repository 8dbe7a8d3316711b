"""Grey-value estimators of porosity and specific surface from grey histograms alone (Zauner 2020, §7.2–7.3).

All functions take the grey histogram M(g, a), g = 0..216 (g = number of the 216 sample points in the matrix).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.units import from_voxel_units

G_MAX = 216
SQRT3 = np.sqrt(3.0)
#: inscribed-sphere bound applies for 10 <= g <= 205 (ψ between √3(√3−1)³/16 ≈ 0.042468 and 1 minus that)
S_MIN_G_RANGE = (10, 205)


def _check_hist(hist) -> np.ndarray:
    hist = np.asarray(hist, dtype=np.int64)
    if hist.shape != (G_MAX + 1,):
        raise PorepipeError(f"grey histogram needs 217 bins (g = 0..216), got shape {hist.shape}")
    if hist.min() < 0 or hist.sum() == 0:
        raise PorepipeError("grey histogram needs non-negative counts and at least one voxel")
    return hist


def porosity_at_threshold(hist, g_th: int) -> float:
    """φ(g_th, a) = (1/N) Σ_{g <= g_th} M(g, a): porosity when pore means g <= g_th (§7.2)."""
    hist = _check_hist(hist)
    return float(hist[: g_th + 1].sum() / hist.sum())


def porosity_bounds(hist) -> tuple[float, float]:
    """(φ(0, a), φ(215, a)): the lower and upper bounds of the true porosity for a continuum model (§7.2)."""
    return porosity_at_threshold(hist, 0), porosity_at_threshold(hist, G_MAX - 1)


def porosity_mean_grey(hist) -> float:
    """φ̄ = 1 − Σ_g g M(g) / (216 N): the mean voxel porosity ψ_i ≈ 1 − g_i/216 of Eq. 7.1.1.

    It is the fraction of all sample points (a lattice of spacing a/6) that lie in the pore space, so it converges
    much faster than the bounds; it needs no threshold.
    """
    hist = _check_hist(hist)
    return float(1.0 - (hist * np.arange(G_MAX + 1)).sum() / (G_MAX * hist.sum()))


def richardson_limit(a, q) -> tuple[float, float]:
    """Limit a → 0 of q(a) = q∞ + c1·a + c2·a² through the three finest resolutions, and an error estimate.

    The error is the change from the two-point (linear) limit of the two finest resolutions to the three-point
    limit — the usual estimate of the size of the next neglected term. Needs ≥ 3 resolutions.
    """
    a = np.asarray(a, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    if a.size < 3:
        raise PorepipeError(f"a three-point limit needs 3 resolutions, got {a.size}")
    if a.shape != q.shape:
        raise PorepipeError(f"a three-point limit needs one value per resolution, got {a.size} and {q.size}")
    idx = np.argsort(a)[:3]
    finest = a[idx]
    if not (np.all(np.isfinite(finest)) and finest[0] > 0 and np.all(np.diff(finest) > 0)):
        raise PorepipeError(
            f"a three-point limit needs three distinct positive resolutions, got the finest {finest.tolist()} µm"
        )
    if not np.all(np.isfinite(q[idx])):
        raise PorepipeError(f"a three-point limit needs finite values, got {q[idx].tolist()}")
    # fit in a / 2^e (2^e near the coarsest of the three): the limit at a = 0 does not depend on the unit of a, and
    # a power of 2 divides exactly, so this gives the same bits as the fit in µm wherever that one is representable
    # (a ~ 1e-100 µm: a² underflows in polyfit's column scaling, which then never converges; 1e100: a² overflows)
    x = np.ldexp(a, -int(np.frexp(finest[-1])[1]))
    coef = np.polyfit(x[idx], q[idx], 2)
    linear = np.polyfit(x[idx[:2]], q[idx[:2]], 1)
    return float(coef[-1]), float(abs(coef[-1] - linear[-1]))


def two_point_line(a_coarse: float, phi_coarse: float, a_fine: float, phi_fine: float) -> tuple[float, float]:
    """Slope k and intercept ϕ of the line φ(a) = ϕ + k·a through two resolutions (Eq. 7.2.1)."""
    if not a_coarse > a_fine > 0:
        raise PorepipeError(f"two-point extrapolation needs a_coarse > a_fine > 0, got {a_coarse}, {a_fine}")
    k = (phi_coarse - phi_fine) / (a_coarse - a_fine)
    return k, phi_fine - k * a_fine


@dataclasses.dataclass(frozen=True)
class PorosityLimit:
    """The a → 0 porosity from the regression of φ* on φ** (§7.2)."""

    phi: float  # intercept at φ** = 0
    phi_err: float  # its standard error (regression) or the spread estimate, see ``error_method``
    slope: float
    phi_star: np.ndarray
    phi_2star: np.ndarray
    error_method: str


def _add_exact_limits(ds: xr.Dataset, bounds: np.ndarray) -> xr.Dataset:
    """No voxel is partly matrix at any resolution (a single phase, or faces on voxel planes): φ is known exactly."""
    phi = float(bounds[-1, 0])
    why = "no partial voxels at any resolution: both bounds equal the porosity, nothing to extrapolate"
    ds["phi_star"] = ("pair", 0.5 * (ds["phi_0"].values + ds["phi_215"].values))
    ds["phi_2star"] = ("pair", ds["phi_215"].values - ds["phi_0"].values)
    ds["phi_regression"] = ((), phi, {"error_method": "exact", "supported": 1, "why": why})
    ds["phi_regression_err"] = ((), 0.0)
    ds["phi_limit"] = ((), phi, {"method": why})
    ds["phi_limit_err"] = ((), 0.0, {"method": "exact"})
    return ds


def regress_porosity_limit(phi0_lines, phi215_lines) -> PorosityLimit:
    """Regress φ* = (ϕ_0 + ϕ_215)/2 linearly on φ** = ϕ_215 − ϕ_0 and return the intercept (φ** → 0).

    Parameters
    ----------
    phi0_lines, phi215_lines : (P,) array_like
        Intercepts ϕ_0(c), ϕ_215(c) of the two-point lines of the lower and upper bound, one per pair c.

    Notes
    -----
    Zauner (2020) §7.2, Table 7.2: with the four pairs c = 8, 4, 2, 1 a0 the intercept is 0.134313. With three or
    more pairs the error is the intercept's standard error from the residuals; with two pairs the line is exact and
    the error is taken as |φ*_finest − intercept| (the last step of the extrapolation), which is stated.
    """
    p0 = np.asarray(phi0_lines, dtype=np.float64)
    p1 = np.asarray(phi215_lines, dtype=np.float64)
    if p0.shape != p1.shape or p0.ndim != 1:
        raise PorepipeError(f"need matching 1-D arrays of intercepts, got shapes {p0.shape} and {p1.shape}")
    if p0.size < 2:
        raise PorepipeError(
            f"the φ*/φ** regression needs at least 2 resolution pairs (3 resolutions), got {p0.size}"
        )
    if not (np.all(np.isfinite(p0)) and np.all(np.isfinite(p1))):
        raise PorepipeError(
            f"the φ*/φ** regression needs finite intercepts, got {p0.tolist()} and {p1.tolist()}"
        )
    star = 0.5 * (p0 + p1)
    star2 = p1 - p0
    if np.ptp(star2) == 0:
        raise PorepipeError("all bound widths φ** are equal: the regression has no lever arm")
    design = np.column_stack([np.ones_like(star2), star2])
    coef, *_ = np.linalg.lstsq(design, star, rcond=None)
    if p0.size > 2:
        resid = star - design @ coef
        sigma2 = resid @ resid / (p0.size - 2)
        cov = sigma2 * np.linalg.inv(design.T @ design)
        err, method = float(np.sqrt(cov[0, 0])), "standard error of the regression intercept"
    else:
        finest = int(np.argmin(star2))
        err, method = float(abs(star[finest] - coef[0])), "two pairs only: |phi*_finest - intercept|"
    return PorosityLimit(float(coef[0]), err, float(coef[1]), star, star2, method)


# -- specific surface (§7.3) --------------------------------------------------------------------------------------------
def cap_base_area(psi, radius):
    """Base area of the spherical cap holding a fraction ``psi`` of a ball's volume (m = 2 root of §7.3)."""
    psi = np.clip(np.asarray(psi, dtype=np.float64), 0.0, 1.0)
    h = radius * (1.0 + 2.0 * np.cos((np.arccos(1.0 - 2.0 * psi) + 4.0 * np.pi) / 3.0))
    return np.pi * h * (2.0 * radius - h)


def corner_cut(fraction, a: float = 1.0):
    """Plane ⟂ to the cube's space diagonal that cuts off ``fraction`` (≤ ½) of a cube of edge ``a``.

    Returns (d, area): the plane's distance from the corner and the area of the cut (triangle for
    fraction ≤ 1/6, hexagon up to ½), Eqs. 7.3.4–7.3.7.
    """
    frac = np.asarray(fraction, dtype=np.float64)
    if np.any((frac < 0) | (frac > 0.5)):
        raise PorepipeError("corner_cut takes a cut-off fraction in [0, 1/2]")
    tri = frac <= 1.0 / 6.0
    psi = 1.0 - frac
    d_tri = (2.0 * frac / SQRT3) ** (1.0 / 3.0)
    arg = np.clip(2.0 * (2.0 * psi - 1.0) / SQRT3, -1.0, 1.0)
    d_hex = SQRT3 / 2.0 - np.cos((np.arccos(arg) + np.pi) / 3.0)
    d = np.where(tri, d_tri, d_hex)
    area = np.where(tri, 1.5 * SQRT3 * d**2, 0.5 * SQRT3 * (3.0 * d**2 - 3.0 * (SQRT3 * d - 1.0) ** 2))
    return d * a, area * a * a


def _surface_per_grey_unit() -> dict[str, np.ndarray]:
    """S_min(g), S_mf(g), S_max(g) for g = 0..216 at voxel edge 1 (Eqs. 7.3.1–7.3.8): S_b(g, a) = S_b(g, 1) / a."""
    g = np.arange(G_MAX + 1, dtype=np.float64)
    psi = 1.0 - g / G_MAX
    mixed = (g >= 1) & (g <= G_MAX - 1)
    s_max = np.where(mixed, cap_base_area(psi, SQRT3 / 2.0), 0.0)
    lo, hi = S_MIN_G_RANGE
    s_min = np.where((g >= lo) & (g <= hi), cap_base_area(psi, 0.5), 0.0)
    frac = np.minimum(g, G_MAX - g) / G_MAX
    s_mf = np.where(mixed, corner_cut(frac)[1], 0.0)
    return {"S_min": s_min, "S_mf": s_mf, "S_max": s_max}


def surface_per_grey(a: float) -> dict[str, np.ndarray]:
    """S_min(g, a), S_mf(g, a), S_max(g, a) for g = 0..216 in 1/length (the unit of ``a``), Eqs. 7.3.1–7.3.8.

    Mixed voxels only (g = 1..215); the mean-field value uses the cut-off fraction min(g, 216 − g)/216. Computed at
    a = 1 and divided by a (the areas scale as a², the voxel volume as a³), so any representable a works.
    """
    return {name: from_voxel_units(values, a, -1, name) for name, values in _surface_per_grey_unit().items()}


def surface_estimates(hist, a: float) -> dict[str, float]:
    """S_b(a) = (1/N) Σ_{g=1}^{215} M(g, a) S_b(g, a) for b in min, mf, max (Eq. 7.3.3)."""
    hist = _check_hist(hist)
    return {
        name: float(from_voxel_units(hist @ values / hist.sum(), a, -1, name))
        for name, values in _surface_per_grey_unit().items()
    }


# -- all estimators over a resolution series ----------------------------------------------------------------------------
def estimate_from_histograms(voxel_um, hists) -> xr.Dataset:
    """Every grey-value estimator for a series of resolutions.

    Parameters
    ----------
    voxel_um : (R,) array_like
        Voxel sizes a in µm (any order).
    hists : (R, 217) array_like
        Grey histograms M(g, a).

    Returns
    -------
    xarray.Dataset
        Over ``a_um``: phi_lower = φ(0, a), phi_upper = φ(215, a), S_min/S_mf/S_max [µm⁻¹]; over ``pair`` (each
        consecutive coarse/fine pair): the two-point lines; with ≥ 3 resolutions the thesis's regression
        (phi_regression ± phi_regression_err, with a ``supported`` flag) and phi_limit ± phi_limit_err from
        three-point limits of both bounds.
    """
    a = np.asarray(voxel_um, dtype=np.float64)
    hists = np.asarray(hists, dtype=np.int64)
    if hists.shape != (a.size, G_MAX + 1):
        raise PorepipeError(
            f"need one 217-bin histogram per resolution: {a.size} resolutions, shape {hists.shape}"
        )
    order = np.argsort(-a)
    a, hists = a[order], hists[order]
    bounds = np.array([porosity_bounds(h) for h in hists])
    mean_grey = np.array([porosity_mean_grey(h) for h in hists])
    surf = [surface_estimates(h, ai) for h, ai in zip(hists, a)]
    ds = xr.Dataset(
        {
            "phi_lower": ("a_um", bounds[:, 0], {"long_name": "phi(0, a): pore iff g = 0"}),
            "phi_upper": ("a_um", bounds[:, 1], {"long_name": "phi(215, a): pore iff g <= 215"}),
            "phi_mean_grey": ("a_um", mean_grey, {"long_name": "1 - mean(g)/216 (Eq. 7.1.1)"}),
            "grey_histogram": (("a_um", "g"), hists, {"long_name": "M(g, a)"}),
            **{k: ("a_um", [s[k] for s in surf], {"units": "1/um"}) for k in ("S_min", "S_mf", "S_max")},
        },
        coords={"a_um": a, "g": np.arange(G_MAX + 1)},
        attrs={"source": "Zauner (2020) sections 7.2-7.3"},
    )
    if a.size >= 2:
        lines = np.array(
            [
                two_point_line(a[i], bounds[i, 0], a[i + 1], bounds[i + 1, 0])
                + two_point_line(a[i], bounds[i, 1], a[i + 1], bounds[i + 1, 1])
                for i in range(a.size - 1)
            ]
        )  # (pair, [k0, phi0, k215, phi215])
        ds = ds.assign_coords(pair_coarse_um=("pair", a[:-1]), pair_fine_um=("pair", a[1:]))
        for col, name in enumerate(("k_0", "phi_0", "k_215", "phi_215")):
            ds[name] = ("pair", lines[:, col], {"units": "1/um" if name.startswith("k") else "1"})
    if a.size >= 3:
        ds = _add_limits(ds, a, bounds)
    return ds


def _add_limits(ds: xr.Dataset, a: np.ndarray, bounds: np.ndarray) -> xr.Dataset:
    """The a → 0 porosity: the thesis's φ*/φ** regression, and three-point limits of both bounds."""
    if np.all(bounds[:, 0] == bounds[:, 1]):
        return _add_exact_limits(ds, bounds)
    lim = regress_porosity_limit(ds["phi_0"].values, ds["phi_215"].values)
    width = lim.phi_2star
    # the regression needs bound widths that shrink towards 0 (as in Table 7.2); otherwise it extrapolates noise
    supported = bool(np.all(width > 0) and np.all(np.diff(width) < 0))
    lower, lower_err = richardson_limit(a, bounds[:, 0])
    upper, upper_err = richardson_limit(a, bounds[:, 1])
    phi_limit = float(np.clip(0.5 * (lower + upper), 0.0, 1.0))
    phi_limit_err = max(0.5 * abs(upper - lower), lower_err, upper_err)
    ds["phi_star"] = ("pair", lim.phi_star)
    ds["phi_2star"] = ("pair", width)
    ds["phi_regression"] = (
        (),
        float(np.clip(lim.phi, 0.0, 1.0)),
        {
            "error_method": f"max({lim.error_method}, |phi_regression - phi_limit| + phi_limit_err)",
            "supported": int(supported),
            "why": ""
            if supported
            else "bound widths phi** do not shrink "
            "monotonically to 0: the regression has no reliable lever arm",
        },
    )
    # the regression is biased high on small samples (φ* is not linear in φ** at coarse a), and its standard
    # error from 1-2 degrees of freedom is far too small; the distance to the three-point limit plus that limit's
    # own error bounds the true error by the triangle inequality whenever the limit's bar covers (README: coverage)
    ds["phi_regression_err"] = ((), max(lim.phi_err, abs(lim.phi - phi_limit) + phi_limit_err))
    ds["phi_limit"] = (
        (),
        phi_limit,
        {"method": "midpoint of the three-point (quadratic in a) limits of phi(0,a) and phi(215,a)"},
    )
    ds["phi_limit_err"] = (
        (),
        phi_limit_err,
        {"method": "max(half gap of the two limits, change from linear to quadratic limit)"},
    )
    return ds
