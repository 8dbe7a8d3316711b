"""PNG figures of the report (matplotlib's Agg canvas, no pyplot state, no display), each with its data as CSV."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatterSciNotation, NullFormatter
from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

from porepipe._shared.store import open_volume
from porepipe.report import _labels
from porepipe.report._analysis import cost_per_digit, pareto_front, reference_limit
from porepipe.sweep import FULL

COLUMNS = 3
#: markers of the error-against-cost series, cycled with the colours so neighbouring series differ in both
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">", "h", "p")


def _figure(n_panels: int, width_in: float = 3.4, height_in: float = 2.7):
    rows = max(1, -(-n_panels // COLUMNS))
    cols = min(COLUMNS, max(1, n_panels))
    fig = Figure(
        figsize=(width_in * cols, height_in * rows)
    )  # fixed margins: constrained layout costs seconds
    fig.subplots_adjust(
        left=0.08, right=0.98, bottom=0.18 / rows, top=1 - 0.12 / rows, wspace=0.3, hspace=0.55
    )
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax in axes[n_panels:]:
        ax.set_visible(False)
    return fig, axes


def write_csv(path: Path, rows: list[dict]) -> Path:
    """Write ``rows`` (dicts with the same keys) as CSV."""
    with open(path, "w", newline="") as fh:
        if rows:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    return path


def power_term(grid, c: float, p: float) -> np.ndarray:
    """``c * grid**p`` (the fitted curve's a-dependent term) without an intermediate overflow or underflow.

    Computed as ``(grid / s)**p * (c * s**p)`` with ``s`` the largest ``|grid|``: the first factor lies in [0, 1], and
    ``c * s**p``, the term at the largest length, goes through logarithms where ``s**p`` alone is beyond float64.
    Before, ``grid**p`` was taken first: lengths of 1e60 µm with p = 5.5 gave inf (a curve of inf and NaN, and
    numpy's overflow warning) where ``c * grid**p`` is ~1e28. Where nothing overflowed the values are the same to
    round-off.

    Parameters
    ----------
    grid : array_like
        Lengths (µm), >= 0.
    c, p : float
        The fit's coefficient and exponent (q = q_inf + c a^p).

    Returns
    -------
    ndarray
        ``c * grid**p``; inf only where that itself is beyond float64.
    """
    grid = np.asarray(grid, dtype=np.float64)
    scale = np.max(np.abs(grid)) if grid.size else np.float64(0.0)  # numpy scalars: inf, not OverflowError
    if c == 0.0 or scale == 0.0:
        return np.zeros_like(grid)
    if not (np.isfinite(scale) and np.isfinite(c) and np.isfinite(p)):
        with np.errstate(all="ignore"):
            return c * grid**p
    with np.errstate(over="ignore", under="ignore"):
        at_scale = c * scale**p
        if not np.isfinite(at_scale) or at_scale == 0.0:  # scale**p (or the product) out of float64's range
            at_scale = np.copysign(np.exp(np.log(abs(c)) + p * np.log(scale)), c)
        return (grid / scale) ** p * at_scale


def _sample_label(s: float) -> str:
    return "whole sample" if s == FULL else f"sample L = {s:g} µm"


def quantities_figure(ds: xr.Dataset, quantities, path: Path, dpi: int) -> list[dict]:
    """Every quantity against resolution, per sample size, with the fitted curve and the limit at a = 0."""
    fig, axes = _figure(len(quantities), height_in=3.0)
    fig.subplots_adjust(left=0.09, wspace=0.42, hspace=0.75)
    rows = []
    a_max = float(ds.a_um.max())
    for ax, q in zip(axes, quantities):
        for s in ds.sample_um.values:
            v = ds.value.sel(quantity=q, sample_um=s).values
            keep = np.isfinite(v)
            if not keep.any():
                continue
            ax.plot(ds.a_um.values[keep], v[keep], "o", label=_sample_label(s))
            rows += [
                {"quantity": q, "unit": _labels.unit_of(ds, q), "sample_um": s, "a_um": a, "value": x}
                for a, x in zip(ds.a_um.values[keep], v[keep])
            ]
        ref = reference_limit(ds, q)
        if ref is not None:
            sel = ds.sel(quantity=q, form=ref.form, sample_um=FULL)
            grid = np.linspace(0.0, a_max, 100)
            ax.plot(
                grid,
                ref.value + power_term(grid, float(sel.c), float(sel.p)),
                "-",
                lw=1,
                label=f"fit p = {float(sel.p):.2g}",
            )
            ax.errorbar(
                [0.0],
                [ref.value],
                yerr=[ref.err],
                fmt="s",
                color="k",
                capsize=3,
                label=f"limit {ref.value:.5g}",
            )
            rows.append(
                {
                    "quantity": q,
                    "unit": _labels.unit_of(ds, q),
                    "sample_um": FULL,
                    "a_um": 0.0,
                    "value": ref.value,
                }
            )
            ax.set_title(_labels.title(q, 44), fontsize=8)
        else:
            why = (
                str(ds.why.sel(quantity=q, form="linear", sample_um=FULL).item())
                if FULL in ds.sample_um.values
                else "no whole-sample runs"
            )
            short = why if len(why) <= 42 else why[:41] + "…"
            ax.set_title(f"{_labels.title(q, 52)}\nno limit: {short}", fontsize=7)
        ax.set_ylabel(_labels.axis_label(ds, q), fontsize=8)
        ax.set_xlabel("voxel edge a [µm]", fontsize=8)
        ax.set_xlim(left=-0.03 * a_max)
        ax.legend(fontsize=6, loc="best")
    fig.savefig(path, dpi=dpi)
    return rows


def error_cost_figure(rows: list[dict], path: Path, dpi: int, clock: str = "wall") -> list[dict]:
    """Relative error against compute cost, log–log, one point per run, the Pareto front of each quantity joined.

    Each quantity has its own colour and marker; the legend sits right of the axes, off the data. Returns one
    summary row per quantity with the cost factor of one more correct digit.
    """
    fig = Figure(figsize=(9.0, 4.4))
    fig.subplots_adjust(left=0.1, right=0.6, bottom=0.13, top=0.92)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    summary = []
    for k, q in enumerate(dict.fromkeys(r["quantity"] for r in rows)):
        mine = [r for r in rows if r["quantity"] == q]
        cost = np.array([r["cost_s"] for r in mine])
        err = np.array([r["rel_err"] for r in mine])
        resolved = np.array([bool(r.get("resolved", 1)) for r in mine])
        front = pareto_front(cost, err)
        known = front[resolved[front]]  # errors below the limit's error bar are not known: no slope from them
        color = f"C{k % 10}"
        marker = MARKERS[k % len(MARKERS)]
        ax.loglog(cost, err, marker, color=color, ms=5, alpha=0.45, mec="none")
        ax.loglog(
            cost[front],
            err[front],
            "-" + marker,
            color=color,
            ms=6,
            lw=1.3,
            mec="k",
            mew=0.5,
            label=_labels.title(q, 36),
        )
        summary.append(
            {
                "quantity": q,
                "front_runs": int(known.size),
                "cost_factor_per_digit": cost_per_digit(cost[known], err[known]),
                "front_cost_s": cost[known].tolist(),
                "front_rel_err": err[known].tolist(),
                "clock": "CPU" if clock == "cpu" else "wall",
            }
        )
    _log_ticks(ax)
    ax.set_xlabel(f"cost of the run incl. its voxelize + segment [s, {'CPU' if clock == 'cpu' else 'wall'}]")
    ax.set_ylabel("relative error |q(a) − q∞| / |q∞|")
    ax.set_title("What accuracy costs (joined: Pareto front; faint: other runs)", fontsize=10)
    ax.grid(True, which="major", lw=0.4, alpha=0.5)
    if rows:
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, frameon=False)
    else:
        ax.text(
            0.5,
            0.5,
            "no quantity has a supported limit yet",
            ha="center",
            va="center",
            transform=ax.transAxes,
        )
    fig.savefig(path, dpi=dpi)
    return summary


def _log_ticks(ax) -> None:
    """Label the log x axis also where it spans less than a decade (matplotlib would leave it bare)."""
    lo, hi = ax.get_xlim()
    if hi / max(lo, 1e-300) < 10:
        ax.xaxis.set_minor_formatter(LogFormatterSciNotation(minor_thresholds=(2, 0.4)))
    else:
        ax.xaxis.set_minor_formatter(NullFormatter())


def message_figure(text: str, path: Path, dpi: int = 60) -> Path:
    """A small figure that says ``text`` (where a figure the workflow expects has nothing to show)."""
    fig = Figure(figsize=(4.0, 1.0))
    FigureCanvasAgg(fig)
    fig.text(0.5, 0.5, text, ha="center", va="center")
    fig.savefig(path, dpi=dpi)
    return path


def nice_length(span: float) -> float:
    """A round length (1, 2 or 5 × 10^k) near a quarter of ``span``, for a scale bar."""
    target = span / 4.0
    base = 10.0 ** np.floor(np.log10(target))
    return float(max(m * base for m in (1.0, 2.0, 5.0) if m * base <= target))


def _scale_bar(ax, span_um: float) -> None:
    length = nice_length(span_um)
    bar = AnchoredSizeBar(
        ax.transData,
        length,
        f"{length:g} µm",
        "lower right",
        pad=0.3,
        color="tab:red",
        frameon=True,
        size_vertical=span_um / 60.0,
        fontproperties={"size": 8},
    )
    bar.patch.set_alpha(0.75)
    ax.add_artist(bar)


def _mid_slice(path, name: str, axis: int) -> np.ndarray:
    with open_volume(path, name) as dset:
        index = [slice(None)] * 3
        index[axis] = dset.shape[axis] // 2
        return dset[tuple(index)]


def sections_figure(grey_paths: dict, binary_paths: dict, axis: int, path: Path, dpi: int) -> list[dict]:
    """Mid cross-sections of the grey and binary volumes at each resolution (as the thesis's Fig. 7.3)."""
    a_list = sorted(set(grey_paths) | set(binary_paths), reverse=True)
    kinds = [(k, p) for k, p in (("grey", grey_paths), ("pore", binary_paths)) if p]
    fig = Figure(figsize=(2.6 * len(a_list), 2.6 * len(kinds)))
    fig.subplots_adjust(left=0.02, right=0.98, bottom=0.02, top=0.92, wspace=0.05, hspace=0.15)
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(kinds), len(a_list), squeeze=False)
    rows = []
    for r, (name, paths) in enumerate(kinds):
        for c, a in enumerate(a_list):
            ax = axes[r, c]
            ax.set_xticks([])
            ax.set_yticks([])
            if a not in paths:
                ax.set_visible(False)
                continue
            img = _mid_slice(paths[a], name, axis)
            cmap, vmax = ("gray", 216) if name == "grey" else ("binary", 1)  # matrix white in both rows
            width_um, height_um = img.shape[0] * a, img.shape[1] * a
            ax.imshow(
                img.T,
                origin="lower",
                cmap=cmap,
                vmin=0,
                vmax=vmax,
                interpolation="nearest",
                extent=(0.0, width_um, 0.0, height_um),
            )
            _scale_bar(ax, width_um)
            ax.set_title(
                f"{'grey g (white = matrix)' if name == 'grey' else 'binary (black = pore)'}, a = {a:g} µm",
                fontsize=8,
            )
            rows.append(
                {
                    "volume": name,
                    "a_um": a,
                    "file": str(paths[a]),
                    "axis": axis,
                    "index": "middle",
                    "pore_or_mean": float(img.mean()),
                }
            )
    fig.savefig(path, dpi=dpi)
    return rows


def lpt_figure(lpt_paths: dict, path: Path, dpi: int) -> list[dict]:
    """Local percolation p_3(L) and the mean/variance of μ(φ, L) against L at each resolution (thesis Fig. 7.7)."""
    fig, axes = _figure(2)
    rows = []
    for a, file in sorted(lpt_paths.items(), reverse=True):
        with xr.open_dataset(file, engine="h5netcdf") as ds:
            L_um = ds.L_um.values
            alphas = [str(x) for x in ds.alpha.values]
            alpha = "3" if "3" in alphas else alphas[0]
            p = ds.p.values[:, alphas.index(alpha)]
            var = ds.phi_var.values
        axes[0].plot(L_um, p, "o-", ms=3, label=f"a = {a:g} µm")
        axes[1].plot(L_um, var, "o-", ms=3, label=f"a = {a:g} µm")
        rows += [
            {"a_um": a, "L_um": l, "alpha": alpha, "p": x, "phi_var": v} for l, x, v in zip(L_um, p, var)
        ]
    axes[0].set(xlabel="cell edge L [µm]", ylabel="p_α(L) [1]", xscale="log", title="local percolation")
    axes[1].set(
        xlabel="cell edge L [µm]",
        ylabel="variance of μ(φ, L) [1]",
        xscale="log",
        yscale="log",
        title="local porosity spread",
    )
    for ax in axes[:2]:
        ax.legend(fontsize=6)
    fig.savefig(path, dpi=dpi)
    return rows
