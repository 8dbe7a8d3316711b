"""Build ``report/index.html``: figures (PNG) and tables, each with its data (CSV), from a scene's ``sweep.h5``.

The page is static HTML with relative links only (no scripts, no network), so it renders offline.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import html
import os
import platform
from pathlib import Path

import numpy as np
import xarray as xr

from porepipe import __version__
from porepipe._shared.atomic import write_text_atomic
from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import read_attrs, read_table
from porepipe.report import _figures, _labels, _rev
from porepipe.report._analysis import CLOCKS, error_cost_table, startup_table, varying_quantities
from porepipe.report._diffusion import section as diffusion_section
from porepipe.report._length_series import parts as length_series_parts
from porepipe.report._permeability_cost import permeability_cost_parts
from porepipe.report._reaction_tables import parts as reaction_parts
from porepipe.report._settings import Clock, Settings
from porepipe.report._thesis import Table, scene_tables
from porepipe.sweep import FULL, parse_name

_CSS = """body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;font-size:12px;margin:.5em 0}td,th{border:1px solid #bbb;padding:2px 6px;
text-align:right}th{background:#eee}td.l,th.l{text-align:left}img{max-width:100%;border:1px solid #ddd;display:block}
.note{color:#555;font-size:12px}h2{border-bottom:1px solid #ccc}ul.headline{font-size:15px;line-height:1.5}"""


def _by_resolution(paths) -> dict[float, Path]:
    out = {}
    for p in map(Path, paths or []):
        _, a, sample, _ = parse_name(p.stem)
        if a is not None and sample == FULL:
            out[a] = p
    return out


def _fmt(value) -> str:
    if isinstance(value, (float, np.floating)):
        if not np.isfinite(value):
            return "–" if np.isnan(value) else str(value)
        return f"{value:.6g}"
    return html.escape(str(value))


def _table_html(columns, rows, first_left: int = 1) -> str:
    head = "".join(
        f"<th{' class=l' if i < first_left else ''}>{html.escape(str(c))}</th>" for i, c in enumerate(columns)
    )
    body = "".join(
        "<tr>"
        + "".join(f"<td{' class=l' if i < first_left else ''}>{_fmt(v)}</td>" for i, v in enumerate(r))
        + "</tr>"
        for r in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"


def _thesis_html(t: Table, out_dir: Path) -> str:
    csv_name = f"table_{t.key.replace('.', '_')}.csv"
    _figures.write_csv(out_dir / csv_name, [dict(zip(t.columns, r)) for r in t.rows])
    return (
        f"<h3>{html.escape(t.title)}</h3>{_table_html(t.columns, t.rows, 2)}"
        f"<p class=note>{html.escape(t.note)}. Data: <a href='{csv_name}'>{csv_name}</a></p>"
    )


def _machine(ds: xr.Dataset) -> str:
    # the variable, not the file's own ``threads`` attribute that ``ds.threads`` falls back to where it is missing
    runs = ds["threads"].values if "threads" in ds.data_vars else np.zeros(0)
    threads = sorted({int(t) for t in np.unique(runs[np.isfinite(runs)])})
    rows = [
        ["porepipe version", __version__],
        ["host", platform.node()],
        ["platform", platform.platform()],
        ["processor", platform.processor() or platform.machine()],
        ["CPU cores seen", os.cpu_count()],
        ["threads of the runs", ", ".join(map(str, threads)) or "not recorded"],
        ["report written", _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")],
    ]
    return _table_html(["", ""], rows, 2)


def _limit_cells(sel) -> tuple[dict, str]:
    """Numbers of one fit for the CSV (NaN where unsupported) and its text for the page."""
    if sel.status.item() == "ok":
        q_inf, err, p = float(sel.q_inf), float(sel.err), float(sel.p)
        return {"q_inf": q_inf, "err": err, "p": p, "status": "ok"}, f"{q_inf:.6g} ± {err:.2g} (p = {p:.3g})"
    nan = float("nan")
    return {"q_inf": nan, "err": nan, "p": nan, "status": sel.status.item()}, f"no limit: {sel.why.item()}"


def _limits_rows(ds: xr.Dataset, quantities) -> tuple[list[dict], list[list]]:
    """One row per (quantity, sample size) with data: numeric CSV records and the page's cells."""
    records, cells = [], []
    for q in quantities:
        unit = _labels.unit_of(ds, q)
        for s in ds.sample_um.values:
            v = ds.value.sel(quantity=q, sample_um=s).values
            if not np.isfinite(v).any():
                continue
            rec = {
                "quantity": q,
                "unit": unit,
                "sample_um": float(s),
                "resolutions": int(np.isfinite(v).sum()),
            }
            rec["finest_value"] = float(v[np.isfinite(v)][-1])
            texts = []
            for form in ("power", "linear"):
                numbers, text = _limit_cells(ds.sel(quantity=q, form=form, sample_um=s))
                rec.update({f"{form}_{k}": x for k, x in numbers.items()})
                texts.append(text)
            records.append(rec)
            cells.append(
                [
                    _labels.title(q),
                    _labels.pretty_unit(unit) or "not stated",
                    "whole" if s == FULL else f"{s:g}",
                    rec["resolutions"],
                    rec["finest_value"],
                    *texts,
                ]
            )
    return records, cells


@dataclasses.dataclass
class Context:
    """What every report section reads: the sweep, the output folder, the settings and the input files."""

    ds: xr.Dataset
    out_dir: Path
    settings: Settings
    quantities: list[str]
    grey: dict[float, Path]
    binary: dict[float, Path]
    lpt: dict[float, Path]
    inputs: dict = dataclasses.field(default_factory=dict)


def _figure_html(png: str, alt: str, note: str) -> str:
    return f"<img src='{png}' alt='{html.escape(alt)}'><p class=note>{note}</p>"


def section_machine(ctx: Context) -> list[str]:
    """Where and with what the runs were made."""
    return ["<h2>Machine</h2>", _machine(ctx.ds)]


def section_quantities(ctx: Context) -> list[str]:
    """Each quantity against resolution with its fit and limit."""
    if not ctx.quantities:  # the figure still exists: the workflow's report() lists it
        _figures.message_figure("no quantity changes with resolution", ctx.out_dir / "quantities.png")
        return ["<h2>Quantities against resolution</h2><p>No quantity changes with resolution.</p>"]
    rows = _figures.quantities_figure(
        ctx.ds, ctx.quantities, ctx.out_dir / "quantities.png", ctx.settings.dpi
    )
    _figures.write_csv(ctx.out_dir / "quantities.csv", rows)
    return [
        "<h2>Quantities against resolution</h2>",
        _figure_html(
            "quantities.png",
            "quantities against voxel edge",
            "Data: <a href='quantities.csv'>quantities.csv</a>; black square: the limit a → 0 with its error bar "
            "(only where the data support one). Matrix-phase twins of pore quantities and κ in other units are "
            "left out.",
        ),
    ]


def section_limits(ctx: Context) -> list[str]:
    """The limits a → 0 of every quantity, with units; numbers in the CSV, never text."""
    names = _labels.distinct(ctx.ds.quantity.values)
    records, cells = _limits_rows(ctx.ds, names)
    _figures.write_csv(ctx.out_dir / "limits.csv", records)
    table = _table_html(
        [
            "quantity",
            "unit",
            "sample [µm]",
            "resolutions",
            "finest value",
            f"q∞, p {ctx.ds.attrs.get('exponent', 'free')}",
            "q∞, linear in a",
        ],
        cells,
        2,
    )
    return [
        "<h2>Limits a → 0</h2>",
        table,
        "<p class=note>Data: <a href='limits.csv'>limits.csv</a> (value, error and exponent in columns of their "
        "own; NaN where the data support no limit, the reason in the status column)</p>",
    ]


#: a Pareto front whose dearest run costs less than this multiple of its cheapest is called overhead-bound
OVERHEAD_BOUND = 2.0


def times(factor: float) -> str:
    """A cost factor for a sentence: ``31.6``, ``1,000``, ``2.5e+06``."""
    if factor >= 1e6:
        return f"{factor:.2g}"
    return f"{factor:,.0f}" if factor >= 100 else f"{factor:.3g}"


def _headline(row: dict) -> str:
    name = _labels.title(row["quantity"])
    factor = row["cost_factor_per_digit"]
    if not np.isfinite(factor):
        return (
            f"{html.escape(name)}: no cost per digit yet ({row['front_runs']} run(s) with a known error on the "
            "Pareto front: add resolutions)."
        )
    cost, err = row["front_cost_s"], row["front_rel_err"]
    text = (
        f"One more correct digit of <b>{html.escape(name)}</b> costs <b>×{times(factor)}</b> in {row['clock']} time "
        f"(Pareto front: error {err[0]:.2g} for {cost[0]:.3g} s → {err[-1]:.2g} for {cost[-1]:.3g} s)."
    )
    if cost[-1] < OVERHEAD_BOUND * cost[0]:
        text += (
            f" These runs are overhead-bound: the finest cost only ×{cost[-1] / cost[0]:.2g} the coarsest, so fixed "
            "costs per run (loading compiled kernels, reading files) dominate the computation at this size."
        )
    return text


def section_error_cost(ctx: Context) -> list[str]:
    """Relative error against compute cost per run, the headline cost of a digit per quantity."""
    clock = Clock(ctx.settings.cost_clock).value
    err_rows = error_cost_table(ctx.ds, ctx.quantities, clock)
    summary = _figures.error_cost_figure(err_rows, ctx.out_dir / "error_cost.png", ctx.settings.dpi, clock)
    _figures.write_csv(ctx.out_dir / "error_cost.csv", err_rows)
    parts = ["<h2>What accuracy costs</h2>"]
    if summary:
        ordered = sorted(
            summary, key=lambda r: not np.isfinite(r["cost_factor_per_digit"])
        )  # known costs first
        parts.append("<ul class=headline>" + "".join(f"<li>{_headline(r)}</li>" for r in ordered) + "</ul>")
    else:
        parts.append(
            "<p>No quantity has a supported limit yet, so no errors can be shown: add resolutions.</p>"
        )
    parts.append(
        _figure_html(
            "error_cost.png",
            "relative error against compute cost",
            f"One point per run; cost = the computation's {'CPU' if clock == 'cpu' else 'wall'} time recorded in its result file plus the "
            "voxelisation and segmentation of the volume it measured (interpreter start-up and imports excluded, "
            "see below; the scene's report.cost_clock chooses CPU or wall time); "
            "error relative to the supported limit. The cost of a digit comes from a straight line through the "
            "Pareto front in log–log. Data: <a href='error_cost.csv'>error_cost.csv</a>",
        )
    )
    return parts


def section_startup(ctx: Context) -> list[str]:
    """Compute time against the whole job's time: what interpreter start-up and imports add per job."""
    rows = startup_table(ctx.ds)
    if not rows:
        return []
    _figures.write_csv(ctx.out_dir / "startup.csv", rows)
    keys = [
        "stage",
        "jobs",
        "compute_wall_s",
        "startup_s_per_job",
        "job_wall_s",
        "job_minus_compute_s_per_job",
    ]
    cells = [[r[k] for k in keys] for r in rows]
    return [
        "<h3>Compute and start-up</h3>",
        _table_html(
            [
                "stage",
                "jobs",
                "compute [s]",
                "start-up per job [s, median]",
                "whole jobs [s]",
                "whole job − compute per job [s, median]",
            ],
            cells,
            1,
        ),
        "<p class=note>Compute: wall time of the computations as their result files record them (wall_s: "
        "reading inputs, compiling kernels on a first run, computing, writing). Start-up: interpreter start-up "
        "and imports before that (startup_s). Whole jobs: Snakemake's benchmarks of the same jobs, which hold "
        "both and Snakemake's own overhead. The costs above use compute only. "
        "Data: <a href='startup.csv'>startup.csv</a></p>",
    ]


def section_diffusion(ctx: Context) -> list[str]:
    """Knudsen diffusion results of the sweep (porepipe.report._diffusion), if the scene ran diffusion."""
    return diffusion_section(ctx.ds, ctx.inputs.get("sweep_path", ""), ctx.out_dir, ctx.settings.dpi)


def section_reactions(ctx: Context) -> list[str]:
    """Reaction studies of the scene (setup reaction with reactions.series) beside Mahler 2001 Tables 4.2-4.4."""
    sweep = ctx.inputs.get("sweep_path", "")
    if not sweep:
        return []
    return reaction_parts(Path(sweep).parent.parent / "diffusion", ctx.out_dir)


def section_length_series(ctx: Context) -> list[str]:
    """A length series of the scene (diffusion.lengths) with α of (3.51) beside the thesis's and the literature's."""
    sweep = ctx.inputs.get("sweep_path", "")
    if not sweep:
        return []
    return length_series_parts(Path(sweep).parent.parent / "diffusion", ctx.out_dir)


def section_permeability_cost(ctx: Context) -> list[str]:
    """κ error against cost of the LBM sphere benchmark (results/benchmarks/lbm_spheres.json), if it was run."""
    return permeability_cost_parts(ctx.out_dir, ctx.settings.dpi)


def section_thesis(ctx: Context) -> list[str]:
    """The thesis tables this scene produced numbers for; the others named in one line."""
    others = {m: read_table(p) for m, p in ctx.inputs.get("thesis_rows", {}).items()}
    shown, skipped = scene_tables(
        ctx.ds, ctx.settings.thesis_tables, ctx.settings.thesis_model, others=others
    )
    parts = []
    if shown:
        parts.append("<h2>Thesis tables</h2>")
        parts += [_thesis_html(t, ctx.out_dir) for t in shown]
    if skipped:
        names = ", ".join(t.key for t in skipped)
        parts.append(
            f"<p class=note>Thesis tables {html.escape(names)}: not shown, this scene produced no numbers for "
            "them (5.1 and 5.2 also need report.thesis_model).</p>"
        )
    return parts


def section_rev(ctx: Context) -> list[str]:
    """REV error bars: each quantity's mean and spread over the sweep's sub-samples (Fig. 7.8, Table 7.4)."""
    rows = _rev.rev_rows(ctx.ds)
    if not rows:
        return []
    _figures.write_csv(ctx.out_dir / "rev.csv", [dict(zip(_rev.COLUMNS, r)) for r in rows])
    return [
        "<h2>REV sub-samples</h2>",
        _table_html(_rev.COLUMNS, rows, 2),
        "<p class=note>Mean and standard deviation (ddof = 1) over the sweep.subsamples cubes of each edge, cut "
        "evenly from face to face (thesis §7.4): the spread is the REV error bar. Data: "
        "<a href='rev.csv'>rev.csv</a></p>",
    ]


def section_cross_sections(ctx: Context) -> list[str]:
    """Mid cross-sections of the grey and binary volumes at each resolution, with scale bars."""
    if not (ctx.settings.slices and (ctx.grey or ctx.binary)):
        return []
    axis = ctx.settings.slice_axis
    rows = _figures.sections_figure(
        ctx.grey, ctx.binary, axis, ctx.out_dir / "sections.png", ctx.settings.dpi
    )
    _figures.write_csv(ctx.out_dir / "sections.csv", rows)
    return [
        "<h2>Cross-sections</h2>",
        _figure_html(
            "sections.png",
            "cross-sections",
            f"Middle section normal to axis {'xyz'[axis]}; red bar: length in µm. Data: "
            "<a href='sections.csv'>sections.csv</a>",
        ),
    ]


def section_lpt(ctx: Context) -> list[str]:
    """Local percolation and porosity spread against cell size."""
    if not ctx.lpt:
        return []
    rows = _figures.lpt_figure(ctx.lpt, ctx.out_dir / "lpt.png", ctx.settings.dpi)
    _figures.write_csv(ctx.out_dir / "lpt.csv", rows)
    return [
        "<h2>Local porosity theory</h2>",
        _figure_html("lpt.png", "LPT curves", "Data: <a href='lpt.csv'>lpt.csv</a>"),
    ]


#: the page, top to bottom. A new section is one function ``f(ctx) -> list of HTML strings`` (empty: nothing to
#: show) and one line here; extra input files reach it through ``build_report(..., inputs={name: paths})``.
SECTIONS = [
    section_machine,
    section_error_cost,
    section_startup,
    section_diffusion,
    section_reactions,
    section_length_series,
    section_permeability_cost,
    section_quantities,
    section_limits,
    section_thesis,
    section_rev,
    section_cross_sections,
    section_lpt,
]


def build_report(
    sweep_path,
    out_html,
    *,
    settings: Settings | None = None,
    grey=(),
    binary=(),
    lpt=(),
    scene_name: str = "",
    inputs: dict | None = None,
) -> Path:
    """Write the report page and its PNG/CSV files into the directory of ``out_html``.

    Parameters
    ----------
    sweep_path : path-like
        ``sweep.h5`` of the scene.
    out_html : path-like
        The page (``index.html``); figures and tables go beside it.
    settings : Settings, optional
        The scene's ``report`` section.
    grey, binary, lpt : sequence of path-like
        Volumes for the cross-sections and LPT results for their curves.
    scene_name : str
        Shown in the title (default: the sweep's scene attribute).
    inputs : dict, optional
        Further input files by name, for sections that need them (``Context.inputs``).

    Returns
    -------
    pathlib.Path
        The page written.
    """
    settings = settings or Settings()
    ds = read_table(sweep_path)
    missing = [v for v in ("q_inf", "err", "value", *CLOCKS["wall"], *CLOCKS["cpu"]) if v not in ds]
    if missing:
        raise PorepipeError(
            f"{sweep_path} is not a sweep result (no {', '.join(missing)}); build it with `porepipe sweep`"
        )
    out_html = Path(out_html)
    out_dir = out_html.parent
    quantities = varying_quantities(ds, settings.quantities, settings.max_quantities)
    out_dir.mkdir(parents=True, exist_ok=True)
    scene_name = scene_name or str(read_attrs(sweep_path).get("scene", ""))
    ctx = Context(
        ds=ds,
        out_dir=out_dir,
        settings=settings,
        quantities=quantities,
        grey=_by_resolution(grey),
        binary=_by_resolution(binary),
        lpt=_by_resolution(lpt),
        inputs={"sweep_path": Path(sweep_path), **(inputs or {})},
    )
    parts = [
        f"<h1>porepipe report: scene {html.escape(scene_name)}</h1>",
        (
            "<p>Accuracy against cost: every quantity at every resolution, extrapolated to a → 0; the error of each "
            f"run against the limit and what it cost. Error bars are {ds.attrs.get('confidence', 0.95):.0%} "
            "intervals (max of fit covariance and leave-one-resolution-out).</p>"
        ),
    ]
    for section in SECTIONS:
        parts += section(ctx)
    parts.append(f"<p class=note>Source: {html.escape(str(sweep_path))}</p>")
    page = (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>porepipe report {html.escape(scene_name)}</title><style>{_CSS}</style></head><body>"
        + "\n".join(parts)
        + "</body></html>\n"
    )
    return write_text_atomic(out_html, page)
