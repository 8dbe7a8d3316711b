"""The report's length-series section (Mahler 2001 §3.6.4, eq. 3.51): W and D = v̄LW/4 against L for a scene that ran
``diffusion.lengths``, and α from the fit 1/D = 1/D₀ + α·(r/L)/D₀ beside the thesis's α = 8.55 (Fig. 3.18) and
the literature's 2.9 [65] (numbers from the digest shared/spec/diffusion-reaction-mahler2001.md §5.4).

The curve is not a line (the thesis saw it steeper for long capillaries), so α depends on the lengths fitted: the
section gives it over all lengths and over the three longest.
"""

from __future__ import annotations

from pathlib import Path

from porepipe._shared.store import read_table
from porepipe.diffusion import fit_length_series
from porepipe.report._diffusion import _html_table
from porepipe.report._figures import write_csv

ALPHA_THESIS = 8.55
ALPHA_LITERATURE = 2.9


def series_rows(path: Path) -> list[dict]:
    """One row per length of the series in result file ``path`` (empty without a series)."""
    t = read_table(path)
    if "series_r_over_L" not in t:
        return []
    keys = ("length", "W", "W_err", "D", "D_err", "r_over_L")
    return [
        {"file": path.name, **{k: float(t[f"series_{k}"].values[i]) for k in keys}}
        for i in range(t["series_length"].size)
    ]


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
    write_csv(Path(out_dir) / "length_series.csv", [r for rows in per_file for r in rows])
    table = []
    for rows in per_file:
        rows = sorted(rows, key=lambda r: r["length"])
        lengths = ", ".join(f"{r['length']:g}" for r in rows)
        w = ", ".join(f"{r['W']:.4f}±{r['W_err']:.4f}" for r in rows)
        table.append(
            [
                rows[0]["file"],
                lengths,
                w,
                _fit_cell(rows),
                _fit_cell(rows[-3:]),
                ALPHA_THESIS,
                ALPHA_LITERATURE,
            ]
        )
    return [
        "<h2>Length dependence of the Knudsen resistance (Mahler 2001 §3.6.4)</h2>",
        _html_table(
            [
                "result",
                "L [voxels]",
                "W ± 1σ",
                "porepipe α, all L",
                "porepipe α, 3 longest",
                "thesis α (Fig. 3.18)",
                "literature α [65]",
            ],
            table,
        ),
        (
            "<p class=note>α from the weighted fit 1/D = 1/D₀ + α·(r/L)/D₀, D = v̄LW/4, r = √(inlet area/π); "
            "errors: 1 σ from the statistical errors of W. χ²/dof ≫ 1 means the curve is not a line, so α depends "
            "on the lengths fitted. Data: <a href='length_series.csv'>length_series.csv</a></p>"
        ),
    ]
