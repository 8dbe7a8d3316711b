"""PNG plots of an lpt Dataset, in the manner of thesis Figs. 4.4-4.6: μ(φ, L), λ_α(φ, L), p_α(L), μ(S_V, L)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure  # no pyplot: no global state, Agg canvas

#: at most this many cell sizes per panel (evenly chosen), so the curves stay readable
MAX_CURVES = 7
#: λ(φ, L) is drawn only for bins with at least this many cells (the data file keeps all bins and their counts)
MIN_LAMBDA_CELLS = 10


def _pick(n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, MAX_CURVES)).round().astype(int))


def _curve(ax, x: np.ndarray, y: np.ndarray, label: str) -> None:
    keep = np.isfinite(x) & np.isfinite(y)
    marker = "o" if keep.sum() <= 12 else None
    ax.plot(x[keep], y[keep], marker=marker, ms=3, lw=1.2, label=label)


def _save(fig: Figure, path: Path) -> Path:
    """Legend (where a curve was drawn: with cells of one voxel only, the S_V plot has none), layout, PNG."""
    for ax in fig.axes:
        if ax.get_legend_handles_labels()[0]:
            fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def plot_mu(ds: xr.Dataset, path) -> Path:
    """μ(φ, L) as a density in φ for several L (thesis Fig. 4.4)."""
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    for i in _pick(ds.sizes["L"]):
        d = ds.isel(L=i)
        inner = np.isfinite(d.phi.values)
        _curve(
            ax, d.phi.values[inner], d.mu_density.values[inner], f"L = {float(d.L_um):g} µm ({int(d.L)} vx)"
        )
    ax.axvline(ds.attrs["phi_bar"], color="0.5", ls=":", lw=1, label="mean porosity")
    ax.set(
        xlabel="local porosity φ",
        ylabel="μ(φ, L)  (density)",
        yscale="log",
        xlim=(0, 1),
        title="local porosity distribution",
    )
    return _save(fig, Path(path))


def plot_lambda(ds: xr.Dataset, path, alpha: str | None = None) -> Path:
    """λ_α(φ, L) for several L (thesis Fig. 4.5); α = 3 if computed, else the first direction."""
    alphas = [str(a) for a in ds.alpha.values]
    alpha = alpha or ("3" if "3" in alphas else alphas[0])
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    for i in _pick(ds.sizes["L"]):
        d = ds.isel(L=i).sel(alpha=alpha)
        lam = np.where(d.lambda_cells.values >= MIN_LAMBDA_CELLS, d["lambda"].values, np.nan)
        _curve(ax, d.phi.values, lam, f"L = {float(d.L_um):g} µm ({int(d.L)} vx)")
    ax.set(
        xlabel="local porosity φ",
        ylabel=f"λ_{alpha}(φ, L)",
        xlim=(0, 1),
        ylim=(-0.02, 1.02),
        title=f"local percolation probability (bins with >= {MIN_LAMBDA_CELLS} cells)",
    )
    return _save(fig, Path(path))


def plot_p(ds: xr.Dataset, path) -> Path:
    """p_α(L) against L in µm for every computed α (thesis Fig. 4.6)."""
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    for alpha in ds.alpha.values:
        _curve(ax, ds.L_um.values, ds.p.sel(alpha=alpha).values, f"α = {alpha}")
    ax.set(
        xlabel="cell edge L [µm]",
        ylabel="p_α(L)",
        xscale="log",
        ylim=(-0.02, 1.02),
        title="fraction of percolating cells",
    )
    return _save(fig, Path(path))


def plot_surface(ds: xr.Dataset, path) -> Path:
    """μ(S_V, L) for several L."""
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    for i in _pick(ds.sizes["L"]):
        d = ds.isel(L=i)
        if int(d.L) > 1:
            _curve(ax, d.sv_per_um.values, d.mu_sv.values, f"L = {float(d.L_um):g} µm ({int(d.L)} vx)")
    ax.set(
        xlabel="local S_V [1/µm]", ylabel="μ(S_V, L)  (per bin)", title="local specific-surface distribution"
    )
    return _save(fig, Path(path))


def plot_lpt(ds: xr.Dataset, stem) -> list[Path]:
    """All plots of ``ds`` as ``{stem}_mu.png``, ``_lambda.png``, ``_p.png`` (and ``_sv.png``); returns the paths."""
    stem = Path(stem)
    paths = [
        plot_mu(ds, f"{stem}_mu.png"),
        plot_lambda(ds, f"{stem}_lambda.png"),
        plot_p(ds, f"{stem}_p.png"),
    ]
    if "mu_sv" in ds:
        paths.append(plot_surface(ds, f"{stem}_sv.png"))
    return paths
