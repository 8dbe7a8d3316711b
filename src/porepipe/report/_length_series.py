"""The report's length-series section (Mahler 2001 §3.6.4, eq. 3.51): W and D = v̄LW/4 against L for a scene that ran
``diffusion.lengths``, and α from the fit 1/D = 1/D₀ + α·(r/L)/D₀ beside the thesis's α = 8.55 (Fig. 3.18) and
the literature's 2.9 [65] (numbers from the digest shared/spec/diffusion-reaction-mahler2001.md §5.4).

The curve is not a line (the thesis saw it steeper for long capillaries), so α depends on the lengths fitted: the
section gives it over all lengths and over the three longest.
"""

from __future__ import annotations

import math
from pathlib import Path

from porepipe._shared.store import read_table
from porepipe.diffusion import fit_length_series
from porepipe.report._diffusion import _csv_keys, _html_table, cut_mark, rel_error_cell, stop_record
from porepipe.report._figures import write_csv

ALPHA_THESIS = 8.55
ALPHA_LITERATURE = 2.9


def series_rows(path: Path) -> list[dict]:
    """One row per length of the series in result file ``path`` (empty without a series); with ``target_met``,
    ``rel_error`` and ``stopped_by`` of each length's run where the result records them.
    """
    t = read_table(path)
    if "series_r_over_L" not in t:
        return []
    keys = ("length", "W", "W_err", "D", "D_err", "r_over_L")
    rows = [
        {"file": path.name, **{k: float(t[f"series_{k}"].values[i]) for k in keys}}
        for i in range(t["series_length"].size)
    ]
    if "series_target_met" in t and "stopped_by" in t.attrs:
        target = stop_record(t.attrs).get("target_rel_error", float("nan"))
        for row, met, rel, by in zip(
            rows,
            t["series_target_met"].values,
            t["series_rel_error"].values,
            str(t.attrs["stopped_by"]).split(","),
        ):
            row.update(target_met=int(met), rel_error=float(rel), target_rel_error=target, stopped_by=by)
    return rows


def _w_cell(r: dict) -> str:
    mark = cut_mark(r["target_met"], r["stopped_by"]) if "target_met" in r else ""
    return f"{r['W']:.4f}±{r['W_err']:.4f}" + (f" {mark}" if mark else "")


def _fit_cell(rows) -> str:
    if len(rows) < 2:
        return "–"
    fit = fit_length_series([r["r_over_L"] for r in rows], [r["D"] for r in rows], [r["D_err"] for r in rows])
    return f"{fit['alpha']:.3f} ± {fit['alpha_err']:.3f} (χ²/dof {fit['chi2_per_dof']:.2g})"


def parts(diffusion_dir, out_dir) -> list[str]:
    """HTML of the section (empty without a length series); writes ``length_series.csv`` into ``out_dir``."""
    folder = Path(diffusion_dir)
    files = sorted(folder.glob("diffusion_a*.h5")) if folder.is_dir() else []
    per_file = [rows for p in files if (rows := series_rows(p))]
    if not per_file:
        return []
    every = [r for rows in per_file for r in rows]
    write_csv(
        Path(out_dir) / "length_series.csv", [{k: r.get(k, "") for k in _csv_keys(every)} for r in every]
    )
    with_stops = any("target_met" in r for r in every)
    table = []
    for rows in per_file:
        rows = sorted(rows, key=lambda r: r["length"])
        lengths = ", ".join(f"{r['length']:g}" for r in rows)
        w = ", ".join(_w_cell(r) for r in rows)
        fits = [_fit_cell(rows), _fit_cell(rows[-3:]), ALPHA_THESIS, ALPHA_LITERATURE]
        table.append([rows[0]["file"], lengths, w, *([_rel_cell(rows)] if with_stops else []), *fits])
    columns = ["result", "L [voxels]", "W ± 1σ", *(["rel. error of W (target)"] if with_stops else [])]
    columns += ["porepipe α, all L", "porepipe α, 3 longest", "thesis α (Fig. 3.18)", "literature α [65]"]
    stops_note = (
        "rel. error: the relative 1-σ error of W each length's rounds reached; ⚠ stopped by: a limit ended that "
        "length's rounds before diffusion.target_rel_error (empty for a result written before porepipe recorded "
        "it). "
        if with_stops
        else ""
    )
    return [
        "<h2>Length dependence of the Knudsen resistance (Mahler 2001 §3.6.4)</h2>",
        _html_table(columns, table),
        (
            "<p class=note>α from the weighted fit 1/D = 1/D₀ + α·(r/L)/D₀, D = v̄LW/4, r = √(inlet area/π); "
            "errors: 1 σ from the statistical errors of W. χ²/dof ≫ 1 means the curve is not a line, so α depends "
            f"on the lengths fitted. {stops_note}Data: <a href='length_series.csv'>length_series.csv</a></p>"
        ),
    ]


def _rel_cell(rows) -> str:
    """The relative errors of W per length beside the target ("" for a result that does not record them)."""
    if not all("rel_error" in r for r in rows):
        return ""
    reached = ", ".join(rel_error_cell(r["rel_error"], float("nan")) for r in rows)
    target = rows[0]["target_rel_error"]
    return f"{reached} (target {target:g})" if math.isfinite(target) else reached
