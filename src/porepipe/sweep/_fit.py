"""Extrapolation to infinite resolution: q(a) = q∞ + c·a^p, and the thesis's linear-in-1/L form.

A fit returns a :class:`Limit` that carries its own verdict: a number with an error bar when the data support a
limit, otherwise the reason (too few points, non-monotonic data, residual as large as the trend).
"""

from __future__ import annotations

import dataclasses
import enum

import numpy as np

from porepipe._shared.errors import PorepipeError

#: range of a fitted exponent p; a fit that ends on either bound is not trusted
P_BOUNDS = (0.2, 6.0)
#: a fit is poor when it explains less than this fraction of the variance of the data (R²)
MIN_R2 = 0.5
#: with known noise, a fit is poor when chi² this improbable (p-value) is reached
MIN_CHI2_PVALUE = 1e-3


class Status(str, enum.Enum):
    """Verdict of an extrapolation."""

    ok = "ok"
    too_few_points = "too_few_points"
    non_monotonic = "non_monotonic"
    poor_fit = "poor_fit"


@dataclasses.dataclass(frozen=True)
class Limit:
    """The a → 0 limit of one quantity and how far to trust it.

    ``err`` is the half-width of the interval at ``confidence``: the larger of the fit-covariance interval
    (``err_fit``) and the leave-one-resolution-out spread (``err_loo``, the largest change of q∞ when one point is
    dropped). NaN where it cannot be estimated.
    """

    q_inf: float
    err: float
    err_fit: float
    err_loo: float
    c: float
    p: float
    n: int
    status: Status
    why: str
    form: str
    confidence: float

    @property
    def supported(self) -> bool:
        return self.status is Status.ok

    @property
    def rel_err(self) -> float:
        return abs(self.err / self.q_inf) if self.q_inf != 0 and np.isfinite(self.err) else float("inf")

    def text(self, digits: int = 4) -> str:
        """'q∞ ± err' when supported, else the reason (with the bare number where it exists)."""
        if self.supported:
            return f"{self.q_inf:.{digits}g} ± {self.err:.2g}"
        bare = f" (bare value {self.q_inf:.{digits}g})" if np.isfinite(self.q_inf) else ""
        return f"no limit: {self.why}{bare}"

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["status"] = self.status.value
        return d


def two_point_limit(q_coarse: float, q_fine: float, ratio: float = 2.0) -> float:
    """Linear extrapolation through two resolutions whose voxel sizes differ by ``ratio``.

    Notes
    -----
    Zauner (2020) §6.2, Table 6.4: κ linear in 1/L_S with L_S doubling gives κ_extrap = 2κ_h.r. − κ_l.r.
    """
    if not 1 < ratio < np.inf:
        raise PorepipeError(f"two_point_limit needs ratio = a_coarse/a_fine > 1, got {ratio}")
    return (ratio * q_fine - q_coarse) / (ratio - 1.0)


def _check(x, q, sigma):
    x = np.asarray(x, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    if x.ndim != 1 or x.shape != q.shape:
        raise PorepipeError(f"extrapolation needs matching 1-D arrays, got shapes {x.shape} and {q.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(q))):
        raise PorepipeError("extrapolation data contain NaN or Inf; drop those runs first")
    if np.any(x <= 0) or np.unique(x).size != x.size:
        raise PorepipeError(f"resolutions must be positive and distinct, got {x.tolist()}")
    if sigma is not None:
        sigma = np.asarray(sigma, dtype=np.float64)
        if sigma.shape not in ((), x.shape) or not np.all(np.isfinite(sigma) & (sigma > 0)):
            raise PorepipeError(
                f"sigma (noise of each point) must be one positive finite number or one per resolution "
                f"({x.size}), got {sigma.tolist()}"
            )
        sigma = np.broadcast_to(sigma, x.shape).copy()
    order = np.argsort(x)
    return x[order], q[order], (None if sigma is None else sigma[order])


def _linear(x, q, w, p):
    """Weighted least squares of q = q∞ + c·x^p for one p or an array of p (closed-form 2×2 normal equations).

    Returns (q∞, c, weighted SSE), each of the shape of ``p``. Callers pass x scaled to max 1 and q to max |q| 1,
    so the sums are well conditioned.
    """
    p = np.asarray(p, dtype=np.float64)
    z = x ** p[..., None]
    ww = w * w
    sw, sz, szz = ww.sum(), (ww * z).sum(-1), (ww * z * z).sum(-1)
    sy, szy = (ww * q).sum(), (ww * z * q).sum(-1)
    det = sw * szz - sz * sz
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(det > 0, (sw * szy - sz * sy) / det, 0.0)
    q_inf = (sy - c * sz) / sw
    resid = q - q_inf[..., None] - c[..., None] * z
    return q_inf, c, (ww * resid * resid).sum(-1)


def _best_p(x, q, w):
    """Exponent minimising the SSE (variable projection): log grid, then a bounded scalar search."""
    from scipy import optimize  # imported here: every `porepipe` command imports this package

    grid = np.geomspace(*P_BOUNDS, 61)
    sse = _linear(x, q, w, grid)[2]
    i = int(np.argmin(sse))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    res = optimize.minimize_scalar(
        lambda p: float(_linear(x, q, w, p)[2]), bounds=(lo, hi), method="bounded", options={"xatol": 1e-10}
    )
    return float(res.x) if res.fun <= sse[i] else float(grid[i])


def _fit(x, q, w, p_fixed):
    p = p_fixed if p_fixed is not None else _best_p(x, q, w)
    q_inf, c, sse = _linear(x, q, w, p)
    return float(q_inf), float(c), p, float(sse)


def _fit_error(x, w, c, p, sse, dof, known_sigma, confidence, p_free):
    from scipy import stats

    cols = [np.ones_like(x), x**p] + ([c * x**p * np.log(x)] if p_free else [])
    jac = np.column_stack(cols) * w[:, None]
    try:
        cov = np.linalg.pinv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return float("nan")
    if known_sigma:
        return float(stats.norm.ppf(0.5 + confidence / 2) * np.sqrt(max(cov[0, 0], 0.0)))
    scale = sse / dof
    return float(stats.t.ppf(0.5 + confidence / 2, dof) * np.sqrt(max(cov[0, 0] * scale, 0.0)))


def _chi2_sf(value: float, dof: int) -> float:
    from scipy import stats

    return float(stats.chi2.sf(value, dof))


def _monotonic(x, q, sigma):
    d = np.diff(q)
    tol = 2.0 * np.hypot(sigma[1:], sigma[:-1]) if sigma is not None else 1e-12 * max(np.abs(q).max(), 1e-300)
    significant = np.sign(d[np.abs(d) > tol])
    return significant.size == 0 or np.all(significant == significant[0])


def _coefficient(c: float, p: float, q_scale: float, x_scale: float) -> float:
    """The fit's c in the data's units, c q_scale / x_scale^p, from its value in the scaled units of the fit; one line
    when it is beyond float64 (lengths near 1e-100 or 1e100 of their unit: Python's power raised a bare
    ZeroDivisionError or OverflowError there).
    """
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        value = float(np.float64(c) * q_scale / np.float64(x_scale) ** p)
    if np.isfinite(value) and (value != 0.0 or c == 0.0 or not np.isfinite(c)):
        return value
    if not (np.isfinite(c) and np.isfinite(p)):
        return float("nan")
    raise PorepipeError(
        f"the fitted c of q_inf + c*a^p ({c:.3g} in units of the data's largest |q| {q_scale:.3g} and largest a "
        f"{x_scale:.3g}, p = {p:.3g}) is beyond float64 in the data's own units; give the lengths in a unit near "
        "their size"
    )


def fit_power(
    a,
    q,
    exponent: float | None = None,
    sigma=None,
    confidence: float = 0.95,
    form: str = "q(a) = q_inf + c*a^p",
) -> Limit:
    """Fit q(a) = q∞ + c·a^p and judge whether the data support the limit a → 0.

    Parameters
    ----------
    a : (n,) array_like
        Resolutions (voxel sizes, any unit), positive and distinct.
    q : (n,) array_like
        The quantity at each resolution.
    exponent : float, optional
        Fixed p, in the range [0.2, 6] of a fitted one (1: linear in a, 2: quadratic); None fits p.
    sigma : float or (n,) array_like, optional
        Known noise (standard deviation) of each q; None estimates it from the residuals.
    confidence : float
        Coverage of the stated interval ``err`` (Student t on the residual scale when sigma is unknown).

    Returns
    -------
    Limit
        ``status`` ok, or the reason the data cannot support a limit: fewer points than parameters + 1,
        non-monotonic data (a power law is monotonic in a), or a fit that explains less than half the variance
        (or, with known sigma, a chi² p-value below 1e-3) or an exponent on its bound.

    Notes
    -----
    Zauner (2020) uses linear extrapolation in a for porosity bounds (§7.2, Eq. 7.2.1) and linear in 1/L_S for
    permeability (§6.2, Table 6.4); the power law generalises both.
    """
    x, y, s = _check(a, q, sigma)
    if exponent is not None and not P_BOUNDS[0] <= exponent <= P_BOUNDS[1]:
        raise PorepipeError(
            f"the exponent p of q_inf + c*a^p must lie in {list(P_BOUNDS)} (or be None: fitted), got {exponent}"
        )
    if not 0 < confidence < 1:
        raise PorepipeError(f"confidence must lie strictly between 0 and 1, got {confidence}")
    # fit in units of the largest |q| and the largest a, so extreme magnitudes neither overflow nor underflow
    q_scale = float(np.abs(y).max(initial=0.0)) or 1.0
    x_scale = float(x.max(initial=0.0)) or 1.0
    x, y, s = x / x_scale, y / q_scale, (None if s is None else s / q_scale)
    n, k = x.size, (2 if exponent is not None else 3)
    w = np.ones_like(x) if s is None else 1.0 / s
    nan = float("nan")

    def result(q_inf, err_fit, err_loo, c, p, status, why):
        finite = [e for e in (err_fit, err_loo) if np.isfinite(e)]
        err = max(finite) if finite else nan
        return Limit(
            float(q_inf) * q_scale,
            float(err) * q_scale,
            float(err_fit) * q_scale,
            float(err_loo) * q_scale,
            _coefficient(c, p, q_scale, x_scale),
            float(p),
            n,
            status,
            why,
            form,
            confidence,
        )

    if n < k:
        return result(
            nan, nan, nan, nan, exponent or nan, Status.too_few_points, f"{n} point(s) for {k} parameters"
        )
    q_inf, c, p, sse = _fit(x, y, w, exponent)
    if n == k:
        return result(
            q_inf,
            nan,
            nan,
            c,
            p,
            Status.too_few_points,
            f"{n} points for {k} parameters: the curve passes through every point, no error estimate",
        )
    err_fit = _fit_error(x, w, c, p, sse, n - k, s is not None, confidence, exponent is None)
    err_loo = nan
    if n - 1 >= k + 1 or (exponent is not None and n - 1 >= k):
        loo = [_fit(np.delete(x, i), np.delete(y, i), np.delete(w, i), exponent)[0] for i in range(n)]
        err_loo = float(np.max(np.abs(np.asarray(loo) - q_inf)))
    status, why = Status.ok, ""
    ss_tot = float(((y - np.average(y, weights=w**2)) ** 2 * w**2).sum())
    if not _monotonic(x, y, s):
        status, why = Status.non_monotonic, "the values do not change monotonically with resolution"
    elif s is not None and _chi2_sf(sse, n - k) < MIN_CHI2_PVALUE:
        status, why = (
            Status.poor_fit,
            f"chi^2 = {sse:.3g} for {n - k} degrees of freedom: the form does not fit",
        )
    elif ss_tot > 0 and 1.0 - sse / ss_tot < MIN_R2:
        status, why = Status.poor_fit, "the fit residual is as large as the spread of the data"
    elif exponent is None and not (P_BOUNDS[0] * 1.01 < p < P_BOUNDS[1] / 1.01):
        status, why = Status.poor_fit, f"fitted exponent p = {p:.3g} is at its bound {P_BOUNDS}"
    return result(q_inf, err_fit, err_loo, c, p, status, why)


def fit_inverse_length(length, q, sigma=None, confidence: float = 0.95) -> Limit:
    """Extrapolate q linearly in 1/L to 1/L = 0 (Zauner 2020 §6.2, Table 6.4: permeability vs sample length L_S).

    For a fixed physical sample L_S ∝ 1/a, so this is :func:`fit_power` with p = 1 in x = 1/L.
    """
    length = np.asarray(length, dtype=np.float64)
    if length.ndim != 1 or np.any(~np.isfinite(length)) or np.any(length <= 0):
        raise PorepipeError(f"sample lengths must be positive and finite, got {length.tolist()}")
    return fit_power(
        1.0 / length, q, exponent=1.0, sigma=sigma, confidence=confidence, form="q(L) = q_inf + c/L"
    )
