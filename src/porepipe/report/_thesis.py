"""The thesis tables (Zauner 2020) next to porepipe's numbers, with the difference in a column.

Tables 6.4 and 7.2 check the extrapolation arithmetic on the thesis's own measured numbers; Tables 5.1, 5.2 and 7.3
compare a scene's values where the scene reproduces the thesis model (``report.thesis_model`` names the row set);
Tables 6.2 and 6.3 take porepipe's numbers from the LBM calibration record that benchmarks/lbm_calibration.py writes
(results/benchmarks/lbm_calibration.json), each row naming that run and its cost; without a record they say so.
Numbers from the spec digest shared/spec/pipeline-zauner2020.md (§2.7, §3.4, §3.5, §4.2, §4.3).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe.estimate import regress_porosity_limit
from porepipe.report._settings import ThesisTable
from porepipe.sweep import FULL, two_point_limit

A0_UM = 15000.0 / 16384  # §7.1: a0 = 1.5 cm / 16384

T6_4 = [
    ("BGK", 0.688, 608, 559, 510),
    ("BGK", 0.857, 773, 634, 495),
    ("MRT", 0.688, 505, 489, 473),
    ("MRT", 0.857, 558, 518, 478),
    ("MRT", 1.000, 601, 541, 481),
]
T7_2_A0 = [8.0, 4.0, 2.0, 1.0, 0.5]
T7_2_BOUNDS = {
    "phi0": [0.0921243, 0.1119007, 0.1227767, 0.1284572, 0.1313791],
    "phi215": [0.1828374, 0.1583219, 0.1462455, 0.1402638, 0.1372924],
}
T7_2_LINES = {
    "phi0": [0.131677153054625, 0.133652713629999, 0.134137638623542, 0.134301059825200],
    "phi215": [0.133806445926894, 0.134169143824690, 0.134282116458962, 0.134321011332180],
}
T7_2_LIMIT = 0.134313
# Table 5.1: model -> [(a_um, phi, S_V 1/um, K_V(P) 1e-3/um^2, T_V(P) 1e-4/um^3)]
T5_1 = {
    "PP": [
        (1.0, 0.182749, 0.039, 1.7449, -2.7909),
        (0.5, 0.182854, 0.040, 1.7619, -4.3873),
        (0.25, 0.182844, 0.041, 1.7617, -8.8408),
    ],
    "FP": [
        (1.0, 0.165780, 0.055, 2.1476, -64.932),
        (0.5, 0.166253, 0.066, 2.0549, -275.78),
        (0.25, 0.166290, 0.072, -0.9055, -498.52),
    ],
}
T5_1_COLS = [
    ("phi", "minkowski.phi[pore]", 1.0),
    ("S_V [1/um]", "minkowski.S_V[pore]", 1.0),
    ("K_V(P) [1e-3/um^2]", "minkowski.K_V[pore]", 1e3),
    ("T_V(P) [1e-4/um^3]", "minkowski.T_V[pore]", 1e4),
]
T5_2 = {"PP": [(1.0, 660.2), (0.5, 617.7)], "FP": [(1.0, 200.7), (0.5, 182.5)]}
# Table 7.3 [1/mm] at a = 8, 4, 2, 1, 0.5 a0
T7_3 = {
    "S_max": [20.039, 20.530, 20.774, 20.904, 20.946],
    "S_mf": [9.6371, 9.8774, 9.9978, 10.061, 10.065],
    "S_min": [6.0407, 6.1915, 6.2673, 6.3068, 6.3096],
}
# Table 6.2: B -> (<|eps_v|>, <|e_v|> as printed; its unit is 1e-7 although the header says 1e-6, see the lbm tests)
T6_2 = {
    4: (0.064099, 0.300),
    8: (0.021840, 0.114),
    16: (0.007241, 0.068),
    32: (0.002331, 0.034),
    64: (0.000784, 0.023),
}
# Table 6.3: record key -> (label, thesis kappa, thesis eps [%])
T6_3 = {
    "fit": ("method 1", 1.73244, 0.61423),
    "fit_trimmed": ("method 2 (W=10)", 1.73689, 0.87278),
    "ends": ("method 3", 1.71346, 0.48787),
    "outside": ("method 4", 1.64270, 4.59761),
    "no chambers, force everywhere": ("no chambers, force everywhere", 1.73689, 0.87277),
}
#: the LBM calibration record of benchmarks/lbm_calibration.py, relative to the working directory
CALIBRATION_RECORD = Path("results/benchmarks/lbm_calibration.json")
NO_RUN = "not run"


@dataclasses.dataclass
class Table:
    """One HTML table: title, column names, rows, and a note saying what was compared."""

    key: str
    title: str
    columns: list[str]
    rows: list[list]
    note: str = ""
    #: True when the porepipe column holds numbers porepipe computed — this scene's results, or the LBM calibration
    #: record's runs for Tables 6.2/6.3 — and not a re-derivation of the thesis's numbers
    scene_values: bool = False


def _diff(ours: float, theirs: float) -> list:
    if not np.isfinite(ours):
        return [float("nan"), ""]
    rel = f"{(ours - theirs) / theirs:+.2%}" if theirs else ""
    return [ours - theirs, rel]


def table_6_4() -> Table:
    rows = [
        [m, tau, lr, hr, ext, two_point_limit(lr, hr), *_diff(two_point_limit(lr, hr), ext)]
        for m, tau, lr, hr, ext in T6_4
    ]
    return Table(
        "6.4",
        "Table 6.4: permeability extrapolated linearly in 1/L_S (mD)",
        [
            "method",
            "tau",
            "kappa l.r.",
            "kappa h.r.",
            "thesis kappa_extrap",
            "porepipe 2h.r.-l.r.",
            "difference",
            "relative",
        ],
        rows,
        "porepipe.sweep.two_point_limit on the thesis's l.r./h.r. values (L_S = 300, 600)",
    )


def table_7_2() -> Table:
    rows = []
    lines = {}
    for key in ("phi0", "phi215"):
        b = T7_2_BOUNDS[key]
        lines[key] = [two_point_limit(b[i], b[i + 1]) for i in range(4)]
    for i, c in enumerate(T7_2_A0[:4]):
        for key, label in (("phi0", "varphi_0"), ("phi215", "varphi_215")):
            ours, theirs = lines[key][i], T7_2_LINES[key][i]
            rows.append([f"{label}(c = {c:g} a0)", theirs, ours, *_diff(ours, theirs)])
    lim = regress_porosity_limit(lines["phi0"], lines["phi215"])
    rows.append(["phi (regression of phi* on phi**)", T7_2_LIMIT, lim.phi, *_diff(lim.phi, T7_2_LIMIT)])
    return Table(
        "7.2",
        "Table 7.2: porosity bounds extrapolated linearly in a, then regressed to phi** = 0",
        ["quantity", "thesis", "porepipe", "difference", "relative"],
        rows,
        "two-point lines from the measured bounds implied by the table (7 digits), then "
        "porepipe.estimate.regress_porosity_limit",
    )


def _value(ds: xr.Dataset, quantity: str, a_um: float) -> float:
    return _measured(ds, quantity, a_um)[0]


def _measured(ds: xr.Dataset, quantity: str, a_um: float, sub_ok: bool = False) -> tuple[float, str]:
    """(value, where it came from) of ``quantity`` at resolution ``a_um``: the whole volume's run with its CPU cost
    (and that of making its binary volume, where the sweep recorded it); with ``sub_ok`` and no whole-volume run, the mean over the largest sub-sample edge, with its REV spread.
    """
    i = np.flatnonzero(np.isclose(ds.a_um.values, a_um, rtol=1e-6))
    if quantity not in ds.quantity.values or not i.size:
        return float("nan"), ""
    at = ds.sel(quantity=quantity).isel(a_um=i[0])
    samples = [FULL] if FULL in ds.sample_um.values else []
    if sub_ok:
        samples += sorted((s for s in ds.sample_um.values if s != FULL), reverse=True)
    for s in samples or [ds.sample_um.values[0]]:
        run = at.sel(sample_um=s)
        value = float(run.value)
        if not np.isfinite(value):
            continue
        cpu = float(run.cpu_s) if "cpu_s" in run else float("nan")
        cost = f"{cpu:.1f} CPU s" if np.isfinite(cpu) else "cost not recorded"
        up = float(run.upstream_cpu_s) if "upstream_cpu_s" in run else float("nan")
        if np.isfinite(cpu) and np.isfinite(up):
            cost += f" (+ {up:.1f} CPU s to voxelise and segment)"
        if s == FULL:
            return value, f"{_whole_volume(at, a_um)}, {cost}"
        count = int(run.rev_count) if "rev_count" in run else 1
        spread = float(run.rev_spread) if "rev_spread" in run else float("nan")
        rev = f" ± {spread:.4g} (REV spread of {count})" if count > 1 and np.isfinite(spread) else ""
        return value, f"sub-sample L = {s:g} um{rev}, {cost}"
    return float("nan"), ""


#: edge of the periodic box the thesis measured in §5.6.1 (Tables 5.1 and 5.2), µm
THESIS_BOX_UM = 300.0


def _whole_volume(at: xr.Dataset, a_um: float) -> str:
    """Label of a whole-volume row: the scene's measured volume as a cube edge where the sweep counted its voxels,
    and, when it is smaller than the thesis's box, that it is a sub-volume (its φ differs by the REV spread).
    """
    voxels = float(at.voxels.sel(sample_um=FULL)) if "voxels" in at else float("nan")
    if not (np.isfinite(voxels) and voxels > 0):
        return "whole volume"
    edge = np.cbrt(voxels) * a_um
    if edge < 0.99 * THESIS_BOX_UM:
        return f"whole scene volume, {edge:.4g}³ um: a sub-volume of the thesis's {THESIS_BOX_UM:g}³ um box"
    return f"whole volume, {edge:.4g}³ um"


def _scene_table(key: str, title: str, columns: list[str], rows: list[list], note: str) -> Table:
    found = any(np.isfinite(r[3]) for r in rows if isinstance(r[3], float))
    return Table(
        key, title, columns, rows, note if found else note + " — this scene has no matching results", found
    )


#: columns of Tables 5.1 and 5.2
_SCENE_COLUMNS = ["row", "quantity", "thesis", "porepipe", "difference", "relative", "source and cost"]


def _models(
    ds: xr.Dataset, model: str | None, others: dict | None, table: dict
) -> list[tuple[str, xr.Dataset]]:
    """(thesis model, sweep) pairs in the thesis's row order: this scene's model and those of ``others``."""
    sweeps = {**(others or {}), **({model: ds} if model in table else {})}
    return [(m, sweeps[m]) for m in table if m in sweeps] or [("FP", ds)]


def table_5_1(ds: xr.Dataset, model: str | None, others: dict | None = None) -> Table:
    """Table 5.1 rows of every model with a sweep (this scene's ``model``, and ``others``: model -> sweep)."""
    rows = []
    for m, sweep in _models(ds, model, others, T5_1):
        for a, *vals in T5_1[m]:
            for (label, q, scale), theirs in zip(T5_1_COLS, vals):
                value, source = _measured(sweep, q, a)
                rows.append(
                    [f"{m} a = {a:g} um", label, theirs, value * scale, *_diff(value * scale, theirs), source]
                )
    return _scene_table(
        "5.1",
        "Table 5.1: Minkowski functionals of the primary (PP) and final (FP) packings",
        _SCENE_COLUMNS,
        rows,
        "minkowski.*[pore] of the scene (and of the scenes in report.thesis_rows_from) at the thesis's resolutions",
    )


def table_5_2(ds: xr.Dataset, model: str | None, others: dict | None = None) -> Table:
    """Table 5.2 rows (κ, mean over the flow axes run) of every model with a sweep; a sub-sample where the whole
    volume was not run, labelled so.
    """
    rows = []
    for m, sweep in _models(ds, model, others, T5_2):
        kappas = [
            q
            for q in sweep.quantity.values
            if str(q).startswith("permeability") and str(q).endswith(".kappa_mD")
        ]
        for a, theirs in T5_2[m]:
            found = [_measured(sweep, q, a, sub_ok=True) for q in kappas]
            found = [(v, src) for v, src in found if np.isfinite(v)]
            ours = float(np.mean([v for v, _ in found])) if found else float("nan")
            source = "; ".join(dict.fromkeys(src for _, src in found))
            rows.append(
                [f"{m} a = {a:g} um", "kappa [mD] (mean of axes)", theirs, ours, *_diff(ours, theirs), source]
            )
    return _scene_table(
        "5.2",
        "Table 5.2: LB permeability of the primary (PP) and final (FP) packings",
        _SCENE_COLUMNS,
        rows,
        "permeability_*.kappa_mD of the scene (and of the scenes in report.thesis_rows_from)",
    )


def table_7_3(ds: xr.Dataset) -> Table:
    rows = []
    for name, values in T7_3.items():
        for l, theirs in zip(T7_2_A0, values):
            ours = _value(ds, f"estimate.{name}", l * A0_UM) * 1000.0
            rows.append([f"a = {l:g} a0", f"{name} [1/mm]", theirs, ours, *_diff(ours, theirs)])
    return _scene_table(
        "7.3",
        "Table 7.3: specific-surface bounds from grey histograms",
        ["row", "quantity", "thesis", "porepipe", "difference", "relative"],
        rows,
        "estimate.S_* of this scene at a = l·a0, a0 = 0.91552734 um",
    )


def load_calibration(source: Path | dict | None) -> dict | None:
    """The calibration record: ``source`` itself if a dict, read from the path if it exists, else None."""
    if source is None or isinstance(source, dict):
        return source
    path = Path(source)
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise PorepipeError(
            f"LBM calibration record {path} is unreadable ({exc}): rerun benchmarks/lbm_calibration.py"
        ) from exc


def _run_note(record: dict | None, what: str) -> str:
    if record is None:
        return (
            f"no pipeline run: {CALIBRATION_RECORD} is missing, so porepipe's column is empty; "
            f"`python benchmarks/lbm_calibration.py` writes it ({what})"
        )
    return f"porepipe: {record.get('source', 'benchmarks/lbm_calibration.py')} on {record.get('machine', '?')} ({what})"


def table_6_2(record: dict | None = None) -> Table:
    """Table 6.2 rows: the thesis's ⟨|ε_v|⟩ and ⟨|e_v|⟩ next to a calibration run's, with that run's cost."""
    ours = {r["B"]: r for r in (record or {}).get("table_6_2", [])}
    rows = []
    for b, (eps_thesis, ev_thesis) in T6_2.items():
        r = ours.get(b)
        source = NO_RUN if r is None else f"{r['setup']} set-up, {r['steps']} steps, {r['wall_s']:.1f} s"
        for label, theirs, key in (
            ("<|eps_v|>", eps_thesis, "eps_v"),
            ("<|e_v|> [1e-7]", ev_thesis, "e_v_1e-7"),
        ):
            value = None if r is None else r.get(key)
            if value is None:
                rows.append([b, label, theirs, "", "", "", source if r is None else f"{source}; no value"])
            else:
                rows.append([b, label, theirs, value, *_diff(value, theirs), source])
    return Table(
        "6.2",
        "Table 6.2: LB velocity error on the middle cross-section of a square channel (BGK, tau = 0.857)",
        ["B", "quantity", "thesis", "porepipe", "difference", "relative", "source and cost"],
        rows,
        _run_note(
            record,
            "square ducts, Eq. 6.1.26; the thesis's e_v column is read in units of 1e-7, "
            "its header's 1e-6 being the same decade slip as its B column",
        ),
        scene_values=bool(ours),
    )


def table_6_3(record: dict | None = None) -> Table:
    """Table 6.3 rows: κ̂ of the four pressure-gradient methods from a calibration run, beside the thesis's."""
    ours = {r["method"]: r for r in (record or {}).get("table_6_3", [])}
    cost = (record or {}).get("table_6_3_cost", {})
    source = f"{cost.get('box', '?')} box, {cost.get('steps', '?')} steps, {cost.get('wall_s', float('nan')):.0f} s"
    rows = []
    for key, (label, kappa, eps) in T6_3.items():
        r = ours.get(key)
        if r is None:
            rows.append([label, kappa, eps, "", "", "", "", NO_RUN])
        else:
            rows.append(
                [label, kappa, eps, r["kappa"], 100 * r["eps_kappa"], *_diff(r["kappa"], kappa), source]
            )
    return Table(
        "6.3",
        "Table 6.3: pressure-gradient methods, B = 7 channel (kappa in lattice units)",
        [
            "method",
            "thesis kappa",
            "thesis eps [%]",
            "porepipe kappa",
            "porepipe eps [%]",
            "difference",
            "relative",
            "source and cost",
        ],
        rows,
        _run_note(
            record, "Eq. 6.1.41 box; eps against kappa_TH(7) of Eq. 6.1.37, signed (the thesis prints |eps|)"
        ),
        scene_values=bool(ours),
    )


def scene_tables(
    ds: xr.Dataset,
    which,
    model: str | None,
    calibration: Path | dict | None = CALIBRATION_RECORD,
    others: dict | None = None,
) -> tuple[list[Table], list[Table]]:
    """The tables of ``which`` this scene produced numbers for, and the others (shown only as a list).

    Tables 5.1 and 5.2 count only when the scene names the thesis model it reproduces (``report.thesis_model``);
    a match of resolutions alone would compare a different packing with the thesis's. Tables 6.2 and 6.3 count when
    the LBM calibration record ``calibration`` holds porepipe's runs of them. ``others``: thesis model -> sweep of
    the scene that reproduces it (``report.thesis_rows_from``), for the rows of Tables 5.1/5.2 not this scene's.
    """
    shown, skipped = [], []
    for t in thesis_tables(ds, which, model, calibration, others):
        produced = t.scene_values and (model is not None or bool(others) or t.key not in ("5.1", "5.2"))
        (shown if produced else skipped).append(t)
    return shown, skipped


def thesis_tables(
    ds: xr.Dataset,
    which,
    model: str | None,
    calibration: Path | dict | None = CALIBRATION_RECORD,
    others: dict | None = None,
) -> list[Table]:
    """The thesis tables named in ``which`` (report settings), each with the pipeline's own values beside them.

    ``calibration``: the LBM calibration record (or its path) that fills Tables 6.2 and 6.3; ``others``: thesis
    model -> sweep of another scene, for more rows of Tables 5.1 and 5.2.
    """
    record = load_calibration(calibration) if {"6.2", "6.3"} & {ThesisTable(w).value for w in which} else None
    builders = {
        ThesisTable.t5_1: lambda: table_5_1(ds, model, others),
        ThesisTable.t5_2: lambda: table_5_2(ds, model, others),
        ThesisTable.t6_2: lambda: table_6_2(record),
        ThesisTable.t6_3: lambda: table_6_3(record),
        ThesisTable.t6_4: table_6_4,
        ThesisTable.t7_2: table_7_2,
        ThesisTable.t7_3: lambda: table_7_3(ds),
    }
    return [builders[ThesisTable(w)]() for w in which]
