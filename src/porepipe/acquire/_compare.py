"""Model versus experiment in the layout of Zauner (2020) Tables 8.4 and 8.5 and Figs. 8.10-8.12.

:func:`compare` takes the two statistics files (``statistics.h5`` of the image, ``model_statistics.h5`` of the
calibrated model) and returns one xarray Dataset: a ``quantity`` table (experiment, model, difference, relative
difference) and, where both sides have LPT results, μ(φ, L), λ_3(φ, L) and p_3(L) on common cell sizes in µm.
:func:`plot_comparison` draws the overlays as one PNG.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import open_h5, read_table

#: Table 8.4 (Minkowski) and Table 8.5 (LB) quantities: (name in the statistics, label, unit)
QUANTITIES = [
    ("porosity", "φ", "1"),
    ("S_V_per_mm", "S_V", "mm^-1"),
    ("K_V_per_mm2", "K_V", "mm^-2"),
    ("T_V_per_mm3", "T_V", "mm^-3"),
    ("connected_porosity_mean", "connected φ", "1"),
    ("grains_per_mm3", "grain density", "mm^-3"),
    ("mean_equivalent_radius_um", "mean grain radius", "µm"),
]
PERMEABILITY = [
    ("mean_velocity_um_s", "mean flow velocity", "µm/s"),
    ("velocity_variance_um2_s2", "variance of flow velocity", "µm²/s²"),
    ("kappa_mD", "κ", "mD"),
]


def _groups(path) -> dict[str, xr.Dataset]:
    out = {"": read_table(path)}
    with open_h5(path) as f:
        present = [group for group in ("lpt", "permeability") if group in f]
    for group in present:  # optional groups: absent is fine, a damaged one is an error naming the file
        out[group] = read_table(path, group)
    return out


def _scalar(root: xr.Dataset, name: str) -> float:
    if name == "connected_porosity_mean" and "connected_porosity" in root:
        return float(root.connected_porosity.mean())
    if name == "mean_equivalent_radius_um" and "equivalent_radius_um" in root:
        r = root.equivalent_radius_um.values
        return float(r.mean()) if r.size else np.nan
    return float(root[name]) if name in root else np.nan


def _table(exp: dict, mod: dict) -> xr.Dataset:
    names, labels, units, e, m = [], [], [], [], []
    for name, label, unit in QUANTITIES:
        names.append(name), labels.append(label), units.append(unit)
        e.append(_scalar(exp[""], name)), m.append(_scalar(mod[""], name))
    if "permeability" in exp and "permeability" in mod:
        for name, label, unit in PERMEABILITY:
            if name not in exp["permeability"] or name not in mod["permeability"]:
                continue  # velocities: statistics written before they were recorded
            names.append(name), labels.append(label), units.append(unit)
            e.append(float(exp["permeability"][name])), m.append(float(mod["permeability"][name]))
    e, m = np.asarray(e), np.asarray(m)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(e != 0, (m - e) / np.abs(e), np.nan)
    return xr.Dataset(
        {
            "experiment": ("quantity", e),
            "model": ("quantity", m),
            "difference": ("quantity", m - e, {"long_name": "model - experiment"}),
            "relative_difference": ("quantity", rel, {"long_name": "(model - experiment) / |experiment|"}),
        },
        coords={"quantity": names, "label": ("quantity", labels), "unit": ("quantity", units)},
    )


def _on_common_lengths(exp: xr.Dataset, mod: xr.Dataset) -> tuple[xr.Dataset, xr.Dataset, np.ndarray]:
    common = np.intersect1d(np.round(exp.L_um.values, 9), np.round(mod.L_um.values, 9))
    pick = lambda ds: ds.isel(L=np.flatnonzero(np.isin(np.round(ds.L_um.values, 9), common)))  # noqa: E731
    return pick(exp), pick(mod), common


def _lpt_overlay(exp: xr.Dataset, mod: xr.Dataset) -> xr.Dataset:
    e, m, common = _on_common_lengths(exp, mod)
    if common.size == 0:
        return xr.Dataset()
    data = {}
    for side, ds in (("experiment", e), ("model", m)):
        data[f"mu_{side}"] = (("side_L", "bin"), (ds.mu_density if "mu_density" in ds else ds.mu).values)
        data[f"phi_{side}"] = (("side_L", "bin"), ds.phi.values)
        data[f"lambda3_{side}"] = (("side_L", "bin"), ds["lambda"].sel(alpha="3").values)
        data[f"p3_{side}"] = ("side_L", ds.p.sel(alpha="3").values)
        data[f"phi_mean_{side}"] = ("side_L", ds.phi_mean.values)
    bins = min(e.sizes["bin"], m.sizes["bin"])
    data = {k: (d, v[..., :bins] if "bin" in d else v) for k, (d, v) in data.items()}
    out = xr.Dataset(data, coords={"side_L": common})
    out["side_L"].attrs.update(units="µm", long_name="LPT cell edge L")
    out["p3_difference"] = out.p3_model - out.p3_experiment
    out["phi_mean_difference"] = out.phi_mean_model - out.phi_mean_experiment
    return out


def compare(experiment_path, model_path) -> xr.Dataset:
    """Side-by-side comparison of two statistics files (Tables 8.4, 8.5; LPT overlays of Figs. 8.10-8.12)."""
    exp, mod = _groups(experiment_path), _groups(model_path)
    out = _table(exp, mod)
    if "lpt" in exp and "lpt" in mod:
        out = xr.merge([out, _lpt_overlay(exp["lpt"], mod["lpt"])])
    if "two_point" in exp[""] and "two_point" in mod[""]:
        e2, m2 = exp[""].two_point.mean("axis"), mod[""].two_point.mean("axis")
        lag_um = np.intersect1d(np.round(e2.lag_um.values, 9), np.round(m2.lag_um.values, 9))
        sel = lambda da: da.values[np.isin(np.round(da.lag_um.values, 9), lag_um)]  # noqa: E731
        out["two_point_experiment"] = ("lag_um", sel(e2))
        out["two_point_model"] = ("lag_um", sel(m2))
        out = out.assign_coords(lag_um=lag_um)
    out.attrs.update(
        experiment=str(experiment_path),
        model=str(model_path),
        layout="Zauner (2020) Table 8.4 (phi, S_V, K_V, T_V), Table 8.5 (kappa), Figs. 8.10-8.12",
    )
    return out


def comparison_markdown(ds: xr.Dataset) -> str:
    """The quantity table as Markdown (the report stage can embed it as is)."""
    lines = [
        "| quantity | unit | experiment | model | model − experiment | relative |",
        "|---|---|---|---|---|---|",
    ]
    for i in range(ds.sizes["quantity"]):
        row = ds.isel(quantity=i)
        lines.append(
            f"| {row.label.item()} | {row.unit.item()} | {float(row.experiment):.6g} | "
            f"{float(row.model):.6g} | {float(row.difference):.4g} | {float(row.relative_difference):+.2%} |"
        )
    return "\n".join(lines)


def plot_comparison(ds: xr.Dataset, path) -> Path:
    """One PNG: μ(φ, L) and λ_3(φ, L) for up to four common L, p_3(L), S_2(r); experiment solid, model dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(10, 8))
    has_lpt = "side_L" in ds.dims and ds.sizes["side_L"] > 0
    if has_lpt:
        Ls = ds.side_L.values
        pick = np.unique(np.linspace(0, Ls.size - 1, min(4, Ls.size)).round().astype(int))
        for j, i in enumerate(pick):
            color = f"C{j}"
            for side, style in (("experiment", "-"), ("model", "--")):
                phi = ds[f"phi_{side}"].isel(side_L=i).values
                ok = np.isfinite(phi)
                inner = ok & (phi > 0) & (phi < 1)  # μ(0), μ(1) are point masses, not density: left out here
                axes[0, 0].plot(
                    phi[inner],
                    ds[f"mu_{side}"].isel(side_L=i).values[inner],
                    style,
                    color=color,
                    label=f"{side} L={Ls[i]:g} µm",
                )
                axes[0, 1].plot(phi[ok], ds[f"lambda3_{side}"].isel(side_L=i).values[ok], style, color=color)
        for side, style in (("experiment", "o-"), ("model", "s--")):
            axes[1, 0].plot(Ls, ds[f"p3_{side}"].values, style, label=side)
        axes[0, 0].legend(fontsize=7)
        axes[1, 0].legend()
    else:
        for ax in (axes[0, 0], axes[0, 1], axes[1, 0]):
            ax.text(0.5, 0.5, "no LPT on both sides", ha="center", transform=ax.transAxes)
    axes[0, 0].set(xlabel="φ", ylabel="μ(φ, L) [probability density]", title="local porosity distribution")
    axes[0, 1].set(xlabel="φ", ylabel="λ₃(φ, L)", title="local percolation probability")
    axes[1, 0].set(xlabel="L [µm]", ylabel="p₃(L)", title="fraction of percolating cells")
    if "two_point_experiment" in ds:
        axes[1, 1].plot(ds.lag_um, ds.two_point_experiment, "-", label="experiment")
        axes[1, 1].plot(ds.lag_um, ds.two_point_model, "--", label="model")
        axes[1, 1].legend()
    axes[1, 1].set(xlabel="r [µm]", ylabel="S₂(r)", title="two-point correlation (mean over axes)")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_comparison(experiment_path, model_path, out, png=None) -> xr.Dataset:
    """Write ``comparison.h5`` (the Dataset), a PNG beside it and a Markdown table ``.md``."""
    from porepipe._shared.store import ResultWriter

    ds = compare(experiment_path, model_path)
    if ds.sizes.get("quantity", 0) == 0:
        raise PorepipeError("nothing to compare")
    out = Path(out)
    with ResultWriter(out, stage="acquire-compare") as w:
        w.write_table(ds)
    plot_comparison(ds, png or out.with_suffix(".png"))
    out.with_suffix(".md").write_text(comparison_markdown(ds) + "\n")
    return ds
