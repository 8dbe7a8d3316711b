"""Reaction-diffusion evaluation of Mahler 2001 §4.2: r_eff, k₀^max, η, Φ (bisection of tanh Φ/Φ = η), D_R, α_R.

Conventions (the thesis's formulas made dimensionally consistent, spec §6.2):

- k = w·ν_wall is the per-particle first-order rate constant (1/time): w the reaction probability per wall hit,
  ν_wall the wall hits per particle per time (kinetic theory: v̄·S/(4V) for an equilibrium gas).
- r_eff (4.3) = products leaving the inlet per time per pore volume; with N particles in the pore volume V_P (total
  concentration c₀ = N/V_P, uniform because product and reactant are the same gas), r_max = k·c₀.
- k₀^max (4.4) = lim_{w→0} r_eff/(w·c₀): the wall-hit rate; η (4.5) = r_eff/(k₀^max·w·c₀).
- Φ = L·√(k/D) (4.6) for a slab of depth L fed from one face (closed back wall), η = tanh Φ/Φ (4.7).
- 1/D_R = Φ²/(L²·k) (4.12); 1/D_R(η) = 1/D_R(1)·(1 + α_R·(1 − η)/η) (4.13).
"""

from __future__ import annotations

import math

import numpy as np

from porepipe._shared.errors import PorepipeError


def eta_of_phi(phi):
    """Slab effectiveness factor η = tanh Φ / Φ (4.7); η(0) = 1. Φ = L·√(k/D) >= 0."""
    phi = np.asarray(phi, dtype=float)
    if np.any(phi < 0):
        raise PorepipeError(f"the Thiele modulus must be >= 0 (Φ = L·√(k/D)), got {float(phi.min())!r}")
    small = phi <= 1e-8
    safe = np.where(small, 1.0, phi)
    tiny = np.where(small, phi, 0.0)  # the series only where it is used: Φ² of a large Φ overflows
    return np.where(small, 1.0 - tiny * tiny / 3.0, np.tanh(safe) / safe)


def phi_of_eta(eta: float, tol: float = 1e-12) -> float:
    """Thiele modulus Φ with tanh Φ/Φ = η, by bisection (the thesis's method; no closed inverse exists).

    η must lie in (0, 1]; η = 1 gives Φ = 0. The bracket is [0, 1/η + 1]: tanh Φ/Φ < η there since tanh < 1.
    """
    if not (0.0 < eta <= 1.0) or not math.isfinite(eta):
        raise PorepipeError(f"the effectiveness factor must lie in (0, 1], got {eta!r}")
    if eta == 1.0:
        return 0.0
    lo, hi = 0.0, 1.0 / eta + 1.0
    while hi - lo > tol * max(1.0, hi):
        mid = 0.5 * (lo + hi)
        if float(eta_of_phi(mid)) > eta:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def thiele_modulus(length: float, k: float, d: float) -> float:
    """Φ = L·√(k/D) (4.6) for a slab of depth ``length`` (k per particle and time, D intrinsic)."""
    if not (length > 0 and k >= 0 and d > 0):
        raise PorepipeError(f"Thiele modulus needs length > 0, k >= 0, D > 0; got {length}, {k}, {d}")
    return length * math.sqrt(k / d)


def r_eff(products: float, time: float, pore_volume: float) -> float:
    """(4.3) effective rate: products leaving per time per pore volume."""
    return products / time / pore_volume


def k0_max(r_max: float, w: float, concentration: float) -> float:
    """(4.4) k₀^max = r_max/(w·c₀) from a run at w → 0 (η ≈ 1); c₀ = N_ges/V_P."""
    return r_max / (w * concentration)


def effectiveness(r: float, k0max: float, w: float, concentration: float) -> float:
    """(4.5) η = r_eff/(k₀^max·w·c₀)."""
    return r / (k0max * w * concentration)


def diffusion_under_reaction(phi: float, length: float, k: float) -> float:
    """(4.12) D_R = L²·k/Φ² (infinite for Φ = 0)."""
    return math.inf if phi == 0 else length * length * k / (phi * phi)


def fit_alpha_r(eta, d_r) -> tuple[float, float, float]:
    """(4.13) fit 1/D_R = a + b·(1 − η)/η by least squares; returns (α_R = b/a, a, b).

    ``eta`` and ``d_r`` are arrays of runs at several w; a = 1/D_R(η = 1).
    """
    eta, d_r = np.asarray(eta, float), np.asarray(d_r, float)
    if eta.size < 2 or eta.shape != d_r.shape:
        raise PorepipeError(f"α_R needs >= 2 (η, D_R) pairs of equal length, got {eta.size} and {d_r.size}")
    x = (1.0 - eta) / eta
    b, a = np.polyfit(x, 1.0 / d_r, 1)
    return float(b / a), float(a), float(b)


def profile_phi(z_over_l, c_over_c0) -> float:
    """(4.11) Φ from a least-squares fit of c/c₀ = cosh(Φ(1 − z/L))/cosh Φ to a measured reactant profile.

    Golden-section search of the squared residual over Φ in [0, 50] (the residual is unimodal in Φ for a profile
    that falls from 1).
    """
    z, c = np.asarray(z_over_l, float), np.asarray(c_over_c0, float)
    if z.size < 2 or z.shape != c.shape:
        raise PorepipeError("the profile fit needs >= 2 points with equal-length z and c")

    def cost(phi):
        return float(np.sum((np.cosh(phi * (1.0 - z)) / np.cosh(phi) - c) ** 2))

    lo, hi = 0.0, 50.0
    g = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - g * (hi - lo), lo + g * (hi - lo)
    while hi - lo > 1e-9:
        if cost(a) < cost(b):
            hi = b
        else:
            lo = a
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
    return 0.5 * (lo + hi)


def eta_slab_mouth(phi, length: float, d: float, vmean: float):
    """η of a one-face-fed slab whose mouth meets a Knudsen reservoir: tanh Φ/Φ / (1 + (2D/v̄)(Φ/L) tanh Φ).

    The reservoir at c₀ feeds the pore through a Marshak (Robin) condition c(0) − (2D/v̄)·c'(0) = c₀ instead of
    c(0) = c₀: the net flux through the mouth is the difference of the one-way fluxes v̄c/4 ± (D/2)c'. The
    correction is of order (D/v̄)·Φ/L, i.e. channel width over decay length, and vanishes for long pores.
    """
    phi = np.asarray(phi, dtype=float)
    return eta_of_phi(phi) / (1.0 + 2.0 * d / vmean * phi / length * np.tanh(phi))
