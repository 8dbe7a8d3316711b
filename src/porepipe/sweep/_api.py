"""Public API of the sweep: gather results, extrapolate every quantity, write ``sweep.h5``."""

from __future__ import annotations

import numpy as np
import xarray as xr

from porepipe.sweep._fit import Limit, fit_power
from porepipe.sweep._gather import FULL, gather
from porepipe.sweep._settings import Exponent

#: fit forms stored in sweep.h5: the scene's power law, and the thesis's linear form (7.2.1, Table 6.4)
FORMS = ("power", "linear")
_P = {Exponent.free: None, Exponent.linear: 1.0, Exponent.quadratic: 2.0}
_LIMIT_FIELDS = ("q_inf", "err", "err_fit", "err_loo", "c", "p", "n")
#: fields that hold numbers only where the fit is supported (status ok); NaN otherwise, the reason in ``why``
_FIT_FIELDS = ("q_inf", "err", "err_fit", "err_loo", "c", "p")
_IN_QUANTITY_UNIT = {"units_from": "unit", "description": "in the unit of its quantity (coordinate `unit`)"}
_FIELD_ATTRS = {
    "q_inf": {**_IN_QUANTITY_UNIT, "long_name": "limit a -> 0"},
    "err": _IN_QUANTITY_UNIT,
    "err_fit": {**_IN_QUANTITY_UNIT, "long_name": "half-width from the fit covariance"},
    "err_loo": {**_IN_QUANTITY_UNIT, "long_name": "largest change of q_inf when one resolution is left out"},
    "c": {
        "units_from": "unit",
        "description": "coefficient of a^p (a in µm): in the unit of its quantity (coordinate `unit`) per µm^p",
    },
    "p": {"units": "1", "long_name": "convergence exponent"},
    "n": {"units": "1", "long_name": "resolutions with a finite value"},
}


def exponent_value(exponent: Exponent | str) -> float | None:
    """P of a scene's ``sweep.exponent`` (None = fitted)."""
    return _P[Exponent(exponent)]


def limit_of(a_um, values, exponent: float | None, confidence: float = 0.95, stat_err=None) -> Limit:
    """Extrapolate one quantity over the resolutions where it is finite.

    ``stat_err``: the points' statistical 1-σ errors; used as the known noise of the fit (weights, chi² verdict)
    when every point has a positive one, else the noise is estimated from the residuals.
    """
    a_um = np.asarray(a_um, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    keep = np.isfinite(values)
    sigma = None
    if stat_err is not None:
        err = np.asarray(stat_err, dtype=np.float64)[keep]
        sigma = err if err.size and np.all(np.isfinite(err)) and np.all(err > 0) else None
    return fit_power(a_um[keep], values[keep], exponent=exponent, sigma=sigma, confidence=confidence)


def add_limits(
    ds: xr.Dataset, exponent: Exponent | str = Exponent.free, confidence: float = 0.95
) -> xr.Dataset:
    """Add q∞ and its verdict over (form, quantity, sample_um): ``q_inf``, ``err``, ``status``, ``why`` and more."""
    p_of = {"power": exponent_value(exponent), "linear": 1.0}
    shape = (len(FORMS), ds.sizes["quantity"], ds.sizes["sample_um"])
    num = {k: np.full(shape, np.nan) for k in _LIMIT_FIELDS}
    status = np.full(shape, "", dtype=object)
    why = np.full(shape, "", dtype=object)
    for f, form in enumerate(FORMS):
        for i in range(shape[1]):
            for j in range(shape[2]):
                stat = ds.stat_err.values[i, :, j] if "stat_err" in ds else None
                lim = limit_of(ds.a_um.values, ds.value.values[i, :, j], p_of[form], confidence, stat)
                for k in _LIMIT_FIELDS:
                    num[k][f, i, j] = getattr(lim, k) if lim.supported or k not in _FIT_FIELDS else np.nan
                status[f, i, j], why[f, i, j] = lim.status.value, lim.why
    dims = ("form", "quantity", "sample_um")
    out = ds.assign_coords(form=np.array(FORMS, dtype=object))
    for k, arr in num.items():
        out[k] = (dims, arr, dict(_FIELD_ATTRS[k]))
    out["status"] = (
        dims,
        status,
        {"description": "ok, or why the data support no limit (then q_inf … are NaN)"},
    )
    out["why"] = (dims, why)
    out["err"].attrs["description"] = (
        f"half-width of the {confidence:.0%} interval of q_inf (max of fit and LOO)"
    )
    out.attrs.update(
        confidence=confidence,
        exponent=Exponent(exponent).value,
        forms="power: q = q_inf + c*a^p (p from the scene); linear: p = 1 (thesis 7.2.1, Table 6.4)",
    )
    return out


def build_sweep(
    result_paths,
    volume_paths=(),
    cost_dir=None,
    exponent: Exponent | str = Exponent.free,
    confidence: float = 0.95,
) -> xr.Dataset:
    """Gather results into quantity × a × sample and extrapolate each quantity to a → 0."""
    return add_limits(gather(result_paths, volume_paths, cost_dir), exponent, confidence)


def limit_from_sweep(ds: xr.Dataset, quantity: str, form: str = "power", sample_um: float = FULL) -> dict:
    """One quantity's limit record from a sweep Dataset (for the adaptive driver and the report)."""
    sel = ds.sel(quantity=quantity, form=form, sample_um=sample_um)
    return {
        k: (sel[k].item() if k in ("status", "why") else float(sel[k]))
        for k in (*_LIMIT_FIELDS, "status", "why")
    }
