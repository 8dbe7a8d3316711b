"""Calibration: image statistics -> a model scene (packing + decoration) that the user can edit and run.

The packer needs a sphere count, a radius distribution from the families it supports (packing.RadiusDist: uniform,
truncated exponential, discrete), and a maximum overlap; the decoration needs grain families with elongation ranges.
From the statistics: count = grain number density x model box volume; radii = radii of the spheres the grains grew
from (distance-transform peaks of the grains centred in the image, :func:`grain_radii`); elongation classes = quantile
classes of the grains' inertia-tensor elongation. The DEM stage's interaction constant k is chosen from the maximum
overlap so that the packing can converge (:func:`interaction_constant`), its time step and damping from k. Sphere
count and maximum overlap are then matched to the image's porosity and specific surface S_V by packing the model
(:func:`porepipe.acquire.match_statistics`), and the scene records what was matched.
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

#: smallest number of grains centred in the image for which the radius fit uses only those
_MIN_CENTRED = 10
#: a parametric family is accepted if its Kolmogorov-Smirnov p-value exceeds this; else the discrete table is used
_KS_ACCEPT_P = 0.01
#: the calibrated stage's time step at k = 400 where the grains are large enough (smaller for stiffer k, below)
_DT = 0.25
#: dt Xi of the calibrated stage (C- = 1 - dt Xi / 2 = 0.975): light damping. Measured (150 spheres, r 40-80 µm,
#: sigma_max 0.1, k from interaction_constant, 400 steps, seeds 1-3): dt Xi = 0.05 converged 145-150 of 150 spheres,
#: dt Xi = 0.25 132-137, dt Xi = 1 (C- = 1/2, the earlier choice) 123-125; the heavily damped spheres freeze in
#: place where a lightly damped one still slides out of a too deep overlap
_DAMPING_DT = 0.05
#: largest stable time step per µm of the closest equilibrium distance dx_eq of two grains at k = 400: the pair force
#: (packing._kernels._pair_force, m = 1) is stiffest just beyond contact, 32 k / dx_eq², so a pair oscillates at
#: ω = sqrt(2 · 32 k) / dx_eq = 160 / dx_eq and the Verlet step is stable for ω dt < 2; ω scales as sqrt(k)
_DT_PER_UM = 1.0 / 80.0
#: the thesis's interaction constant (§5.6.1 phase 1: k = 400, sigma_max = 0.3, converged in 20 steps)
_K_THESIS = 400.0
#: largest attraction of the pair force in units of k / dx_eq: at dx = (17/9)^(1/8) dx_eq, |f| = (288/289) (9/17)^(1/8)
_ATTRACTION_PEAK = 288.0 / 289.0 * (9.0 / 17.0) ** 0.125


def _radius_range(radius_spec: dict) -> tuple[float, float]:
    values = radius_spec.get("values_um")
    if values:
        return float(min(values)), float(max(values))
    return float(radius_spec["min_um"]), float(radius_spec["max_um"])


def interaction_constant(radius_spec: dict, max_overlap: float) -> float:
    """The calibrated stage's k: a pair pressed to ``max_overlap`` repels at least as hard as a neighbour can pull.

    The pair force (Zauner 2020 §5.2) is a harmonic core, sqrt(k) (1 + k/4) / dx_eq (1 - dx / dx_eq), inside the
    equilibrium distance dx_eq (overlap sigma_max / 2) and a Lennard-Jones tail whose attraction peaks at
    0.9204 k / dx_eq. At the largest allowed overlap, 1 - dx_min / dx_eq = sigma_max r_s / dx_eq (r_s the smaller
    radius), so the core's push there against the peak pull is R = (1 + k/4) sigma_max r_s / (0.9204 sqrt(k) dx_eq).
    With R < 1 one attracting neighbour presses a contact past sigma_max, and the packing cannot converge: k = 400 at
    sigma_max = 0.1 gives R = 0.29 (equal spheres) and 42-60 of 150 spheres converged however long it ran. The
    thesis's k = 400 at sigma_max = 0.3 (§5.6.1, converged in 20 steps) has R = 0.97 for equal spheres: the k
    returned keeps R >= 1 for the least favourable pair (smallest radius against largest), and is at least 400.

    Parameters
    ----------
    radius_spec : dict
        The packer's ``radius_um`` block (uniform, exponential or discrete).
    max_overlap : float
        sigma_max of the grains.

    Returns
    -------
    float
        k, to 3 significant digits.
    """
    r_s, r_l = _radius_range(radius_spec)
    a = _ATTRACTION_PEAK * (r_s + r_l - max_overlap * r_s) / (max_overlap * r_s)
    # (1 + k/4) / sqrt(k) >= a; with x = sqrt(k): x^2 - 4 a x + 4 >= 0, whose larger root is 2 (a + sqrt(a^2 - 1))
    root = 2.0 * (a + np.sqrt(a * a - 1.0)) if a > 1.0 else 0.0
    return max(_K_THESIS, float(f"{np.ceil(root * root):.3g}"))


def stage_dynamics(radius_spec: dict, max_overlap: float) -> dict:
    """The calibrated stage's ``k``, ``dt`` and ``damping`` (``dt Xi`` = 0.05) for a radius law and sigma_max."""
    k = interaction_constant(radius_spec, max_overlap)
    dt = time_step(radius_spec, max_overlap, k)
    return {"k": {"grain": k}, "dt": dt, "damping": {"grain": float(f"{_DAMPING_DT / dt:.3g}")}}


def _law_points(radius_spec: dict) -> tuple[np.ndarray, np.ndarray]:
    """Radii and their probabilities (summing to 1) under the packer's radius law, on a fine grid if continuous."""
    values = radius_spec.get("values_um")
    if values:
        r = np.asarray(values, dtype=np.float64)
        p = np.asarray(radius_spec["probabilities"], dtype=np.float64)
    else:
        lo, hi = _radius_range(radius_spec)
        r = np.linspace(lo, hi, 4001)
        p = np.exp(-float(radius_spec.get("alpha_per_um", 0.0)) * (r - lo))
    return r, p / p.sum()


def radius_moments(radius_spec: dict, power: int = 3) -> tuple[float, float]:
    """Mean and standard deviation of r**power (µm**power) under the packer's radius law."""
    r, p = _law_points(radius_spec)
    x = r**power
    mean = float(np.sum(p * x))
    return mean, float(np.sqrt(np.sum(p * (x - mean) ** 2)))


def porosity_tolerance(radius_spec: dict, count: int, box_um) -> float:
    """Realisation scatter of a model's porosity: sqrt(N) sd(v) / V for N spheres of random volume v in the box V.

    A model packed with other positions and other radii drawn from the same law differs by about this much (the sum
    of N independent sphere volumes dominates; overlaps bounded by sigma_max change it little), so matching the
    image's porosity closer than this fits one realisation, not the law. It is at least half a sphere's volume
    mean(v) / (2 V): the count cannot set the porosity finer.
    """
    mean, sd = radius_moments(radius_spec, 3)
    volume = float(np.prod(np.asarray(box_um, dtype=np.float64)))
    # never below half a sphere: the count, the only control of the porosity, moves it by mean(v) / V per sphere (and
    # a law without radius scatter, equal grains, had a tolerance of 0, which no packing meets)
    return float(4.0 / 3.0 * np.pi * max(np.sqrt(count) * sd, 0.5 * mean) / volume)


def surface_tolerance(radius_spec: dict, count: int, s_v_per_mm: float) -> float:
    """Realisation scatter of a model's specific surface S_V: S_V sd(r²) / (mean(r²) sqrt(N)), per mm.

    The pore-solid surface is the sum of the N spheres' exposed surfaces e 4π r²; with the exposed fraction e the
    same for every sphere, the sum's standard deviation is e 4π sqrt(N) sd(r²), a fraction sd(r²) / (mean(r²)
    sqrt(N)) of S_V (the law's coefficient of variation of the sphere surface over sqrt(N)). Measured: 20 packings
    of 157 spheres (exponential radii 40-80 µm, alpha 0.05/µm, 600 µm box, 6 µm voxels, seeds 1-20) scatter by 3.7 %
    at sigma_max 0.4 and 2.9 % at 0.3 (2.4-3.0 % about their trend with porosity), against 3.2 % from this formula.
    A model closer to the image's S_V than this fits one realisation, not the law. It is at least half a sphere's
    share, S_V / (2 N).
    """
    mean, sd = radius_moments(radius_spec, 2)
    count = max(count, 1)
    # never below half a sphere's share S_V / (2 N): equal grains (sd 0) had a tolerance of 0 and a misfit of x / 0
    return float(s_v_per_mm * max(sd / (mean * np.sqrt(count)), 0.5 / count))


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
    """Radii of the spheres the grains grew from: those whose centre lies in the image, when there are enough of them.

    A grain counts (``counted``) when its marker, the distance-transform peak at the sphere's centre, is not on the
    image boundary. Whether a sphere's centre lies in the box does not depend on its size, so these radii are a
    sample of the radius law; the distance transform does not see past the image boundary, so a sphere cut by it
    still peaks at its radius. Grains not touching the boundary (``cut`` = 0), the earlier choice, are kept with a
    probability that falls with size, about (L - 2r)³ / L³ in a box of edge L: 83 uncut grains of an image of 150
    spheres of r 40-80 µm, alpha 0.05/µm in a 600 µm box fitted alpha 0.074 (their true radii 0.090), the 132
    counted ones 0.045. Statistics without ``counted`` (older files) fall back to the uncut grains.
    """
    if "inscribed_radius_um" not in stats_ds or stats_ds.sizes.get("grain", 0) == 0:
        raise PorepipeError(
            "the statistics have no grains (image all pore, or measured with acquire --no-grains or the scene's "
            "acquire.statistics.grains: false); "
            "cannot calibrate a packing"
        )
    r = stats_ds.inscribed_radius_um.values
    centred = stats_ds.counted.values == 1 if "counted" in stats_ds else stats_ds.cut.values == 0
    return r[centred] if centred.sum() >= _MIN_CENTRED else r


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


def time_step(radius_spec: dict, max_overlap: float, k: float = _K_THESIS) -> float:
    """The calibrated stage's time step: 0.25 sqrt(400 / k), or less where the smallest grains make that unstable.

    The packer's pair force scales as 1 / dx_eq, so its stiffness as k / dx_eq²: at k = 400 a fixed dt = 0.25 is
    stable for grains of r >= 10.5 µm (max_overlap 0.1) and made grains of a few µm oscillate and overlap without end
    (an image of 2 µm voxels whose grains had r = 4 µm). A stiffer k (:func:`interaction_constant`) shortens the
    step by sqrt(400 / k), so that ω dt stays what it is at k = 400. A sphere inserted onto a neighbour is pushed by
    the harmonic core's largest force, sqrt(k) (1 + k/4) / dx_eq, which grows as k^1.5: from rest one step moves it
    F dt² / 2 (m = 1), and the step is also kept to dt <= dx_eq / sqrt(sqrt(k) (1 + k/4)), so that this is at most
    dx_eq / 2 (never binding at k = 400; without it, 300 spheres of r 3-6 µm in a 64 µm box at k = 10 900,
    dt = 0.0139, ran away in 2 of 3 seeds).
    """
    r_s, _ = _radius_range(radius_spec)
    closest = r_s * (2.0 - max_overlap)  # dx_eq of two of the smallest grains at the largest overlap
    oscillation = min(_DT, _DT_PER_UM * closest) * np.sqrt(_K_THESIS / k)
    push = closest / np.sqrt(np.sqrt(k) * (1.0 + 0.25 * k))
    return float(f"{min(oscillation, push):.3g}")


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
    stage = {
        "name": "calibrated",
        "insert": ["grain"],
        "steps": calibration.steps,
        **stage_dynamics(fit.spec, calibration.max_overlap),
        "freezing": {"lock_step": 10},
        "stochastic_forces": {"step_size": 0.05},
        # the few spheres still overlapping too much at the step limit are deleted, so the model packing is converged
        # (§5.1); matching refuses a packing that loses more than 5 % this way (match_statistics)
        "delete_unconverged": ["grain"],
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
