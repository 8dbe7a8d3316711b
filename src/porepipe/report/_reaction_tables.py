"""The report's reaction-study section: Mahler 2001 Tables 4.2-4.4 (η for A → A′, η for A ⇌ A′, selectivity S of
A → P → S) beside the numbers of a scene that ran setup ``reaction`` with ``reactions.series``.

The thesis's numbers (two digits, no error bars) are copied from the digest shared/spec/diffusion-reaction-mahler2001.md
§6.5; porepipe's come from the scene's diffusion result files (``series_*`` arrays) with their 1-σ statistical
errors. The thesis gives no dimensions for its capillaries A/B/C, so the scene's own geometry (constricted,
pocketed, rough) is the analogue of one column, and all three columns are shown for the trends.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from porepipe._shared.store import read_table
from porepipe.report._diffusion import _html_table
from porepipe.report._figures import write_csv

#: (table, w, w_reverse, w_follow) -> thesis values for capillaries (A, B, C); η for 4.2/4.3, S for 4.4
THESIS: dict[tuple[str, float, float, float], tuple[float, float, float]] = {
    ("4.2", 0.5, 0.0, 0.0): (0.17, 0.15, 0.15),
    ("4.2", 0.1, 0.0, 0.0): (0.30, 0.30, 0.35),
    ("4.2", 0.05, 0.0, 0.0): (0.34, 0.38, 0.47),
    ("4.2", 0.01, 0.0, 0.0): (0.47, 0.67, 0.78),
    ("4.2", 0.001, 0.0, 0.0): (0.77, 0.93, 0.96),
    ("4.3", 0.01, 0.01, 0.0): (0.40, 0.53, 0.66),
    ("4.3", 0.01, 0.001, 0.0): (0.46, 0.65, 0.77),
    ("4.3", 0.1, 0.1, 0.0): (0.25, 0.23, 0.24),
    ("4.3", 0.1, 0.01, 0.0): (0.29, 0.29, 0.33),
    ("4.3", 0.2, 0.01, 0.0): (0.24, 0.22, 0.23),
    ("4.3", 0.2, 0.001, 0.0): (0.25, 0.23, 0.24),
    ("4.3", 0.2, 0.0, 0.0): (0.25, 0.23, 0.24),
    ("4.4", 0.01, 0.0, 0.01): (0.77, 0.72, 0.81),
    ("4.4", 0.01, 0.0, 0.001): (0.94, 0.95, 0.99),
    ("4.4", 0.2, 0.0, 0.01): (0.95, 0.92, 0.88),
    ("4.4", 0.2, 0.0, 0.001): (0.99, 0.99, 0.99),
}
#: geometry kind of the scene -> the thesis capillary it stands for
ANALOGUE = {"constricted": "A", "pocketed": "B", "rough": "C"}


def study_rows(path: Path) -> list[dict]:
    """One row per thesis entry that the study in result file ``path`` ran (empty if it ran no study)."""
    table = read_table(path)
    if "series_eta" not in table:
        return []
    settings = json.loads(table.attrs.get("settings", "{}"))
    kind = ((settings.get("geometry") or {}).get("kind")) or ""
    ours = {}
    for k in range(table["series_w"].size):
        key = tuple(float(table[f"series_{c}"].values[k]) for c in ("w", "w_reverse", "w_follow"))
        ours[key] = k
    rows = []
    for (tab, *key), thesis in THESIS.items():
        k = ours.get(tuple(key))
        if k is None:
            continue
        name = "selectivity" if tab == "4.4" else "eta"
        rows.append(
            {
                "file": path.name,
                "table": tab,
                "w": key[0],
                "w_reverse": key[1],
                "w_follow": key[2],
                "quantity": "S" if tab == "4.4" else "η",
                "thesis_A": thesis[0],
                "thesis_B": thesis[1],
                "thesis_C": thesis[2],
                "analogue": ANALOGUE.get(kind, ""),
                "porepipe": float(table[f"series_{name}"].values[k]),
                "porepipe_err": float(table[f"series_{name}_err"].values[k]),
                "r_eff_per_particle_jiffie": float(table["series_r_eff"].values[k]),
                "r_eff_err": float(table["series_r_eff_err"].values[k]),
            }
        )
    return rows


def _fmt(value: float, err: float) -> str:
    return f"{value:.3f} ± {err:.3f}" if math.isfinite(err) else f"{value:.3f}"


def _rows(diffusion_dir) -> list[dict]:
    folder = Path(diffusion_dir)
    files = sorted(folder.glob("diffusion_a*.h5")) if folder.is_dir() else []
    return [r for p in files for r in study_rows(p)]


def parts(diffusion_dir, out_dir) -> list[str]:
    """The section's HTML (empty without a study); writes ``reactions.csv`` into ``out_dir``."""
    rows = _rows(diffusion_dir)
    if not rows:
        return []
    write_csv(Path(out_dir) / "reactions.csv", rows)
    cells = []
    for r in rows:
        w = f"{r['w']:g}" + (f", w′ = {r['w_reverse']:g}" if r["w_reverse"] else "")
        w += f", w₂ = {r['w_follow']:g}" if r["w_follow"] else ""
        thesis = [f"{r[f'thesis_{c}']:.2f}" + (" ◀" if r["analogue"] == c else "") for c in "ABC"]
        diff = r["porepipe"] - r[f"thesis_{r['analogue']}"] if r["analogue"] else np.nan
        r_eff = _fmt(1e3 * r["r_eff_per_particle_jiffie"], 1e3 * r["r_eff_err"])
        cells.append(
            [
                r["table"],
                r["quantity"],
                w,
                *thesis,
                _fmt(r["porepipe"], r["porepipe_err"]),
                f"{diff:+.3f}",
                r_eff,
            ]
        )
    kinds = sorted({r["analogue"] for r in rows if r["analogue"]})
    return [
        "<h2>Wall reactions: Mahler 2001 Tables 4.2-4.4</h2>",
        _html_table(
            [
                "table",
                "",
                "w",
                "thesis A",
                "thesis B",
                "thesis C",
                "porepipe",
                "porepipe − thesis ◀",
                "porepipe r_eff [1e-3/jiffie]",
            ],
            cells,
        ),
        (
            "<p class=note>η = products leaving the inlet / (w · wall hits) (4.5); S = product rate with the "
            "follow-up reaction / without it; r_eff = products leaving per particle in the pore per jiffie (4.3 at "
            "unit concentration: compare it across the A/B/C scenes for the thesis's Fig. 4.6 crossover). Thesis: "
            "two printed digits, no error bars. porepipe: 1 σ over "
            "independent particle streams (S: the two runs' errors added in quadrature, which overstates it). "
            f"This scene's capillary stands for thesis column {', '.join(kinds) or '–'} (◀); the thesis gives no "
            "dimensions, so the columns agree in trend (η falls with w; reverse reaction lowers η; S rises as "
            "w₂ falls), not digit by digit. Data: <a href='reactions.csv'>reactions.csv</a></p>"
        ),
    ]
