"""Continuum theory of silos and heaps used to read the granular runs (Schinner 2001, §1.3 and ch. 3).

Silos (2-D, slice of width 2 r(z), depth z measured downwards from the free surface, stresses compressive
positive, rho g the weight per area of the bulk):

- Janssen (Eq. 3.4): sigma_zz = rho g r/(k mu_j) (1 - exp(-k mu_j z/r)), sigma_xx = k sigma_zz;
- any shape r(z) (Eqs. 3.10-3.12): sigma_zz = exp(-mu_j xi(z)) rho g int_0^z exp(mu_j xi(z')) dz',
  xi(z) = int_0^z (r'² + k)/(r (1 + r'²)^{3/2}) du;
- stepped (Eq. 3.15), hopper r = a z + b with the a/b swap and the b² of the printed Eqs. 3.17/3.18 corrected
  (digest §5.6), parabolic r = sqrt((b - z)/a) with xi of Eq. 3.20 and the effective radius r_P of Eq. 3.22
  without its spurious extra k (digest §5.7).

Lateral-pressure bounds for a cohesionless Mohr-Coulomb bulk of friction angle phi = atan(mu): Rankine's active
k_a = (1 - sin phi)/(1 + sin phi) and passive k_p = 1/k_a (the only values a bulk at failure can take, so every
stable state lies between them), and Jaky's at-rest estimate k_0 = 1 - sin phi (empirical, between the two).

Heaps (Wittmer, Cates & Claudin; thesis Eqs. 1.9-1.31): a 2-D wedge of repose angle phi, z down from the apex,
rho = 1, scale variable S = x tan(phi)/z (0 on the axis, 1 on the surface) and sigma_ij = g z s_ij(S). The closures
relate sigma_xx/sigma_zz = C(U), U = sigma_xz/sigma_zz (the thesis prints sigma_rr/sigma_rz in Eqs. 1.15-1.16, but
all four closures it lists are ratios to sigma_zz). IFE is Mohr-Coulomb failure everywhere; the thesis's Eq. 1.18
prints 1/cos(phi) where the failure condition gives 1/cos²(phi) (at U = 0 only the latter yields k_p and k_a).
For the linear closures (BCC, FPA, OSL: C = eta + mu U) the wedge solution is piecewise linear in S; the form
that vanishes at the surface, s ∝ (1 - S) (thesis Eqs. 1.26-1.28), holds in the *outer* region c1 tan(phi) < S <= 1
and the other (Eqs. 1.29-1.31) inside, the reverse of the thesis's labels (only the outer form meets the IFS
condition sigma(S = 1) = 0; both forms are continuous at S = c1 tan(phi)).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import integrate

from porepipe._shared.errors import PorepipeError, positive_number


# -- lateral pressure coefficients ---------------------------------------------------------------------------------
def lateral_pressure_bounds(mu: float) -> dict[str, float]:
    """Rankine active/passive and Jaky at-rest coefficients k = sigma_xx/sigma_zz for friction mu = tan(phi).

    Parameters
    ----------
    mu : float
        Internal friction coefficient (tan of the friction angle).

    Returns
    -------
    dict
        ``rankine_active``, ``jaky``, ``rankine_passive`` and ``phi_rad``.
    """
    phi = math.atan(positive_number("friction mu", mu))
    s = math.sin(phi)
    return {
        "rankine_active": (1 - s) / (1 + s),
        "jaky": 1 - s,
        "rankine_passive": (1 + s) / (1 - s),
        "phi_rad": phi,
    }


# -- silos ---------------------------------------------------------------------------------------------------------
def janssen(z, r: float, k: float, mu_j: float, rho_g: float) -> tuple[np.ndarray, np.ndarray]:
    """Janssen stresses (Eq. 3.4) of a 2-D silo of half-width ``r`` at depth ``z`` below the free surface.

    Parameters
    ----------
    z : array_like
        Depth in m (>= 0).
    r : float
        Half the silo width, m.
    k : float
        sigma_xx/sigma_zz.
    mu_j : float
        Wall friction (tau_w = mu_j sigma_xx).
    rho_g : float
        Bulk weight per area, rho_bulk g (N/m³ in 3-D, N/m² per m in 2-D).

    Returns
    -------
    sigma_zz, sigma_xx : ndarray
        Vertical stress and wall pressure; sigma_xx saturates at rho g r/mu_j.
    """
    z = np.asarray(z, dtype=np.float64)
    r, k, mu_j = positive_number("r", r), positive_number("k", k), positive_number("mu_j", mu_j)
    szz = rho_g * r / (k * mu_j) * -np.expm1(-k * mu_j * z / r)
    return szz, k * szz


def silo_xi(z, r, dr, k: float) -> np.ndarray:
    """xi(z) = int_0^z (r'² + k)/(r (1 + r'²)^{3/2}) du (Eq. 3.12) by adaptive quadrature; r, dr callables."""
    integrand = _xi_integrand(r, dr, k)
    z = np.atleast_1d(np.asarray(z, dtype=np.float64))
    return np.array([integrate.quad(integrand, 0.0, zz, epsabs=0, epsrel=1e-12, limit=200)[0] for zz in z])


def _xi_integrand(r, dr, k):
    def f(u):
        d2 = dr(u) ** 2
        return (d2 + k) / (r(u) * (1 + d2) ** 1.5)

    return f


def silo_sigma_zz(z, r, dr, k: float, mu_j: float, rho_g: float, xi=None) -> np.ndarray:
    """Vertical stress in a silo of any shape r(z) (Eqs. 3.10-3.12).

    Parameters
    ----------
    z : array_like
        Depths (m) below the free surface.
    r, dr : callable
        Half-width r(z) and its derivative r'(z).
    k, mu_j, rho_g : float
        As in :func:`janssen`.
    xi : callable, optional
        xi(z) in closed form (any additive constant, Eq. 3.13); default: quadrature of Eq. 3.12.

    Returns
    -------
    ndarray
        sigma_zz(z).
    """
    z = np.atleast_1d(np.asarray(z, dtype=np.float64))
    if xi is None:
        integrand = _xi_integrand(r, dr, k)

        def xi(u):
            return integrate.quad(integrand, 0.0, u, epsabs=0, epsrel=1e-12, limit=200)[0]

    out = np.empty_like(z)
    for m, zz in enumerate(z):
        x0 = float(xi(zz))
        val = integrate.quad(
            lambda u, x0=x0: math.exp(mu_j * (float(xi(u)) - x0)), 0.0, zz, epsabs=0, epsrel=1e-12, limit=200
        )[0]
        out[m] = rho_g * val
    return out


def stepped_silo(z, r1: float, r2: float, h0: float, k: float, mu_j: float, rho_g: float) -> np.ndarray:
    """Wall pressure sigma_xx of a silo narrowing from half-width r1 to r2 at depth h0 (Eq. 3.15).

    The solution restarts Janssen at h0 with the stress reached there; valid for r1 > r2 only.
    """
    r1, r2 = positive_number("r1", r1), positive_number("r2", r2)
    if r2 >= r1:
        raise PorepipeError(
            f"stepped silo: Eq. 3.15 holds only for a narrowing step, got r1 = {r1} <= r2 = {r2}"
        )
    z = np.asarray(z, dtype=np.float64)
    c = mu_j * k
    upper = rho_g * r1 / mu_j * -np.expm1(-c * z / r1)
    zl = np.maximum(z, h0)
    lower = (
        rho_g
        / mu_j
        * (
            (r1 - r2) * np.exp(c * (h0 - zl) / r2)
            + r2
            - r1 * np.exp(c * (h0 * r1 - r1 * zl - h0 * r2) / (r1 * r2))
        )
    )
    return np.where(z <= h0, upper, lower)


def hopper_sigma_zz(z, a: float, b: float, k: float, mu_j: float, rho_g: float) -> np.ndarray:
    """Vertical stress in a hopper r = a z + b (a < 0, z < -b/a), corrected Eq. 3.18.

    sigma_zz = alpha rho g/(mu_j (a² + k) + alpha a) [(b + a z) - (b + a z)^(-beta) b^(beta + 1)],
    alpha = (1 + a²)^{3/2}, beta = mu_j (a² + k)/(alpha a).
    """
    if not a < 0:
        raise PorepipeError(f"hopper: the wall slope a must be negative (narrowing downwards), got {a}")
    b = positive_number("b", b)
    z = np.asarray(z, dtype=np.float64)
    if np.any(z >= -b / a):
        raise PorepipeError(f"hopper: depth must stay above the apex z = -b/a = {-b / a:.6g} m")
    alpha = (1 + a * a) ** 1.5
    beta = mu_j * (a * a + k) / (alpha * a)
    r = b + a * z
    return alpha * rho_g / (mu_j * (a * a + k) + alpha * a) * (r - r ** (-beta) * b ** (beta + 1))


def parabolic_xi(z, a: float, b: float, k: float) -> np.ndarray:
    """xi(z) of the parabolic silo r = sqrt((b - z)/a) (Eq. 3.20), up to the constant of Eq. 3.13."""
    z = np.asarray(z, dtype=np.float64)
    return (1 - 4 * k * a * b + 4 * k * a * z - 2 * k) / np.sqrt(4 * a * b - 4 * a * z + 1)


def parabolic_r_p(a: float, b: float, k: float) -> float:
    """Effective Janssen radius r_P = k (1 + 4ab)^{3/2}/(2a (1 + 4kab)) of the parabolic silo (Eq. 3.22, corrected).

    It is k/xi'(0): near the top the parabolic silo is a Janssen silo of half-width r_P (Eq. 3.24).
    """
    a, b = positive_number("a", a), positive_number("b", b)
    return k * (1 + 4 * a * b) ** 1.5 / (2 * a * (1 + 4 * k * a * b))


def parabolic_sigma_zz(z, a: float, b: float, k: float, mu_j: float, rho_g: float) -> np.ndarray:
    """Vertical stress in the parabolic silo r = sqrt((b - z)/a) (Eq. 3.11 with the closed-form xi of Eq. 3.20)."""
    a, b = positive_number("a", a), positive_number("b", b)

    def r(u):
        return math.sqrt((b - u) / a)

    def dr(u):
        return -0.5 / (a * r(u))

    def xi(u):
        return float(parabolic_xi(u, a, b, k))

    return silo_sigma_zz(z, r, dr, k, mu_j, rho_g, xi=xi)


#: bounds of k and mu_j in :func:`fit_janssen`'s least squares
_JANSSEN_BOUNDS = (1e-3, 20.0)


def fit_janssen(depth_m, wall_pressure, r: float, rho_g: float, k: float | None = None) -> dict[str, float]:
    """Least-squares fit of Janssen's wall pressure (Eq. 3.4) to a measured profile.

    Parameters
    ----------
    depth_m, wall_pressure : array_like
        Depth below the free surface (m) and wall pressure sigma_xx at that depth.
    r : float
        Half-width of the silo.
    rho_g : float
        Bulk weight per area (rho_rel rho_particle g in 2-D).
    k : float, optional
        Fix k (e.g. measured as sigma_xx/sigma_zz from stress tensors) and fit mu_j only; default fits both.

    Returns
    -------
    dict
        ``k``, ``mu_j``, their standard errors ``k_err``, ``mu_j_err``, ``rms`` (residual, same unit as p), and
        ``at_bound``: a fitted parameter sits on its bound (1e-3 or 20): the profile is not Janssen's (e.g. a
        pressure that falls with depth), and the errors at the bound mean nothing.

    Raises
    ------
    PorepipeError
        Fewer than 3 finite points, or a pressure that is nowhere positive (it gave scipy's "initial guess is outside
        of provided bounds"); a given ``k`` that is not finite and positive (from :func:`janssen`).
    """
    from scipy.optimize import curve_fit

    z = np.asarray(depth_m, dtype=np.float64)
    p = np.asarray(wall_pressure, dtype=np.float64)
    good = np.isfinite(z) & np.isfinite(p)
    z, p = z[good], p[good]
    if len(z) < 3:
        raise PorepipeError(f"fit_janssen: need at least 3 finite points of the wall pressure, got {len(z)}")
    if not p.max() > 0:
        raise PorepipeError(
            f"fit_janssen: the wall pressure is nowhere positive (max {p.max():.3g}): nothing to fit"
        )
    lo, hi = _JANSSEN_BOUNDS
    mu0 = min(max(rho_g * r / p.max(), 0.05), hi)
    if k is None:

        def model(zz, kk, mm):
            return janssen(zz, r, kk, mm, rho_g)[1]

        popt, pcov = curve_fit(model, z, p, p0=(0.6, mu0), bounds=([lo, lo], [hi, hi]))
        err = np.sqrt(np.diag(pcov))
        kk, mm, kerr, merr = popt[0], popt[1], err[0], err[1]
    else:

        def model(zz, mm):
            return janssen(zz, r, k, mm, rho_g)[1]

        popt, pcov = curve_fit(model, z, p, p0=(mu0,), bounds=([lo], [hi]))
        kk, mm, kerr, merr = k, popt[0], 0.0, float(np.sqrt(pcov[0, 0]))
    rms = float(np.sqrt(np.mean((janssen(z, r, kk, mm, rho_g)[1] - p) ** 2)))
    at_bound = bool(np.any(np.isclose(popt, lo, rtol=1e-6) | np.isclose(popt, hi, rtol=1e-6)))
    return {
        "k": float(kk),
        "mu_j": float(mm),
        "k_err": float(kerr),
        "mu_j_err": float(merr),
        "rms": rms,
        "at_bound": at_bound,
    }


# -- heaps (Wittmer-Cates-Claudin) -------------------------------------------------------------------------------
def closure_ife(u, phi: float, branch: int = 1) -> np.ndarray:
    """IFE closure C(U) = sigma_xx/sigma_zz at Mohr-Coulomb failure (Eq. 1.18 with 1/cos² phi).

    ``branch`` +1 is the passive (larger) root, -1 the active one; |U| <= tan(phi) required.
    """
    u = np.asarray(u, dtype=np.float64)
    s, c = math.sin(phi), math.cos(phi)
    root = np.sqrt(1 - (u / math.tan(phi)) ** 2)
    return (1 + s * s + 2 * branch * s * root) / (c * c)


def closure_linear(model: str, phi: float, K: float | None = None, tau: float | None = None):
    """(eta, mu) of a linear closure sigma_xx = eta sigma_zz + mu sigma_xz (Eqs. 1.19-1.23).

    Parameters
    ----------
    model : {"BCC", "FPA", "OSL"}
        BCC: eta = eta_0 = 1/(1 + 2 tan² phi), mu = 0; FPA: eta = 1, mu = -2 tan(phi); OSL: Eq. 1.23 from K and tau.
    phi : float
        Repose angle, rad.
    K, tau : float, optional
        OSL's sigma_nn = K sigma_mm in axes turned by tau (rad) from the vertical.
    """
    t = math.tan(phi)
    if model == "BCC":
        return 1 / (1 + 2 * t * t), 0.0
    if model == "FPA":
        return 1.0, -2 * t
    if model == "OSL":
        if K is None or tau is None:
            raise PorepipeError("OSL closure needs K and tau")
        t2 = math.tan(tau) ** 2
        return (K - t2) / (1 - K * t2), 2 * (K + 1) * t2 / (1 - K * t2)
    raise PorepipeError(f"unknown closure {model!r}: use BCC, FPA, OSL (IFE is closure_ife)")


def wedge_stress(S, phi: float, eta: float, mu: float) -> dict[str, np.ndarray]:
    """Scaled stresses s_ij(S) = sigma_ij/(g z) of a 2-D heap with a linear closure (Eqs. 1.24-1.31).

    Right half (S >= 0; sigma_xz is odd, the others even in x). Outer region c1 tan(phi) < S <= 1:
    s = s* (1 - S) (c - mu, eta c, eta) with c = cot(phi), s* = c/(c² - mu c - eta); inner region:
    s = s* (c - c1)/c1 (c1 - mu S, eta c1, eta S), c1 = (mu + sqrt(mu² + 4 eta))/2.

    Returns
    -------
    dict
        ``zz``, ``xx``, ``xz`` and ``S_c`` (the boundary c1 tan(phi)).
    """
    S = np.abs(np.asarray(S, dtype=np.float64))
    c = 1 / math.tan(phi)
    c1 = 0.5 * (mu + math.sqrt(mu * mu + 4 * eta))
    den = c * c - mu * c - eta
    if not (0 < c1 < c and den > 0):
        raise PorepipeError(
            f"wedge_stress: closure (eta = {eta:.4g}, mu = {mu:.4g}) has c1 = {c1:.4g} outside (0, cot phi = {c:.4g})"
        )
    s_star = c / den
    s_c = c1 / c
    inner = s_c >= S
    a = s_star * (1 - S)
    b = s_star * (c - c1) / c1
    return {
        "zz": np.where(inner, b * (c1 - mu * S), a * (c - mu)),
        "xx": np.where(inner, b * eta * c1, a * eta * c),
        "xz": np.where(inner, b * eta * S, a * eta),
        "S_c": s_c,
    }


def principal_angle(sxx, szz, sxz) -> np.ndarray:
    """Angle Psi (rad) of the major principal stress axis from the vertical, in (-pi/2, pi/2]."""
    sxx, szz, sxz = (np.asarray(v, dtype=np.float64) for v in (sxx, szz, sxz))
    # major axis direction (sin Psi, cos Psi): tan(2 Psi) = 2 sxz/(szz - sxx)
    return 0.5 * np.arctan2(2 * sxz, szz - sxx)
