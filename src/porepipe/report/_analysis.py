"""Numbers behind the report: which limit to trust, error against cost per run, the Pareto front, cost per digit."""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe.report import _labels
from porepipe.sweep import FULL

#: floor of a relative error on a log axis (a run that hits the limit to round-off)
ERR_FLOOR = 1e-16


@dataclasses.dataclass(frozen=True)
class Reference:
    """The limit a quantity's errors are measured against."""

    quantity: str
    value: float
    err: float
    form: str  # 'power', 'linear'
    text: str


def check_quantities(ds: xr.Dataset, quantities, what: str = "quantity") -> list[str]:
    """``quantities`` (a list of names) if the sweep holds each; else one line naming those it lacks and what it has."""
    names = [str(q) for q in ds.quantity.values]
    missing = [str(q) for q in quantities if str(q) not in names]
    if isinstance(quantities, str) or missing:
        given = repr(quantities) if isinstance(quantities, str) else ", ".join(missing)
        raise PorepipeError(
            f"{what} {given}: {'give a list of names' if isinstance(quantities, str) else 'not in the sweep'}; "
            f"allowed: {', '.join(names) or 'none (the sweep holds no quantity)'}"
        )
    return [str(q) for q in quantities]


def reference_limit(ds: xr.Dataset, quantity: str, sample_um: float = FULL) -> Reference | None:
    """The supported limit of ``quantity`` (scene's power form first, then the linear form).

    Parameters
    ----------
    ds : xarray.Dataset
        The sweep (``sweep.h5``).
    quantity : str
        A quantity of the sweep (``stage.name[phase]``); another is one line naming the allowed ones.
    sample_um : float
        Sample edge (default: the whole sample).

    Returns
    -------
    Reference or None
        None if neither form is supported, or the sweep has no sample of edge ``sample_um`` (a sweep of sub-samples
        has no whole sample).
    """
    check_quantities(ds, [quantity])
    if sample_um not in ds.sample_um.values:
        return None
    for form in ("power", "linear"):
        sel = ds.sel(quantity=quantity, form=form, sample_um=sample_um)
        if sel.status.item() == "ok":
            value, err = float(sel.q_inf), float(sel.err)
            return Reference(quantity, value, err, form, f"{value:.6g} ± {err:.2g} ({form})")
    return None


#: the clocks a run's cost can be read on: (its own, the Snakemake benchmark's fallback, its volume's)
CLOCKS = {
    "wall": ("wall_s", "bench_s", "upstream_wall_s"),
    "cpu": ("cpu_s", "bench_cpu_s", "upstream_cpu_s"),
}


def runs_of(ds: xr.Dataset, quantity: str, clock: str = "wall") -> dict[str, np.ndarray]:
    """Every run of one quantity: a, sample, value and total cost (the run plus the volume it measured).

    Parameters
    ----------
    ds : xarray.Dataset
        A sweep (``sweep.h5``).
    quantity : str
        One of its quantities.
    clock : {'wall', 'cpu'}
        Cost in wall seconds or CPU seconds (core-seconds: all threads; unaffected by other jobs on the machine).
        A run without its own record falls back to its Snakemake benchmark, which includes start-up.

    Returns
    -------
    dict of str -> ndarray
        ``a_um``, ``sample_um``, ``value``, ``cost_s`` of every run with a finite value.
    """
    if clock not in CLOCKS:
        raise PorepipeError(f"clock = {clock!r}; allowed: {', '.join(CLOCKS)}")
    check_quantities(ds, [quantity])
    own, bench, upstream = CLOCKS[clock]
    sel = ds.sel(quantity=quantity)
    a, s = np.meshgrid(ds.a_um.values, ds.sample_um.values, indexing="ij")
    run = np.where(np.isfinite(sel[own].values), sel[own].values, sel[bench].values)
    cost = np.nan_to_num(run) + np.nan_to_num(ds[upstream].values)
    keep = np.isfinite(sel.value.values)
    return {"a_um": a[keep], "sample_um": s[keep], "value": sel.value.values[keep], "cost_s": cost[keep]}


def _cost_and_err(cost, err) -> tuple[np.ndarray, np.ndarray]:
    """``cost`` and ``err`` as 1-D float arrays of one length; else one line naming their shapes."""
    cost = np.asarray(cost, dtype=np.float64)
    err = np.asarray(err, dtype=np.float64)
    if cost.ndim != 1 or cost.shape != err.shape:
        raise PorepipeError(
            f"cost and err must be 1-D and of one length (one value per run), got shapes {cost.shape} and {err.shape}"
        )
    return cost, err


def pareto_front(cost, err) -> np.ndarray:
    """Indices of the runs no other run beats in both cost and error, ordered by cost.

    Parameters
    ----------
    cost, err : (N,) array_like
        Cost and error of each run; runs of unknown (NaN or infinite) cost or NaN error are left out, arrays of
        different shapes are one line.
    """
    cost, err = _cost_and_err(cost, err)
    order = np.lexsort((err, cost))
    front, best = [], np.inf
    for i in order[np.isfinite(cost[order])]:
        if err[i] < best:
            front.append(i)
            best = err[i]
    return np.asarray(front, dtype=np.int64)


def cost_per_digit(cost, err) -> float:
    """Factor by which the cost grows for one more correct digit, from a log–log line through the Pareto front.

    NaN with fewer than two front points or no decrease of the error; points of zero, infinite or NaN cost or error
    are left out.
    """
    cost, err = _cost_and_err(cost, err)
    ok = (cost > 0) & (err > 0) & np.isfinite(cost) & np.isfinite(err)
    if ok.sum() < 2 or np.ptp(np.log10(err[ok])) == 0:
        return float("nan")
    slope = np.polyfit(-np.log10(err[ok]), np.log10(cost[ok]), 1)[0]
    return float(10.0**slope) if slope > 0 else float("nan")


def error_cost_table(ds: xr.Dataset, quantities, clock: str = "wall") -> list[dict]:
    """One row per run of every quantity with a supported limit: relative error against total cost (``clock``).

    A run closer to the limit than the limit's own error bar has an unknown error: its ``rel_err`` is that bar and
    ``resolved`` is 0.
    """
    rows = []
    for q in check_quantities(ds, quantities):
        ref = reference_limit(ds, q)
        if ref is None or ref.value == 0:
            continue
        runs = runs_of(ds, q, clock)
        diff = np.abs(runs["value"] - ref.value) / abs(ref.value)
        # an error below the limit's own error bar is not known: shown at that bar, left out of the cost of a digit
        bar = ref.err / abs(ref.value) if np.isfinite(ref.err) else 0.0
        err = np.maximum(np.maximum(diff, bar), ERR_FLOOR)
        front = set(pareto_front(runs["cost_s"], err).tolist())
        for i in range(err.size):
            rows.append(
                {
                    "quantity": q,
                    "a_um": float(runs["a_um"][i]),
                    "sample_um": float(runs["sample_um"][i]),
                    "value": float(runs["value"][i]),
                    "limit": ref.value,
                    "rel_err": float(err[i]),
                    "resolved": int(diff[i] > bar),
                    "cost_s": float(runs["cost_s"][i]),
                    "pareto": int(i in front),
                }
            )
    return rows


def varying_quantities(ds: xr.Dataset, wanted, cap: int) -> list[str]:
    """The quantities to plot: those asked for, else porosity, χ and κ wherever measured, then those that change
    with resolution (supported limits first), without pore/matrix twins or κ in a second unit; at most ``cap``.
    """
    names = [str(q) for q in ds.quantity.values]
    if wanted:
        return check_quantities(ds, wanted, "report.quantities")
    full = ds.value.sel(sample_um=FULL) if FULL in ds.sample_um.values else ds.value.isel(sample_um=0)
    candidates = _labels.distinct(names)

    def measured(q):
        return bool(np.isfinite(full.sel(quantity=q).values).any())

    def varies(q):
        v = full.sel(quantity=q).values
        return measured(q) and np.nanmax(v) > np.nanmin(v)

    core = [q for q in candidates if _labels.is_core(q) and measured(q)]
    vary = [q for q in candidates if q not in core and varies(q)]
    vary.sort(key=lambda q: (reference_limit(ds, q) is None, q))
    return (core + vary)[:cap]


def startup_table(ds: xr.Dataset) -> list[dict]:
    """Per stage: jobs, the computations' wall time, their start-up (both from the result files) and the whole jobs'
    wall time (Snakemake's benchmarks).

    Start-up is interpreter start-up and imports before the computation; whole job minus computation also holds
    Snakemake's own overhead. Quantities of one result file share one cost, so each (stage, a, sample) counts once.
    """
    seen: dict[tuple, tuple[float, float, float]] = {}
    startup = ds["startup_s"] if "startup_s" in ds else xr.full_like(ds.wall_s, np.nan)
    for q in ds.quantity.values:
        group = _labels.parts(str(q))[0] or str(q)
        wall, bench = ds.wall_s.sel(quantity=q).values, ds.bench_s.sel(quantity=q).values
        start = startup.sel(quantity=q).values
        for i in range(wall.shape[0]):
            for j in range(wall.shape[1]):
                if np.isfinite(wall[i, j]):
                    seen[(group, i, j)] = (wall[i, j], start[i, j], bench[i, j])
    rows = []
    for group in sorted({k[0] for k in seen}):
        rec = np.array([v for k, v in seen.items() if k[0] == group], dtype=np.float64)
        if not np.isfinite(rec[:, 1:]).any():
            continue
        with np.errstate(all="ignore"):
            rows.append(
                {
                    "stage": group,
                    "jobs": int(len(rec)),
                    "compute_wall_s": float(rec[:, 0].sum()),
                    "startup_s_per_job": _median(rec[:, 1]),
                    "job_wall_s": float(np.nansum(rec[:, 2]))
                    if np.isfinite(rec[:, 2]).any()
                    else float("nan"),
                    "job_minus_compute_s_per_job": _median(rec[:, 2] - rec[:, 0]),
                }
            )
    return rows


def _median(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(np.median(finite)) if finite.size else float("nan")
