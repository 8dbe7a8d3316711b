"""Calibration: image statistics -> a model scene (packing + decoration) that the user can edit and run.

The packer needs a sphere count, a radius distribution from the families it supports (packing.RadiusDist: uniform,
truncated exponential, discrete), and a maximum overlap; the decoration needs grain families with elongation ranges.
From the statistics: count = grain number density x model box volume; radii = radii of the spheres the grains grew
from (distance-transform peaks, grains cut by the image boundary left out); elongation classes = quantile classes of
the grains' inertia-tensor elongation. The target porosity is recorded with the scene so the comparison can check it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import xarray as xr
import yaml
from scipy import optimize, stats

from porepipe._shared.atomic import write_text_atomic
from porepipe._shared.errors import PorepipeError
from porepipe.acquire._settings import Calibration, Family

#: smallest number of uncut grains for which the radius fit uses only uncut grains
_MIN_UNCUT = 10
#: a parametric family is accepted if its Kolmogorov-Smirnov p-value exceeds this; else the discrete table is used
_KS_ACCEPT_P = 0.01
#: the calibrated stage's time step and damping where the grains are large enough: dt = 0.25, Xi = 4 (C- = 1/2)
_DT, _DAMPING_DT = 0.25, 1.0
#: largest stable time step per µm of the closest equilibrium distance dx_eq of two grains: the pair force
#: (packing._kernels._pair_force, k = 400, m = 1) is stiffest just beyond contact, 32 k / dx_eq², so a pair
#: oscillates at ω = sqrt(2 · 32 k) / dx_eq = 160 / dx_eq and the Verlet step is stable for ω dt < 2
_DT_PER_UM = 1.0 / 80.0


@dataclasses.dataclass
class RadiusFit:
    """Fitted radius distribution: the packer's ``radius_um`` block, the KS statistic of every candidate."""

    spec: dict
    family: Family
    ks: dict[str, float]
    pvalue: dict[str, float]


def _truncexp_cdf(r, lo, hi, alpha):
    r = np.clip(r, lo, hi)
    if alpha <= 0:
        return (r - lo) / (hi - lo)
    return -np.expm1(-alpha * (r - lo)) / -np.expm1(-alpha * (hi - lo))


def _truncexp_mean(alpha, lo, hi):
    w = hi - lo
    return lo + 1.0 / alpha - w * np.exp(-alpha * w) / -np.expm1(-alpha * w)


def fit_exponential_alpha(radii: np.ndarray, lo: float, hi: float) -> float:
    """Maximum-likelihood alpha of P(r) ∝ exp(-alpha r) on [lo, hi] (mean matching); 0 if the data do not decay."""
    mean = float(np.mean(radii))
    if mean >= 0.5 * (lo + hi) or hi <= lo:
        return 0.0  # the packer allows alpha >= 0 only; a non-decaying sample is best fitted by alpha = 0
    f = lambda a: _truncexp_mean(a, lo, hi) - mean  # noqa: E731  (decreasing in a)
    top = 1.0 / max(mean - lo, 1e-12 * (hi - lo))
    while f(top) > 0:
        top *= 2
    return float(optimize.brentq(f, 1e-12 / (hi - lo), top, xtol=1e-14, rtol=1e-12))


def fit_radius_distribution(radii_um, families: list[Family], discrete_bins: int = 12) -> RadiusFit:
    """Fit the radius sample with each family; the best-KS parametric family wins if acceptable, else discrete."""
    r = np.asarray(radii_um, dtype=np.float64).ravel()
    bad = np.flatnonzero(~(np.isfinite(r) & (r > 0)))
    if bad.size:
        raise PorepipeError(f"radii_um[{bad[0]}] = {r[bad[0]]}; allowed: positive, finite radii")
    if r.size < 2:
        raise PorepipeError(
            f"calibration needs at least 2 grain radii, got {r.size}: the image has (almost) no "
            "grains; check the segmentation (acquire --method/--thresholds, or the scene's acquire.segmentation) "
            "or the grain phase"
        )
    lo, hi = float(r.min()), float(r.max())
    if hi <= lo:
        return RadiusFit({"dist": "uniform", "min_um": lo, "max_um": lo}, Family.uniform, {}, {})
    specs, ks, pval = {}, {}, {}
    if Family.uniform in families:
        specs[Family.uniform] = {"dist": "uniform", "min_um": lo, "max_um": hi}
        res = stats.kstest(r, lambda x: _truncexp_cdf(x, lo, hi, 0.0))
        ks["uniform"], pval["uniform"] = float(res.statistic), float(res.pvalue)
    if Family.exponential in families:
        alpha = fit_exponential_alpha(r, lo, hi)
        specs[Family.exponential] = {"dist": "exponential", "min_um": lo, "max_um": hi, "alpha_per_um": alpha}
        res = stats.kstest(r, lambda x: _truncexp_cdf(x, lo, hi, alpha))
        ks["exponential"], pval["exponential"] = float(res.statistic), float(res.pvalue)
    parametric = sorted((k for k in specs), key=lambda f: ks[f.value])
    if parametric and (pval[parametric[0].value] > _KS_ACCEPT_P or Family.discrete not in families):
        best = parametric[0]
        return RadiusFit(specs[best], best, ks, pval)
    if Family.discrete not in families:
        raise PorepipeError(f"acquire.calibration.families = {[f.value for f in families]}: none is usable")
    counts, edges = np.histogram(r, bins=discrete_bins, range=(lo, hi))
    keep = counts > 0
    probs = counts[keep] / counts.sum()
    probs[-1] = 1.0 - probs[:-1].sum()
    spec = {
        "dist": "discrete",
        "values_um": [float(v) for v in 0.5 * (edges[:-1] + edges[1:])[keep]],
        "probabilities": [float(p) for p in probs],
    }
    return RadiusFit(spec, Family.discrete, ks, pval)


def grain_radii(stats_ds: xr.Dataset) -> np.ndarray:
    """Radii of the spheres the grains grew from; uncut grains only when there are enough of them."""
    if "inscribed_radius_um" not in stats_ds or stats_ds.sizes.get("grain", 0) == 0:
        raise PorepipeError(
            "the statistics have no grains (image all pore, or measured with acquire --no-grains or the scene's "
            "acquire.statistics.grains: false); "
            "cannot calibrate a packing"
        )
    r = stats_ds.inscribed_radius_um.values
    uncut = stats_ds.cut.values == 0
    return r[uncut] if uncut.sum() >= _MIN_UNCUT else r


def elongation_classes(stats_ds: xr.Dataset, n_classes: int) -> list[dict]:
    """Quantile classes of grain elongation: [{elongation: [lo, hi], probability}] (uncut grains)."""
    e = stats_ds.elongation.values[stats_ds.cut.values == 0]
    e = e if e.size else stats_ds.elongation.values
    edges = np.unique(np.quantile(e, np.linspace(0, 1, n_classes + 1)))
    if edges.size < 2:
        return [{"elongation": [float(edges[0]), float(edges[0])], "probability": 1.0}]
    counts, _ = np.histogram(e, bins=edges)
    probs = counts / counts.sum()
    return [
        {"elongation": [float(a), float(b)], "probability": float(p)}
        for a, b, p in zip(edges[:-1], edges[1:], probs)
        if p > 0
    ]


def _decoration(classes: list[dict]) -> dict | None:
    """A decoration section with one random-polyhedron family per elongation class."""
    from porepipe.decorate import Settings as DecorationSettings

    families = [
        {
            "name": f"elong{i}",
            "generator": "random",
            "count": 8,
            "facets": 36,
            "elongation": [min(c["elongation"][0], 0.9), min(c["elongation"][1], 0.9)],
        }
        for i, c in enumerate(classes)
    ]
    probs = {f["name"]: c["probability"] for f, c in zip(families, classes)}
    total = sum(probs.values())
    probs = {k: v / total for k, v in probs.items()}
    section = {"families": families, "assign": [{"probabilities": probs}], "scale": "inscribed"}
    DecorationSettings.model_validate(section)
    return section


def time_step(radius_spec: dict, max_overlap: float) -> float:
    """The calibrated stage's time step: 0.25, or less where the smallest grains make that unstable.

    The packer's pair force scales as 1 / dx_eq, so its stiffness as 1 / dx_eq²: a fixed dt = 0.25 is stable for
    grains of r >= 10.5 µm (max_overlap 0.1) and made grains of a few µm oscillate and overlap without end (an image
    of 2 µm voxels whose grains had r = 4 µm). The damping goes with 1 / dt (``dt Xi`` = 1), so the packing of
    small grains runs step by step as that of grains scaled up to r = 10.5 µm.
    """
    values = radius_spec.get("values_um") or [radius_spec["min_um"]]
    closest = min(values) * (2.0 - max_overlap)  # dx_eq of two of the smallest grains at the largest overlap
    return min(_DT, float(f"{_DT_PER_UM * closest:.3g}"))


def calibrated_scene(stats_ds: xr.Dataset, calibration: Calibration, *, name: str, seed: int = 0) -> dict:
    """The model scene (a plain dict, ready for YAML) calibrated to the image statistics."""
    voxel = float(stats_ds.attrs["voxel_um"])
    shape = np.asarray(stats_ds.attrs["shape"], dtype=np.float64)
    a = float(calibration.resolution_um or voxel)
    box = [float(b) for b in (calibration.box_um or tuple(shape * voxel))]
    box = [max(a, round(b / a) * a) for b in box]  # whole voxels per edge at the model resolution
    fit = fit_radius_distribution(grain_radii(stats_ds), calibration.families, calibration.discrete_bins)
    density = float(stats_ds.grains_per_mm3)
    count = int(round(density * np.prod(box) * 1e-9))
    if count < 1:
        raise PorepipeError(f"grain density {density:.4g} /mm³ gives no sphere in the model box {box} µm")
    dt = time_step(fit.spec, calibration.max_overlap)
    stage = {
        "name": "calibrated",
        "insert": ["grain"],
        "steps": calibration.steps,
        "dt": dt,
        "k": {"grain": 400.0},
        "damping": {"grain": float(f"{_DAMPING_DT / dt:.3g}")},
        "freezing": {"lock_step": 10},
        "stochastic_forces": {"step_size": 0.05},
    }
    scene = {
        "name": name,
        "seed": int(seed),
        "domain": {"size_um": box, "periodic": True},
        "spheres": {"pack": True},
        "packing": {
            "types": [
                {
                    "name": "grain",
                    "count": count,
                    "radius_um": fit.spec,
                    "max_overlap": calibration.max_overlap,
                }
            ],
            "stages": [stage],
        },
        "resolutions_um": [a],
        "segmentation": {"method": "otsu"},
        "analyses": ["segment", "minkowski", "lpt"],
    }
    classes = elongation_classes(stats_ds, calibration.elongation_classes)
    deco = _decoration(classes) if calibration.decoration else None
    if deco is not None:
        scene["decoration"] = deco
    scene["_calibration"] = {
        "target_porosity": float(stats_ds.porosity),
        "grains_per_mm3": density,
        "radius_family": fit.family.value,
        "ks_statistic": fit.ks,
        "ks_pvalue": fit.pvalue,
        "elongation_classes": classes,
        "source_voxel_um": voxel,
        "S_V_per_mm": float(stats_ds.S_V_per_mm) if "S_V_per_mm" in stats_ds else None,
    }
    return scene


def write_scene_yaml(scene: dict, path) -> Path:
    """Write the calibrated scene; the calibration record goes into a comment block the scene loader ignores."""
    scene = dict(scene)
    record = scene.pop("_calibration", {})
    header = [
        "# Calibrated by `porepipe acquire-calibrate` from image statistics (Zauner 2020 §4.7 item 1).",
        "# Edit freely, then run it with `porepipe run <this file>`. What it was fitted to:",
    ]
    header += [f"#   {line}" for line in yaml.safe_dump(record, sort_keys=False).splitlines()]
    return write_text_atomic(path, "\n".join(header) + "\n" + yaml.safe_dump(scene, sort_keys=False))
