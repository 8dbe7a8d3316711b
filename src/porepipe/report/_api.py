"""Build ``report/index.html``: figures (PNG) and tables, each with its data (CSV), from a scene's ``sweep.h5``.

The page is static HTML with relative links only (no scripts, no network), so it renders offline.
"""

from __future__ import annotations

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
from porepipe.report import _figures
from porepipe.report._analysis import error_cost_table, varying_quantities
from porepipe.report._diffusion import section as diffusion_section
from porepipe.report._permeability_cost import permeability_cost_parts
from porepipe.report._settings import Settings
from porepipe.report._thesis import Table, thesis_tables
from porepipe.sweep import FULL, parse_name

_CSS = """body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;font-size:12px;margin:.5em 0}td,th{border:1px solid #bbb;padding:2px 6px;
text-align:right}th{background:#eee}td.l,th.l{text-align:left}img{max-width:100%;border:1px solid #ddd}
.note{color:#555;font-size:12px}h2{border-bottom:1px solid #ccc}"""


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
    threads = sorted({int(t) for t in np.unique(ds.threads.values[np.isfinite(ds.threads.values)])})
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


def _limits_rows(ds: xr.Dataset) -> list[list]:
    rows = []
    for q in ds.quantity.values:
        for s in ds.sample_um.values:
            v = ds.value.sel(quantity=q, sample_um=s).values
            if not np.isfinite(v).any():
                continue
            texts = []
            for form in ("power", "linear"):
                sel = ds.sel(quantity=q, form=form, sample_um=s)
                if sel.status.item() == "ok":
                    texts.append(f"{float(sel.q_inf):.6g} ± {float(sel.err):.2g} (p = {float(sel.p):.3g})")
                else:
                    texts.append(f"no limit: {sel.why.item()}")
            finest = v[np.isfinite(v)][-1]
            rows.append(
                [str(q), "whole" if s == FULL else f"{s:g}", int(np.isfinite(v).sum()), finest, *texts]
            )
    return rows


def build_report(
    sweep_path,
    out_html,
    *,
    settings: Settings | None = None,
    grey=(),
    binary=(),
    lpt=(),
    scene_name: str = "",
) -> Path:
    """Write the report page and its PNG/CSV files into the directory of ``out_html``."""
    settings = settings or Settings()
    ds = read_table(sweep_path)
    if "q_inf" not in ds:
        raise PorepipeError(f"{sweep_path} is not a sweep result (no q_inf); build it with `porepipe sweep`")
    out_html = Path(out_html)
    out_dir = out_html.parent
    out_dir.mkdir(parents=True, exist_ok=True)
    scene_name = scene_name or str(read_attrs(sweep_path).get("scene", ""))
    parts = [
        f"<h1>porepipe report: scene {html.escape(scene_name)}</h1>",
        (
            "<p>Accuracy against cost: every quantity at every resolution, extrapolated to a → 0; the error of each "
            f"run against the limit and what it cost. Error bars are {ds.attrs.get('confidence', 0.95):.0%} "
            "intervals (max of fit covariance and leave-one-resolution-out).</p>"
        ),
        "<h2>Machine</h2>",
        _machine(ds),
    ]
    quantities = varying_quantities(ds, settings.quantities, settings.max_quantities)
    if quantities:
        rows = _figures.quantities_figure(ds, quantities, out_dir / "quantities.png", settings.dpi)
        _figures.write_csv(out_dir / "quantities.csv", rows)
        parts += [
            "<h2>Quantities against resolution</h2>",
            "<img src='quantities.png' alt='quantities'>",
            (
                "<p class=note>Data: <a href='quantities.csv'>quantities.csv</a>; black square: the limit a → 0 "
                "with its error bar (only where the data support one).</p>"
            ),
        ]
    limits = _limits_rows(ds)
    _figures.write_csv(
        out_dir / "limits.csv",
        [dict(zip(["quantity", "sample_um", "n", "finest", "power", "linear"], r)) for r in limits],
    )
    parts += [
        "<h2>Limits a → 0</h2>",
        _table_html(
            [
                "quantity",
                "sample [um]",
                "resolutions",
                "finest value",
                f"q_inf, p {ds.attrs.get('exponent', 'free')}",
                "q_inf, linear in a",
            ],
            limits,
            1,
        ),
        "<p class=note>Data: <a href='limits.csv'>limits.csv</a></p>",
    ]
    err_rows = error_cost_table(ds, quantities)
    summary = _figures.error_cost_figure(err_rows, out_dir / "error_cost.png", settings.dpi)
    _figures.write_csv(out_dir / "error_cost.csv", err_rows)
    parts += [
        "<h2>Error against cost</h2>",
        "<img src='error_cost.png' alt='error against cost'>",
        _table_html(
            ["quantity", "runs on the Pareto front", "cost factor per extra digit"],
            [[r["quantity"], r["front_runs"], r["cost_factor_per_digit"]] for r in summary],
            1,
        ),
        (
            "<p class=note>One point per run; cost = the run's wall time plus the voxelisation and segmentation "
            "of the volume it measured; error relative to the supported limit. Data: "
            "<a href='error_cost.csv'>error_cost.csv</a></p>"
        ),
    ]
    if not err_rows:
        parts.append(
            "<p>No quantity has a supported limit yet, so no errors can be shown: add resolutions.</p>"
        )
    parts += diffusion_section(ds, sweep_path, out_dir, settings.dpi)
    parts += permeability_cost_parts(out_dir, settings.dpi)  # results/benchmarks/lbm_spheres.json, if run
    parts.append("<h2>Thesis tables</h2>")
    parts += [
        _thesis_html(t, out_dir) for t in thesis_tables(ds, settings.thesis_tables, settings.thesis_model)
    ]
    grey_by_a, binary_by_a = _by_resolution(grey), _by_resolution(binary)
    if settings.slices and (grey_by_a or binary_by_a):
        rows = _figures.sections_figure(
            grey_by_a, binary_by_a, settings.slice_axis, out_dir / "sections.png", settings.dpi
        )
        _figures.write_csv(out_dir / "sections.csv", rows)
        parts += [
            "<h2>Cross-sections</h2>",
            "<img src='sections.png' alt='cross-sections'>",
            (
                f"<p class=note>Middle section normal to axis {'xyz'[settings.slice_axis]}. Data: "
                "<a href='sections.csv'>sections.csv</a></p>"
            ),
        ]
    lpt_by_a = _by_resolution(lpt)
    if lpt_by_a:
        rows = _figures.lpt_figure(lpt_by_a, out_dir / "lpt.png", settings.dpi)
        _figures.write_csv(out_dir / "lpt.csv", rows)
        parts += [
            "<h2>Local porosity theory</h2>",
            "<img src='lpt.png' alt='LPT curves'>",
            "<p class=note>Data: <a href='lpt.csv'>lpt.csv</a></p>",
        ]
    parts.append(f"<p class=note>Source: {html.escape(str(sweep_path))}</p>")
    page = (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>porepipe report {html.escape(scene_name)}</title><style>{_CSS}</style></head><body>"
        + "\n".join(parts)
        + "</body></html>\n"
    )
    return write_text_atomic(out_html, page)
