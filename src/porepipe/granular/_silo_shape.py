"""Shaped 2-D silos (Schinner 2001 ch. 3): half-width r(z) of each shape, its wall slabs, and its stress theory.

z is the depth below the silo's top, as in the thesis. The theory of §3.2-3.5 measures z from the *free surface of
the fill*; a fill whose surface lies z_s below the top sees the same shape family with shifted parameters
(stepped h0 - z_s, hopper b + a z_s, parabolic b - z_s), which :func:`shaped_sigma_zz` applies.
"""

from __future__ import annotations

import math

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.granular import _theory as T
from porepipe.granular._settings import Silo, SiloShape


def silo_half_width(silo: Silo, z) -> np.ndarray:
    """r(z) of the silo's inner wall surface at depth z below its top (the step of a stepped silo belongs above)."""
    return silo.half_width(z)


def _slab(x_inner_a, y_a, x_inner_b, y_b, t, side):
    """A wall slab: its inner face from (x_a, y_a) to (x_b, y_b), thickness t outwards (side -1 left, +1 right)."""
    return np.array(
        [(x_inner_a, y_a), (x_inner_b, y_b), (x_inner_b + side * t, y_b), (x_inner_a + side * t, y_a)]
    )


def silo_wall_slabs(silo: Silo) -> list[tuple[str, np.ndarray]]:
    """(name, corners) of every wall of the silo: side slabs ("silo left …", "silo right …") and "silo floor"."""
    xc, t, d = silo.axis_x_m, silo.thickness_m, silo.depth_m
    top = silo.bottom_m + d
    out = []
    for side, word in ((-1, "left"), (1, "right")):
        if silo.shape is SiloShape.stepped:
            r1, r2, h0 = silo.r1_m, silo.r2_m, silo.h0_m
            y0 = top - h0
            out += [
                (f"silo {word} upper", _slab(xc + side * r1, top, xc + side * r1, y0, t, side)),
                (f"silo {word} step", _box(xc + side * r2, y0 - t, xc + side * (r1 + t), y0)),
                (
                    f"silo {word} lower",
                    _slab(xc + side * r2, y0 - t, xc + side * r2, silo.bottom_m - t, t, side),
                ),
            ]
            continue
        z = silo.wall_corner_depths()
        n = len(z) - 1
        x = xc + side * silo_half_width(silo, z)
        for k in range(n):
            name = f"silo {word}" if n == 1 else f"silo {word} {k}"
            y_low = silo.bottom_m - t if k == n - 1 else top - z[k + 1]
            x_low = x[k + 1] if k < n - 1 else x[n] + (x[n] - x[n - 1]) * t / (z[n] - z[n - 1])
            out.append((name, _slab(x[k], top - z[k], x_low, y_low, t, side)))
    rb = float(silo_half_width(silo, d))
    out.append(("silo floor", _box(xc - rb - 2 * t, silo.bottom_m - t, xc + rb + 2 * t, silo.bottom_m)))
    return out


def _box(xa, ya, xb, yb):
    x0, x1 = min(xa, xb), max(xa, xb)
    return np.array([(x0, ya), (x1, ya), (x1, yb), (x0, yb)])


def shifted_silo(silo: Silo, z_s: float) -> Silo:
    """The same silo seen from a fill surface z_s below its top: r_new(z) = r(z + z_s)."""
    z_s = float(z_s)
    if silo.shape is SiloShape.stepped:
        if z_s >= silo.h0_m:
            return silo.model_copy(
                update={"shape": SiloShape.straight, "r_m": silo.r2_m, **_none("r1_m", "r2_m", "h0_m")}
            )
        return silo.model_copy(update={"h0_m": silo.h0_m - z_s, "depth_m": silo.depth_m - z_s})
    if silo.shape is SiloShape.hopper:
        return silo.model_copy(update={"b_m": silo.b_m + silo.slope * z_s, "depth_m": silo.depth_m - z_s})
    if silo.shape is SiloShape.parabolic:
        return silo.model_copy(update={"b_m": silo.b_m - z_s, "depth_m": silo.depth_m - z_s})
    return silo.model_copy(update={"depth_m": silo.depth_m - z_s})


def _none(*keys):
    return dict.fromkeys(keys)


def shaped_sigma_zz(silo: Silo, z, k: float, mu_j: float, rho_g: float) -> np.ndarray:
    """Vertical stress sigma_zz at depth z below the free surface of a fill that reaches the silo's top.

    Straight: Janssen (Eq. 3.4); stepped: Eq. 3.15 over k; hopper: corrected Eq. 3.18; parabolic: Eq. 3.11 with
    the closed-form xi of Eq. 3.20. For a fill surface below the top, pass :func:`shifted_silo` of the silo.
    """
    z = np.asarray(z, dtype=np.float64)
    if silo.shape is SiloShape.straight:
        return T.janssen(z, silo.r_m, k, mu_j, rho_g)[0]
    if silo.shape is SiloShape.stepped:
        return T.stepped_silo(z, silo.r1_m, silo.r2_m, silo.h0_m, k, mu_j, rho_g) / k
    if silo.shape is SiloShape.hopper:
        return T.hopper_sigma_zz(z, silo.slope, silo.b_m, k, mu_j, rho_g)
    return T.parabolic_sigma_zz(z, silo.a_per_m, silo.b_m, k, mu_j, rho_g)


def fit_shaped_mu_j(silo: Silo, depth_m, sigma_xx, k: float, rho_g: float) -> dict[str, float]:
    """Least-squares mu_j of sigma_xx = k sigma_zz(z; shape) against a measured wall-pressure profile, k fixed.

    The thesis fitted mu_j this way for every shape (§3.1-3.5; Eqs. 3.4, 3.15, 3.18, 3.24).

    Returns
    -------
    dict
        ``mu_j``, ``mu_j_err`` (standard error of the fit) and ``rms`` (residual, same unit as sigma_xx).
    """
    from scipy.optimize import curve_fit

    z = np.asarray(depth_m, dtype=np.float64)
    p = np.asarray(sigma_xx, dtype=np.float64)
    good = np.isfinite(z) & np.isfinite(p)
    z, p = z[good], p[good]
    if len(z) < 3:
        raise PorepipeError(
            f"fit_shaped_mu_j: need at least 3 finite points of the wall pressure, got {len(z)}"
        )
    if not (math.isfinite(k) and k > 0):
        raise PorepipeError(f"fit_shaped_mu_j: k must be a positive number, got {k}")

    def model(zz, mm):
        return k * shaped_sigma_zz(silo, zz, k, mm, rho_g)

    popt, pcov = curve_fit(model, z, p, p0=(0.3,), bounds=([1e-3], [5.0]))
    rms = float(np.sqrt(np.mean((model(z, popt[0]) - p) ** 2)))
    return {"mu_j": float(popt[0]), "mu_j_err": float(np.sqrt(pcov[0, 0])), "rms": rms}
