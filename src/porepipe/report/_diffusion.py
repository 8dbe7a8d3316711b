"""The report's Knudsen-diffusion section: D_eff, W and τ against resolution with their statistical error bars and
the limit a → 0, and what each further digit of D_eff costs (statistical error against particles × flights).

The values and limits come from ``sweep.h5`` (quantities ``diffusion_<axis>.<name>``, errors ``stat_err``); the
error-against-cost curves from the ``history_*`` arrays of the diffusion result files the sweep gathered (found in
the scene's ``diffusion`` folder beside ``sweep/``).
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from porepipe._shared.store import read_table
from porepipe.report._figures import write_csv
from porepipe.sweep import FULL

#: the section's quantities per transport axis, in table order
NAMES = ("W", "D_eff_m2_s", "tortuosity")
PREFIX = "diffusion"


def diffusion_groups(ds: xr.Dataset) -> list[str]:
    """Quantity groups of the diffusion stage in the sweep (``diffusion_z``, ``diffusion_x``, ...), sorted."""
    groups = {str(q).split(".")[0] for q in ds.quantity.values}
    return sorted(g for g in groups if g == PREFIX or g.startswith(PREFIX + "_"))


def digit_cost(flights, rel_err) -> dict:
    """What further digits of D_eff cost, from the relative error after each round against the flights so far.

    Batch means over independent particle streams fall as flights^(-1/2), so each further significant digit costs
    100 times the flights; the prefactor is taken from the last round (the most flights). With three or more rounds
    the measured log-log slope is reported beside it as a check.

    Returns
    -------
    dict
        ``slope`` (measured s of rel_err ∝ flights^-s; NaN with fewer than three usable rounds),
        ``flights_for_1e-3`` and ``flights_for_1e-4`` (on the 1/√N law through the last round; NaN if none usable).
    """
    flights, rel_err = np.asarray(flights, float), np.asarray(rel_err, float)
    ok = np.isfinite(rel_err) & (rel_err > 0) & (flights > 0)
    nan = float("nan")
    out = {"slope": nan, "flights_for_1e-3": nan, "flights_for_1e-4": nan}
    if not ok.any():
        return out
    last_f, last_e = flights[ok][-1], rel_err[ok][-1]
    out["flights_for_1e-3"] = float(last_f * (last_e / 1e-3) ** 2)
    out["flights_for_1e-4"] = float(last_f * (last_e / 1e-4) ** 2)
    if ok.sum() >= 3 and np.unique(flights[ok]).size >= 3:
        out["slope"] = -float(np.polyfit(np.log(flights[ok]), np.log(rel_err[ok]), 1)[0])
    return out


def cpu_per_flight(flights, round_cpu_s) -> float:
    """Kernel CPU seconds per flight over the timed rounds after the first (whose time includes the compilation)."""
    flights, cpu = np.asarray(flights, float), np.asarray(round_cpu_s, float)
    if flights.size < 2:
        return float("nan")
    per_round = np.diff(flights)
    timed = np.isfinite(cpu[1:]) & (per_round > 0)
    return float(cpu[1:][timed].sum() / per_round[timed].sum()) if timed.any() else float("nan")


def _histories(sweep_path: Path) -> list[dict]:
    """One record per diffusion result file of the scene (``<scene>/diffusion/diffusion_a*.h5``) with a history."""
    folder = Path(sweep_path).parent.parent / PREFIX
    out = []
    for path in sorted(folder.glob(f"{PREFIX}_a*.h5")) if folder.is_dir() else []:
        table = read_table(path)
        if "history_flights" not in table:
            continue
        flights = table["history_flights"].values
        d_eff = table["history_D_eff"].values
        err = table["history_D_eff_err"].values
        rel = np.divide(err, np.abs(d_eff), out=np.full(err.shape, np.nan), where=d_eff != 0)
        cpu = (
            table["history_round_cpu_s"].values
            if "history_round_cpu_s" in table
            else np.full(flights.shape, np.nan)
        )
        out.append(
            {
                "file": path.name,
                "particles": table["history_particles"].values,
                "flights": flights,
                "rel_err": rel,
                "cpu_s_per_flight": cpu_per_flight(flights, cpu),
                **digit_cost(flights, rel),
            }
        )
    return out


def _value_rows(ds: xr.Dataset, group: str) -> list[dict]:
    rows = []
    for a in ds.a_um.values:
        row = {"group": group, "a_um": float(a)}
        for name in NAMES:
            q = f"{group}.{name}"
            if q in ds.quantity.values:
                sel = ds.sel(quantity=q, a_um=a, sample_um=FULL)
                row[name] = float(sel.value)
                row[f"{name}_err"] = float(sel.stat_err) if "stat_err" in ds else float("nan")
        if any(np.isfinite(row.get(n, np.nan)) for n in NAMES):
            rows.append(row)
    return rows


def _limit_row(ds: xr.Dataset, group: str) -> dict:
    row = {"group": group, "a_um": 0.0}
    for name in NAMES:
        q = f"{group}.{name}"
        if q not in ds.quantity.values:
            continue
        sel = ds.sel(quantity=q, form="power", sample_um=FULL)
        ok = sel.status.item() == "ok"
        row[name] = float(sel.q_inf) if ok else float("nan")
        row[f"{name}_err"] = float(sel.err) if ok else float("nan")
        row[f"{name}_status"] = sel.status.item() if ok else f"{sel.status.item()}: {sel.why.item()}"
    return row


def _pm(value: float, err: float) -> str:
    if not np.isfinite(value):
        return "–"
    return f"{value:.5g} ± {err:.2g}" if np.isfinite(err) else f"{value:.5g}"


def _figure(ds, groups, histories, path: Path, dpi: int) -> None:
    fig = Figure(figsize=(10.2, 3.2))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.17, top=0.88, wspace=0.3)
    FigureCanvasAgg(fig)
    ax_d, ax_t, ax_e = fig.subplots(1, 3)
    for group in groups:
        rows = _value_rows(ds, group)
        lim = _limit_row(ds, group)
        for ax, name in ((ax_d, "D_eff_m2_s"), (ax_t, "tortuosity")):
            pts = [r for r in rows if np.isfinite(r.get(name, np.nan))]
            if not pts:
                continue
            a = [r["a_um"] for r in pts]
            ax.errorbar(
                a, [r[name] for r in pts], yerr=[r[f"{name}_err"] for r in pts], fmt="o-", ms=3, label=group
            )
            if np.isfinite(lim.get(name, np.nan)):
                ax.errorbar([0.0], [lim[name]], yerr=[lim[f"{name}_err"]], fmt="ks", ms=4)
    for ax, title in ((ax_d, "D_eff [m²/s]"), (ax_t, "tortuosity τ")):
        ax.set_xlabel("a [µm]")
        ax.set_title(title, fontsize=9)
        ax.set_xlim(left=-0.05 * float(ds.a_um.max()))
    if ax_d.get_legend_handles_labels()[0]:  # results without D_eff (W only) draw no curve
        ax_d.legend(fontsize=7)
    for h in histories:
        ok = np.isfinite(h["rel_err"]) & (h["rel_err"] > 0)
        ax_e.loglog(h["flights"][ok], h["rel_err"][ok], "o-", ms=3, label=h["file"])
        if np.isfinite(h["slope"]) and ok.any():
            f0, e0 = h["flights"][ok][-1], h["rel_err"][ok][-1]
            f = np.geomspace(
                f0, max(h["flights_for_1e-4"], f0 * 10) if np.isfinite(h["flights_for_1e-4"]) else f0 * 100
            )
            ax_e.loglog(f, e0 * (f / f0) ** -0.5, "k:", lw=0.8)
    ax_e.set_xlabel("flights (particles × flights per particle)")
    ax_e.set_title("relative statistical error of D_eff", fontsize=9)
    if histories:
        ax_e.legend(fontsize=6)
    fig.savefig(path, dpi=dpi)


def section(ds: xr.Dataset, sweep_path, out_dir, dpi: int = 100) -> list[str]:
    """HTML parts of the diffusion section (empty without diffusion quantities of the whole sample); writes its PNG
    and CSV files.
    """
    groups = diffusion_groups(ds)
    if not groups or FULL not in ds.sample_um.values:
        return []
    out_dir = Path(out_dir)
    histories = _histories(Path(sweep_path))
    _figure(ds, groups, histories, out_dir / "diffusion.png", dpi)
    rows = [r for g in groups for r in (*_value_rows(ds, g), _limit_row(ds, g))]
    write_csv(out_dir / "diffusion.csv", [{k: r.get(k, "") for k in _csv_keys(rows)} for r in rows])
    cost = [
        {
            k: h[k]
            for k in (
                "file",
                "slope",
                "flights_for_1e-3",
                "flights_for_1e-4",
                "cpu_s_per_flight",
            )
        }
        for h in histories
    ]
    write_csv(out_dir / "diffusion_cost.csv", cost)
    table = []
    for r in rows:
        a = "a → 0" if r["a_um"] == 0.0 else f"{r['a_um']:g}"
        cells = [_pm(r.get(n, np.nan), r.get(f"{n}_err", np.nan)) for n in NAMES]
        if r["a_um"] == 0.0:
            cells = [
                c if np.isfinite(r.get(n, np.nan)) else str(r.get(f"{n}_status", "–"))
                for c, n in zip(cells, NAMES)
            ]
        table.append([r["group"], a, *cells])
    parts = [
        "<h2>Knudsen diffusion</h2>",
        "<img src='diffusion.png' alt='diffusion'>",
        _html_table(["", "a [um]", "W", "D_eff [m²/s]", "τ"], table),
        (
            "<p class=note>Error bars: 1 σ statistical (batch means over independent particle streams); the limit "
            "a → 0 is the sweep's power-law fit weighted by them (95 % interval). Data: "
            "<a href='diffusion.csv'>diffusion.csv</a></p>"
        ),
    ]
    if cost:
        parts += [
            _html_table(
                [
                    "result",
                    "error ∝ flights^-s, s",
                    "flights × per digit",
                    "flights for 1e-3",
                    "CPU s for 1e-3",
                ],
                [
                    [
                        h["file"],
                        f"{h['slope']:.3g}",
                        f"{h['flights_for_1e-3']:.3g}",
                        f"{h['flights_for_1e-4']:.3g}",
                        f"{h['flights_for_1e-3'] * h['cpu_s_per_flight']:.3g}",
                    ]
                    for h in histories
                ],
            ),
            (
                "<p class=note>What each further digit of D_eff costs: the relative error after each round against "
                "the flights run so far (dotted: the 1/√N law of independent batches through the last round, "
                "continued to 1e-4): each digit costs 100 times the flights. CPU s: kernel time per flight of the "
                "rounds after the first (which includes the compilation). Data: "
                "<a href='diffusion_cost.csv'>diffusion_cost.csv</a></p>"
            ),
        ]
    return parts


def _csv_keys(rows: list[dict]) -> list[str]:
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    return keys


def _html_table(columns, rows) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in columns)
    body = "".join(
        "<tr>" + "".join(f"<td class=l>{html.escape(str(v))}</td>" for v in r) + "</tr>" for r in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"
