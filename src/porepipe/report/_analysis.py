"""Numbers behind the report: which limit to trust, error against cost per run, the Pareto front, cost per digit."""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr

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


def reference_limit(ds: xr.Dataset, quantity: str, sample_um: float = FULL) -> Reference | None:
    """The supported limit of ``quantity`` (scene's power form first, then the linear form); None if neither."""
    for form in ("power", "linear"):
        sel = ds.sel(quantity=quantity, form=form, sample_um=sample_um)
        if sel.status.item() == "ok":
            value, err = float(sel.q_inf), float(sel.err)
            return Reference(quantity, value, err, form, f"{value:.6g} ± {err:.2g} ({form})")
    return None


def runs_of(ds: xr.Dataset, quantity: str) -> dict[str, np.ndarray]:
    """Every run of one quantity: a, sample, value and total cost (the run plus the volume it measured)."""
    sel = ds.sel(quantity=quantity)
    a, s = np.meshgrid(ds.a_um.values, ds.sample_um.values, indexing="ij")
    run = np.where(np.isfinite(sel.wall_s.values), sel.wall_s.values, sel.bench_s.values)
    cost = np.nan_to_num(run) + np.nan_to_num(ds.upstream_wall_s.values)
    keep = np.isfinite(sel.value.values)
    return {"a_um": a[keep], "sample_um": s[keep], "value": sel.value.values[keep], "cost_s": cost[keep]}


def pareto_front(cost, err) -> np.ndarray:
    """Indices of the runs no other run beats in both cost and error, ordered by cost."""
    cost = np.asarray(cost, dtype=np.float64)
    err = np.asarray(err, dtype=np.float64)
    order = np.lexsort((err, cost))
    front, best = [], np.inf
    for i in order:
        if err[i] < best:
            front.append(i)
            best = err[i]
    return np.asarray(front, dtype=np.int64)


def cost_per_digit(cost, err) -> float:
    """Factor by which the cost grows for one more correct digit, from a log–log line through the Pareto front.

    NaN with fewer than two front points or no decrease of the error.
    """
    cost = np.asarray(cost, dtype=np.float64)
    err = np.asarray(err, dtype=np.float64)
    ok = (cost > 0) & (err > 0)
    if ok.sum() < 2 or np.ptp(np.log10(err[ok])) == 0:
        return float("nan")
    slope = np.polyfit(-np.log10(err[ok]), np.log10(cost[ok]), 1)[0]
    return float(10.0**slope) if slope > 0 else float("nan")


def error_cost_table(ds: xr.Dataset, quantities) -> list[dict]:
    """One row per run of every quantity with a supported limit: relative error against total cost."""
    rows = []
    for q in quantities:
        ref = reference_limit(ds, q)
        if ref is None or ref.value == 0:
            continue
        runs = runs_of(ds, q)
        err = np.maximum(np.abs(runs["value"] - ref.value) / abs(ref.value), ERR_FLOOR)
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
        return [q for q in wanted if q in names]
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
    """Per stage: jobs, the computations' wall time (result files) and the jobs' wall time (Snakemake benchmarks).

    The difference is what a job spends outside the computation: interpreter start-up, imports, loading compiled
    kernels, reading and writing files. Quantities of one result file share one cost, so each (stage, a, sample)
    counts once.
    """
    seen: dict[tuple, tuple[float, float]] = {}
    for q in ds.quantity.values:
        group = _labels.parts(str(q))[0] or str(q)
        sel = ds.sel(quantity=q)
        for i, a in enumerate(ds.a_um.values):
            for j, s in enumerate(ds.sample_um.values):
                wall, bench = float(sel.wall_s.values[i, j]), float(sel.bench_s.values[i, j])
                if np.isfinite(wall) and np.isfinite(bench):
                    seen[(group, float(a), float(s))] = (wall, bench)
    rows = []
    for group in sorted({k[0] for k in seen}):
        pairs = np.array([v for k, v in seen.items() if k[0] == group])
        rows.append(
            {
                "stage": group,
                "jobs": int(len(pairs)),
                "compute_wall_s": float(pairs[:, 0].sum()),
                "job_wall_s": float(pairs[:, 1].sum()),
                "startup_s_per_job": float(np.median(pairs[:, 1] - pairs[:, 0])),
            }
        )
    return rows
