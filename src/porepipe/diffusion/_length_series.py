"""Length dependence of the Knudsen resistance (Mahler 2001 §3.6.4).

Transmission through the first L voxels of a volume along the transport axis for each L of a series, and the fit of
(3.51):

    1/D(r/L) = 1/D₀ + α·(r/L)/D₀,

with D = v̄·L·W/4 (the transmission diffusivity) and r the equal-area radius √(A_open/π) of the inlet (the thesis's
r = 30/√π for its 30 × 30 square channel). The literature's α = 2.9 [65]; the thesis measured α = 8.55 (isotropic
walls, r = 16.93 nm, Kn ≈ 200); for a diffuse cylinder Clausing's exact W gives α_eff = 8/(3W) − L/R, 2.83-4.85 for
L/R = 0.5-40 (digest §5.4), so α depends on the lengths fitted.
"""

from __future__ import annotations

import math

import numpy as np

from porepipe._shared.errors import PorepipeError


def weighted_line(x, d, d_err, what: str) -> dict:
    """Weighted least squares of 1/D = c + s·x through (x, D ± D_err), the error of 1/D being σ = D_err/D².

    Solved in exactly rescaled units, so any finite positive D and errors work, however small or large: 1/D, σ and x
    are each divided by a power of two (exact in floating point) that brings them near 1 — the smallest σ to about
    1 — and the solution is scaled back the same exact way. The parameters do not change under one common factor
    on all the errors, and they do not here (the plain normal equations overflowed at errors of 1e-200: weights
    1/σ² = 1e400, parameters NaN). A point whose σ is more than ~1e308 times the smallest has no weight (it
    underflows to 0, its limit); fewer than two distinct x with weight are refused. Returns ``c``, ``s``, their
    standard errors ``c_err``, ``s_err``, ``alpha`` = s/c with ``alpha_err`` (delta method), ``inv_c`` = 1/c with
    ``inv_c_err``, and ``chi2_per_dof``: χ² grows as 1/σ², and where it exceeds the float range (residuals of 1e-16
    of 1/D on errors of 1e-200 are 1e184 σ) it is inf — that is its value, not a failure of the fit. Every other
    entry is the exact fit's, rounded once.

    Parameters
    ----------
    x, d, d_err : (n,) array_like
        Abscissae, D > 0 and its errors > 0, all finite.
    what : str
        Names the fit in the error message.
    """
    x, d, d_err = (np.asarray(v, dtype=float) for v in (x, d, d_err))
    if x.ndim != 1 or x.size < 2 or not (x.shape == d.shape == d_err.shape):
        raise PorepipeError(f"{what} needs >= 2 points with D and its error, got {x.size}")
    finite = np.all(np.isfinite(x)) and np.all(np.isfinite(d)) and np.all(np.isfinite(d_err))
    if not finite or np.any(d <= 0) or np.any(d_err <= 0) or np.unique(x).size < 2:
        raise PorepipeError(
            f"{what} needs finite values, D > 0 and errors > 0, and at least two distinct points"
        )
    # mantissa · 2**exponent of D and of its error: 1/D and σ = D_err/D² follow without overflow or underflow
    md, ed = np.frexp(d)
    me, ee = np.frexp(d_err)
    ed, ee = ed.astype(np.int64), ee.astype(np.int64)
    ey = int((-ed).max())  # 1/D = 2**ey · u, u in (0, 2]
    u = np.ldexp(1.0 / md, -ed - ey)
    sig_exp = ee - 2 * ed
    k = int(sig_exp.min())  # σ = 2**k · t, t >= 1/2 (inf: no weight)
    with np.errstate(over="ignore"):
        t = np.ldexp(me / md**2, sig_exp - k)
    ex = int(np.frexp(np.abs(x).max())[1])  # x = 2**ex · xn, |xn| < 1
    xn = np.ldexp(x, -ex)
    w = 1.0 / t
    q, r = np.linalg.qr(np.column_stack([w, xn * w]))
    if np.unique(x[w > 0]).size < 2 or abs(r[1, 1]) <= 1e-12 * abs(r[0, 0]):
        raise PorepipeError(
            f"{what}: fewer than two distinct points keep a weight (their errors span more than the float "
            "range); give errors within 1e300 of each other"
        )
    cn, sn = np.linalg.solve(r, q.T @ (u * w))
    r_inv = np.linalg.inv(r)
    cov = r_inv @ r_inv.T  # of (cn, sn) for the errors t; that of (c, s) is 2**(2k) · diag(1, 2**-ex) · this
    grad = np.array([-sn / cn**2, 1.0 / cn])  # of s/c in the scaled units
    with np.errstate(over="ignore", divide="ignore"):
        chi2 = np.ldexp(float(np.sum(((u - cn - sn * xn) * w) ** 2)) / max(x.size - 2, 1), 2 * (ey - k))
        return {
            key: float(value)
            for key, value in (
                ("c", np.ldexp(cn, ey)),
                ("c_err", np.ldexp(math.sqrt(cov[0, 0]), k)),
                ("s", np.ldexp(sn, ey - ex)),
                ("s_err", np.ldexp(math.sqrt(cov[1, 1]), k - ex)),
                ("alpha", np.ldexp(sn / cn, -ex)),
                ("alpha_err", np.ldexp(math.sqrt(grad @ cov @ grad), k - ey - ex)),
                ("inv_c", np.ldexp(1.0 / cn, -ey)),
                ("inv_c_err", np.ldexp(math.sqrt(cov[0, 0]) / cn**2, k - 2 * ey)),
                ("chi2_per_dof", chi2),
            )
        }


def fit_length_series(r_over_l, d, d_err) -> dict:
    """Weighted least squares of 1/D = c + s·(r/L) (weights from the errors of D); α = s/c, D₀ = 1/c.

    Errors: the parameter covariance of the weighted fit (statistical errors of D only), propagated to α and D₀.
    Any finite positive D and errors work (:func:`weighted_line`: exactly rescaled; χ²/dof beyond the float range
    is inf).
    """
    fit = weighted_line(r_over_l, d, d_err, "the length series")
    return {
        "alpha": fit["alpha"],
        "alpha_err": fit["alpha_err"],
        "D0": fit["inv_c"],
        "D0_err": fit["inv_c_err"],
        "chi2_per_dof": fit["chi2_per_dof"],
    }


def length_series(
    pore, axis: int, lengths, settings, voxel_um=1.0, periodic=(False, False, False), seed=0
) -> dict:
    """Transmission (``settings`` with setup transmission) through ``pore[..., :L]`` along ``axis`` for each L.

    Returns ``series_length`` (voxels), ``series_W``/``series_W_err``, ``series_D``/``series_D_err`` (D = v̄LW/4
    in the transport's units), ``series_r_over_L``, ``series_target_met`` (1/0: W's relative error reached
    ``target_rel_error``) and ``series_rel_error`` per length, and the fit of :func:`fit_length_series` with
    ``r_equal_area``.
    """
    return series_runs(pore, axis, lengths, settings, voxel_um, periodic, seed)[0]


def series_runs(pore, axis: int, lengths, settings, voxel_um=1.0, periodic=(False, False, False), seed=0):
    """:func:`length_series` and the tallies of its runs, one per length (what stopped each: the result records it).

    Returns
    -------
    (dict, list of porepipe.diffusion._api.Tallies)
    """
    from porepipe.diffusion._api import transport

    pore = np.asarray(pore)
    n = pore.shape[axis]
    lengths = [int(v) for v in lengths]
    if len(lengths) < 2 or min(lengths) < 1 or max(lengths) > n:
        raise PorepipeError(
            f"diffusion.lengths must hold >= 2 lengths in [1, {n}] voxels along the axis, got {lengths}"
        )
    rows, runs = [], []
    for length in lengths:
        cut = [slice(None)] * 3
        cut[axis] = slice(0, length)
        res = transport(np.ascontiguousarray(pore[tuple(cut)]), axis, settings, voxel_um, periodic, seed=seed)
        v = res.values
        runs.append(res.tallies)
        rows.append((length, v["W"], v["W_err"], v["D"], v["D_err"], v["open_area"], v["length"]))
    arr = np.array(rows, dtype=float)
    r = math.sqrt(arr[0, 5] / math.pi)
    x = r / arr[:, 6]
    out = {
        "series_length": arr[:, 0],
        "series_W": arr[:, 1],
        "series_W_err": arr[:, 2],
        "series_D": arr[:, 3],
        "series_D_err": arr[:, 4],
        "series_r_over_L": x,
        "series_target_met": np.array([t.stopped_by == "target_rel_error" for t in runs], dtype=float),
        "series_rel_error": np.array([t.rel_error for t in runs], dtype=float),
        "r_equal_area": r,
    }
    out.update(fit_length_series(x, arr[:, 3], arr[:, 4]))
    return out, runs
