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


def fit_length_series(r_over_l, d, d_err) -> dict:
    """Weighted least squares of 1/D = c + s·(r/L) (weights from the errors of D); α = s/c, D₀ = 1/c.

    Errors: the parameter covariance of the weighted fit (statistical errors of D only), propagated to α and D₀.
    """
    x, d, d_err = (np.asarray(v, dtype=float) for v in (r_over_l, d, d_err))
    if x.size < 2 or not (x.shape == d.shape == d_err.shape):
        raise PorepipeError(f"the length series needs >= 2 lengths with D and its error, got {x.size}")
    finite = np.all(np.isfinite(x)) and np.all(np.isfinite(d)) and np.all(np.isfinite(d_err))
    if not finite or np.any(d <= 0) or np.any(d_err <= 0) or np.unique(x).size < 2:
        raise PorepipeError(
            "the length series needs finite r/L, D > 0 and errors > 0, and at least two distinct lengths"
        )
    y = 1.0 / d
    sy = d_err / d**2
    a = np.column_stack([np.ones_like(x), x]) / sy[:, None]
    cov = np.linalg.inv(a.T @ a)
    c, s = cov @ (a.T @ (y / sy))
    alpha = s / c
    grad = np.array([-s / c**2, 1.0 / c])
    chi2 = float(np.sum(((y - c - s * x) / sy) ** 2))
    return {
        "alpha": float(alpha),
        "alpha_err": float(math.sqrt(grad @ cov @ grad)),
        "D0": float(1.0 / c),
        "D0_err": float(math.sqrt(cov[0, 0]) / c**2),
        "chi2_per_dof": chi2 / max(x.size - 2, 1),
    }


def length_series(
    pore, axis: int, lengths, settings, voxel_um=1.0, periodic=(False, False, False), seed=0
) -> dict:
    """Transmission (``settings`` with setup transmission) through ``pore[..., :L]`` along ``axis`` for each L.

    Returns ``series_length`` (voxels), ``series_W``/``series_W_err``, ``series_D``/``series_D_err`` (D = v̄LW/4
    in the transport's units), ``series_r_over_L`` and the fit of :func:`fit_length_series` with ``r_equal_area``.
    """
    from porepipe.diffusion._api import transport

    pore = np.asarray(pore)
    n = pore.shape[axis]
    lengths = [int(v) for v in lengths]
    if len(lengths) < 2 or min(lengths) < 1 or max(lengths) > n:
        raise PorepipeError(
            f"diffusion.lengths must hold >= 2 lengths in [1, {n}] voxels along the axis, got {lengths}"
        )
    rows = []
    for length in lengths:
        cut = [slice(None)] * 3
        cut[axis] = slice(0, length)
        res = transport(np.ascontiguousarray(pore[tuple(cut)]), axis, settings, voxel_um, periodic, seed=seed)
        v = res.values
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
        "r_equal_area": r,
    }
    out.update(fit_length_series(x, arr[:, 3], arr[:, 4]))
    return out
