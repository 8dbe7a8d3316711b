"""Accuracy against cost of the permeability: κ of simple-cubic sphere arrays against resolution, halfway and
interpolated walls, against the published drag (Zick & Homsy 1982), and the resolution and time each wall rule needs
for a 1 % error.

Fed by ``results/benchmarks/lbm_spheres.json``, the rows ``benchmarks/lbm_spheres.py`` writes: one per run with the
solid fraction ``c``, voxels per diameter ``diameter``, ``walls``, the relative error of the drag K (= of κ, to first
order) ``error`` and the run's ``cpu_s`` (CPU seconds of the process: robust on a shared machine; ``wall_s`` where
absent).

Per (c, walls) the error is fitted as |e| = A d^(−p) over the finest three diameters (least squares in log–log; the
order p is measured, not assumed; below p = 0.5 no extrapolation is made) and the time as t = B d^m over the same; the diameter for 1 % is (A/0.01)^(1/p) and its time B d^m.
Where the measured runs are within 1 % from some diameter on (that one and every finer one: halfway walls' staircase
error changes sign with the diameter and can cross 1 % by chance), that diameter and its time are given as measured.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from porepipe.report._figures import _figure, write_csv

#: the results file of benchmarks/lbm_spheres.py, relative to the results root (results/<scene>/report/../..)
RESULTS_FILE = Path("benchmarks", "lbm_spheres.json")
#: the error the table sizes runs for
TARGET_ERROR = 0.01
#: error and time power laws are fitted to the finest this many runs (the coarsest are outside the asymptotic range)
FIT_RUNS = 3
#: a fitted order below this is no convergence (halfway walls' staircase error wanders with d): no extrapolation
MIN_ORDER = 0.5


def read_rows(path) -> list[dict]:
    """The benchmark's rows (a JSON list of dicts) with the sphere centred (``--shifts`` adds shifted ones, one
    diameter several times); [] when the file is absent.
    """
    path = Path(path)
    if not path.is_file():
        return []
    rows = json.loads(path.read_text())
    keys = {"c", "diameter", "walls", "error"}
    return [r for r in rows if keys <= set(r) and not any(r.get("shift", ()))]


def _power_fit(x, y) -> tuple[float, float]:
    """(A, p) of y = A x^(−p), least squares in log–log (NaN with fewer than two positive points)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = (x > 0) & (y > 0)
    if np.count_nonzero(keep) < 2 or np.ptp(np.log(x[keep])) == 0:
        return float("nan"), float("nan")
    slope, intercept = np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)
    return float(np.exp(intercept)), float(-slope)


def cost_rows(rows: list[dict], target: float = TARGET_ERROR) -> list[dict]:
    """One row per (c, walls): measured order, diameter and time for ``target``, and the measured runs."""
    out = []
    for c, walls in sorted({(r["c"], r["walls"]) for r in rows}):
        runs = sorted((r for r in rows if r["c"] == c and r["walls"] == walls), key=lambda r: r["diameter"])
        d = np.array([r["diameter"] for r in runs])
        err = np.abs([r["error"] for r in runs])
        time_s = np.array([r.get("cpu_s", r.get("wall_s", np.nan)) for r in runs])
        a_err, order = _power_fit(d[-FIT_RUNS:], err[-FIT_RUNS:])
        b_time, m_time = _power_fit(d[-FIT_RUNS:], 1.0 / time_s[-FIT_RUNS:])  # t = B d^m <=> 1/t = d^(−m)/B
        d_fit = (a_err / target) ** (1.0 / order) if order >= MIN_ORDER else float("nan")
        t_fit = (1.0 / b_time) * d_fit**m_time if np.isfinite(d_fit) else float("nan")
        # the coarsest run from which on every finer run is within the target (a staircase error can cross it by chance)
        within = np.flatnonzero(np.cumprod((err <= target)[::-1])[::-1])
        out.append(
            {
                "c": c,
                "walls": walls,
                "diameters": " ".join(f"{v:.3g}" for v in d),
                "errors_percent": " ".join(f"{100 * v:+.2f}" for v in (r["error"] for r in runs)),
                "order": order,
                "time_exponent": m_time,
                "d_for_target_fit": d_fit,
                "time_for_target_fit_s": t_fit,
                "d_for_target_measured": float(d[within[0]]) if within.size else float("nan"),
                "time_for_target_measured_s": float(time_s[within[0]]) if within.size else float("nan"),
            }
        )
    return out


def kappa_figure(rows: list[dict], path: Path, dpi: int) -> None:
    """|error| of κ against voxels per diameter, one panel per solid fraction, halfway dashed, interpolated solid."""
    fractions = sorted({r["c"] for r in rows})
    fig, axes = _figure(len(fractions))
    for ax, c in zip(axes, fractions):
        for walls in sorted({r["walls"] for r in rows if r["c"] == c}):
            runs = sorted(
                (r for r in rows if r["c"] == c and r["walls"] == walls), key=lambda r: r["diameter"]
            )
            ax.loglog(
                [r["diameter"] for r in runs],
                [max(abs(r["error"]), 1e-6) for r in runs],
                "o--" if walls == "halfway" else "s-",
                label=walls,
            )
        ax.axhline(TARGET_ERROR, color="0.5", lw=0.8)
        ax.set_title(f"sphere array c = {c:g}", fontsize=9)
        ax.set_xlabel("voxels per diameter", fontsize=8)
        ax.set_ylabel("|κ error| vs Zick & Homsy", fontsize=8)
        ax.legend(fontsize=7)
    fig.savefig(path, dpi=dpi)


def _cell(value, fmt: str) -> str:
    return "–" if not np.isfinite(value) else format(value, fmt)


def permeability_cost_parts(out_dir, dpi: int = 100, results=None) -> list[str]:
    """HTML parts of the report section (figure, table, CSV written into ``out_dir``); [] without results.

    ``results`` defaults to ``benchmarks/lbm_spheres.json`` of the results root that holds ``out_dir``
    (``results/<scene>/report`` -> ``results/benchmarks/lbm_spheres.json``).
    """
    results = Path(results) if results is not None else Path(out_dir).resolve().parents[1] / RESULTS_FILE
    rows = read_rows(results)
    if not rows:
        return []
    out_dir = Path(out_dir)
    kappa_figure(rows, out_dir / "permeability_cost.png", dpi)
    table = cost_rows(rows)
    write_csv(out_dir / "permeability_cost.csv", table)
    head = "".join(
        f"<th>{h}</th>"
        for h in (
            "c",
            "walls",
            "voxels per diameter",
            "error [%]",
            "order p",
            "d for 1 % (fit)",
            "CPU time for 1 % (fit) [s]",
            "d for 1 % (measured)",
            "CPU time [s]",
        )
    )
    body = "".join(
        "<tr>"
        + "".join(
            f"<td>{v}</td>"
            for v in (
                f"{r['c']:g}",
                html.escape(r["walls"]),
                r["diameters"],
                r["errors_percent"],
                _cell(r["order"], ".2f"),
                _cell(r["d_for_target_fit"], ".3g"),
                _cell(r["time_for_target_fit_s"], ".3g"),
                _cell(r["d_for_target_measured"], ".3g"),
                _cell(r["time_for_target_measured_s"], ".3g"),
            )
        )
        + "</tr>"
        for r in table
    )
    return [
        "<h2>Permeability: accuracy against cost of the wall rule</h2>",
        "<img src='permeability_cost.png' alt='permeability error against resolution'>",
        f"<table><tr>{head}</tr>{body}</table>",
        (
            "<p class=note>Simple-cubic sphere arrays, flow along an axis, TRT Λ = 3/16, κ stop rule; error of the "
            "drag K = L³/(6π a κ̂) against Zick &amp; Homsy (1982). Fits |e| = A d^−p and t = B d^m over the "
            f"measured diameters; time = CPU seconds of one run on the machine that ran the benchmark. Source: "
            f"{html.escape(str(results))}; data: <a href='permeability_cost.csv'>permeability_cost.csv</a></p>"
        ),
    ]
