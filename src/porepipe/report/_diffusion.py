"""The report's Knudsen-diffusion section: D_eff, W and τ against resolution with their statistical error bars and
the limit a → 0, and what each further digit of D_eff costs (statistical error against particles × flights).

The values and limits come from ``sweep.h5`` (quantities ``diffusion_<axis>.<name>``, errors ``stat_err``); the
error-against-cost curves from the ``history_*`` arrays of the diffusion result files the sweep gathered (found in
the scene's ``diffusion`` folder beside ``sweep/``), and from their root attributes whether each run's rounds met
``diffusion.target_rel_error`` (``target_met``, ``rel_error``, ``stopped_by``; a result written before these has none,
and its row shows nothing about it).
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from porepipe._shared.store import read_attrs, read_table
from porepipe.report._figures import write_csv
from porepipe.sweep import FULL, parse_name

#: the section's quantities per transport axis, in table order
NAMES = ("W", "D_eff_m2_s", "tortuosity")
PREFIX = "diffusion"
#: what the report writes before the limit(s) on a row whose rounds stopped before ``target_rel_error``
CUT_MARK = "⚠ stopped by "


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


def stop_record(attrs: dict) -> dict:
    """Whether a diffusion run's rounds met ``target_rel_error``, from its result's root attributes.

    Returns
    -------
    dict
        ``target_met`` (1/0), ``stopped_by`` (what ended the rounds; comma-separated for a length series),
        ``rel_error`` (the relative 1-σ error the rounds reached; inf before 2 rounds) and ``target_rel_error`` (NaN
        if the settings are not recorded); empty for a result written before these attributes existed.
    """
    if "target_met" not in attrs:
        return {}
    settings = json.loads(attrs.get("settings") or "{}")
    return {
        "target_met": int(attrs["target_met"]),
        "stopped_by": str(attrs.get("stopped_by", "")),
        "rel_error": float(attrs.get("rel_error", np.nan)),
        "target_rel_error": float(settings.get("target_rel_error", np.nan)),
    }


def cut_mark(target_met: int, stopped_by: str) -> str:
    """``⚠ stopped by <limit>[, <limit>]`` for rounds that a limit ended before the target, "" for met ones.

    Parameters
    ----------
    target_met : int
        The result's ``target_met`` (1/0).
    stopped_by : str
        The result's ``stopped_by`` (comma-separated for a length series).
    """
    if target_met:
        return ""
    limits = dict.fromkeys(by for by in stopped_by.split(",") if by and by != "target_rel_error")
    return CUT_MARK + (", ".join(limits) or "a limit")


def rel_error_cell(rel_error: float, target: float) -> str:
    """The relative error a run reached beside its target (∞: fewer than 2 rounds or a zero estimate).

    Parameters
    ----------
    rel_error : float
        The result's ``rel_error``, printed to 2 significant digits.
    target : float
        ``target_rel_error`` of its settings (NaN: not shown).
    """
    reached = f"{rel_error:.2g}" if np.isfinite(rel_error) else "∞"
    return f"{reached} (target {target:g})" if np.isfinite(target) else reached


def _stops(sweep_path: Path) -> dict[tuple[str, float], dict]:
    """(group, a_um) -> :func:`stop_record` of each whole-sample diffusion result of the scene that has one."""
    folder = Path(sweep_path).parent.parent / PREFIX
    out = {}
    for path in sorted(folder.glob(f"{PREFIX}_a*.h5")) if folder.is_dir() else []:
        _, a, sample, tag = parse_name(path.stem)
        record = stop_record(read_attrs(path))
        if record and a is not None and sample == FULL:
            out[(PREFIX + (f"_{tag}" if tag else ""), a)] = record
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
    stops = _stops(Path(sweep_path))
    rows = [r for g in groups for r in (*_value_rows(ds, g), _limit_row(ds, g))]
    for r in rows:  # the limit rows (a_um 0) match no run
        r.update(stops.get((r["group"], r["a_um"]), {}))
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
    parts = [
        "<h2>Knudsen diffusion</h2>",
        "<img src='diffusion.png' alt='diffusion'>",
        *_value_table(rows, with_stops=bool(stops)),
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


def _value_table(rows: list[dict], with_stops: bool) -> list[str]:
    """The values table; ``with_stops``: two more columns, the relative error against the target and the limit
    that stopped a run before it, and a warning line above the table naming the runs a limit stopped.
    """
    table = []
    for r in rows:
        a = "a → 0" if r["a_um"] == 0.0 else f"{r['a_um']:g}"
        cells = [_pm(r.get(n, np.nan), r.get(f"{n}_err", np.nan)) for n in NAMES]
        if r["a_um"] == 0.0:
            cells = [
                c if np.isfinite(r.get(n, np.nan)) else str(r.get(f"{n}_status", "–"))
                for c, n in zip(cells, NAMES)
            ]
        if with_stops:
            has = "target_met" in r
            cells += [
                rel_error_cell(r["rel_error"], r["target_rel_error"]) if has else "",
                cut_mark(r["target_met"], r["stopped_by"]) if has else "",
            ]
        table.append([r["group"], a, *cells])
    columns = ["", "a [um]", "W", "D_eff [m²/s]", "τ"]
    if not with_stops:
        return [_html_table(columns, table)]
    cut = [f"{r['group']} a = {r['a_um']:g} µm" for r in rows if "target_met" in r and not r["target_met"]]
    warning = (
        [
            f"<p><b>⚠ {len(cut)} diffusion run(s) ended before diffusion.target_rel_error</b> "
            f"({html.escape('; '.join(cut))}): a limit stopped their rounds, so their error bars are wider than "
            "asked.</p>"
        ]
        if cut
        else []
    )
    note = (
        "<p class=note>rel. error: the relative 1-σ error the run's rounds reached (of W; Wicke-Kallenbach: of D; "
        "msd: the largest D_dd) beside diffusion.target_rel_error (∞: fewer than 2 rounds, none to compare); ⚠: a "
        "limit (max_rounds, max_wall_hits) ended the rounds first. A result written before porepipe recorded this "
        "shows neither.</p>"
    )
    return [*warning, _html_table([*columns, "rel. error (target)", "stopped before target"], table), note]


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
