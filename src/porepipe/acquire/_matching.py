"""Matching a calibrated model scene to its image: the sphere count sets the porosity, sigma_max the specific surface.

Each round packs, voxelises, segments and measures the model exactly as ``acquire-model`` will (:mod:`._model`), and
the next round's count and sigma_max follow from the rounds so far (:func:`match_statistics`).
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np

from porepipe._shared.errors import UnstableRunError
from porepipe.acquire._model import model_grey, model_phases
from porepipe.acquire._stats import minkowski_numbers

#: a pack-and-measure round counts as packed when at least this fraction of the inserted spheres converged (the
#: stage deletes the others); below it the count is past what sigma_max lets converge, and sigma_max is raised
MIN_KEPT = 0.95
#: largest change of sigma_max in one round, and the step by which it is raised where a packing does not converge
_OVERLAP_STEP = 0.1
#: d ln S_V / d sigma_max assumed until two rounds at different sigma_max measure it. Measured near matched porosity
#: (exponential radii 40-80 µm, 600 µm box, 6 µm voxels, sigma_max 0.2 -> 0.4): -0.97 with 132 spheres (porosity
#: 0.60-0.64) and -1.4 with 167 (0.39-0.44)
_SV_SLOPE_PRIOR = -1.0
#: range a measured slope is kept in: deeper overlaps hide surface, so S_V falls as sigma_max rises, but a secant
#: between two rounds, each off by about the realisation scatter, may say otherwise
_SV_SLOPE_RANGE = (-4.0, -0.25)
#: a secant slope is measured only between rounds whose sigma_max differ by at least this
_MIN_SECANT_STEP = 0.02
#: γ = d ln S_V / d ln(1 - φ) at fixed sigma_max as the count changes: the S_V a round would have at the target
#: porosity is S_V ((1 - φ_t) / (1 - φ))^γ. Measured: 0.51 (sigma_max 0.3, 132 -> 162 spheres, porosity 0.62 -> 0.49)
#: and 0.43 (sigma_max 0.4, 207 -> 226 spheres, 0.35 -> 0.32); 0.51 for a Boolean model of spheres at φ = 0.53
_SV_POROSITY_EXPONENT = 0.5


@dataclasses.dataclass(frozen=True)
class _Targets:
    porosity: float
    s_v_per_mm: float | None  # None: the statistics carry no S_V, and the porosity is matched alone


def _measure(scene_dict: dict, base_dir, periodic: bool) -> tuple[float, float, int]:
    """Pack, voxelise and segment the scene as acquire-model does: (porosity, S_V per mm, spheres kept)."""
    from porepipe.scene import parse_scene

    scene = parse_scene({k: v for k, v in scene_dict.items() if not k.startswith("_")}, base_dir)
    grey, packing, a = model_grey(scene, base_dir)
    pore = model_phases(grey).pore()
    s_v = minkowski_numbers(pore, a, periodic)["S_V_per_mm"]
    return float(pore.mean(dtype=np.float64)), float(s_v), int(packing.radii_um.size)


def _set_overlap(scene_dict: dict, sigma: float) -> None:
    """Set sigma_max of the grain type, with the stage's k, dt and damping for it (``stage_dynamics``)."""
    from porepipe.acquire._calibrate import stage_dynamics

    ptype, stage = scene_dict["packing"]["types"][0], scene_dict["packing"]["stages"][0]
    ptype["max_overlap"] = round(float(sigma), 6)
    stage.update(stage_dynamics(ptype["radius_um"], ptype["max_overlap"]))


def _round(scene_dict: dict, targets: _Targets, base_dir, periodic: bool) -> dict:
    """Pack and measure the scene once; the round's record, with its misfit (in tolerances, the worse quantity)."""
    from porepipe.acquire._calibrate import porosity_tolerance, surface_tolerance

    packing = scene_dict["packing"]
    ptype = packing["types"][0]
    rec = {
        "count": int(ptype["count"]),
        "max_overlap": float(ptype["max_overlap"]),
        "k": float(packing["stages"][0]["k"]["grain"]),
    }
    try:
        phi, s_v, kept = _measure(scene_dict, base_dir, periodic)
    except (
        UnstableRunError
    ) as err:  # spheres packed past what sigma_max holds are pushed apart too hard: not packed
        return {**rec, "spheres_kept": 0, "packed": False, "ran_away": str(err)}
    rec |= {
        "spheres_kept": kept,
        "packed": kept >= MIN_KEPT * ptype["count"],
        "porosity": phi,
        "porosity_tolerance": porosity_tolerance(ptype["radius_um"], kept, scene_dict["domain"]["size_um"]),
        "S_V_per_mm": s_v,
    }
    misfit = abs(phi - targets.porosity) / rec["porosity_tolerance"]
    if targets.s_v_per_mm is not None:
        rec["S_V_tolerance_per_mm"] = surface_tolerance(ptype["radius_um"], kept, targets.s_v_per_mm)
        misfit = max(misfit, abs(s_v - targets.s_v_per_mm) / rec["S_V_tolerance_per_mm"])
    rec["misfit"] = float(misfit)
    return rec


def _surface_misfit(rec: dict, targets: _Targets) -> float:
    """ln(S_V / S_V,t) of a round, with S_V taken to the target porosity: (1 - φ)^γ, γ = ``_SV_POROSITY_EXPONENT``."""
    solid_ratio = (1.0 - targets.porosity) / (1.0 - rec["porosity"])
    return float(np.log(rec["S_V_per_mm"] / targets.s_v_per_mm) + _SV_POROSITY_EXPONENT * np.log(solid_ratio))


def _surface_slope(history: list[dict], targets: _Targets) -> float:
    """The slope d ln S_V / d sigma_max: secant from the last packed round to the latest earlier one at another."""
    packed = [h for h in history if h["packed"] and h["S_V_per_mm"] > 0 and h["porosity"] < 1.0]
    for h in reversed(packed[:-1]):
        step = packed[-1]["max_overlap"] - h["max_overlap"]
        if abs(step) >= _MIN_SECANT_STEP:
            slope = (_surface_misfit(packed[-1], targets) - _surface_misfit(h, targets)) / step
            return float(np.clip(slope, *_SV_SLOPE_RANGE))
    return _SV_SLOPE_PRIOR


def _next_overlap(history: list[dict], targets: _Targets, bounds: tuple[float, float]) -> float:
    """sigma_max for the next round: a secant step of ln S_V (at the target porosity) towards the target.

    The step is at most ``_OVERLAP_STEP``, and sigma_max stays within ``bounds``.
    """
    last = history[-1]
    sigma = last["max_overlap"]
    if targets.s_v_per_mm is None or last["S_V_per_mm"] <= 0 or last["porosity"] >= 1.0:
        return sigma
    step = -_surface_misfit(last, targets) / _surface_slope(history, targets)
    return round(float(np.clip(sigma + np.clip(step, -_OVERLAP_STEP, _OVERLAP_STEP), *bounds)), 3)


def _next_parameters(scene_dict: dict, history: list[dict], targets: _Targets, bounds) -> None:
    """Sphere count and sigma_max of the next round (in place) from the rounds so far."""
    ptype = scene_dict["packing"]["types"][0]
    last = history[-1]
    if not last["packed"]:  # more spheres than sigma_max lets converge
        if ptype["max_overlap"] < bounds[1]:
            _set_overlap(scene_dict, min(bounds[1], ptype["max_overlap"] + _OVERLAP_STEP))
        else:  # at the limit: no more spheres than did converge (of a run that ran away: MIN_KEPT of them)
            ptype["count"] = max(1, last["spheres_kept"] or int(MIN_KEPT * ptype["count"]))
        return
    if last["porosity"] < 1.0:  # solid fraction in proportion to the count (bounded overlap)
        ptype["count"] = max(
            1, int(round(ptype["count"] * (1.0 - targets.porosity) / (1.0 - last["porosity"])))
        )
    else:
        ptype["count"] *= 2
    sigma = _next_overlap(history, targets, bounds)
    if sigma != ptype["max_overlap"]:
        _set_overlap(scene_dict, sigma)


def _rank(rec: dict, targets: _Targets) -> tuple[bool, float]:
    """How a packed round ranks for the scene left (smaller is better): one whose porosity is within its tolerance
    before any other, then by misfit, so that an S_V out of reach never costs the porosity matched by the count.
    """
    return abs(rec["porosity"] - targets.porosity) > rec["porosity_tolerance"], rec["misfit"]


def _repeats(scene_dict: dict, history: list[dict]) -> bool:
    """Whether the scene's sphere count and sigma_max are those of a round already measured."""
    ptype = scene_dict["packing"]["types"][0]
    return any(h["count"] == ptype["count"] and h["max_overlap"] == ptype["max_overlap"] for h in history)


def match_statistics(
    scene_dict: dict,
    porosity: float,
    s_v_per_mm: float | None,
    iterations: int,
    base_dir: Path | str = ".",
    *,
    max_overlap_limit: float = 0.4,
    periodic: bool = False,
) -> list[dict]:
    """Adjust a calibrated scene (in place) until its packing converges and matches the image's porosity and S_V.

    The model has two free parameters that the image fixes: the sphere count, which sets the porosity, and the
    overlap level sigma_max, which at a given porosity sets the specific surface S_V (deeper overlaps hide more
    surface). Each round packs, voxelises, segments and measures the model exactly as ``acquire-model`` will (same
    seed, so the same packing). A round that keeps fewer than 95 % of its spheres converged (``MIN_KEPT``; the
    stage deletes the rest), or whose packing ran away (spheres inserted deeper than sigma_max pushed apart too
    hard, ``UnstableRunError``), has more spheres than sigma_max lets converge: sigma_max is raised by 0.1. Otherwise
    both parameters take a step: the count n (1 - φ_t) / (1 - φ), exact where the solid fraction grows in
    proportion to the count, as in a packing of bounded overlap; sigma_max a secant step of ln S_V (slope from the
    last two rounds at different sigma_max, -1 before; steps of at most 0.1). sigma_max stays between the scene's
    starting value and ``max_overlap_limit``, and the stage's k, dt and damping follow it (``stage_dynamics``).
    The rounds stop when porosity and S_V are within their realisation scatter (``porosity_tolerance``,
    ``surface_tolerance``), or when the next round would repeat one already measured. The scene left is the
    converged round of the smallest misfit (the larger of |φ - φ_t| / tolerance and |S_V - S_V,t| / tolerance) among
    those whose porosity is within its tolerance, where there are any (an S_V out of reach never costs the porosity);
    without S_V (``s_v_per_mm`` None) the porosity is matched alone and sigma_max is raised only where the packing
    does not converge.

    Parameters
    ----------
    scene_dict : dict
        The calibrated scene (:func:`calibrated_scene`), changed in place; its ``_calibration`` record gets
        ``matching_rounds`` (one record per round) and ``matched`` (what the scene left was matched to, how well).
    porosity : float
        The image's porosity.
    s_v_per_mm : float or None
        The image's S_V (per mm); None (or not a positive number): match the porosity alone.
    iterations : int
        Largest number of pack-and-measure rounds.
    base_dir : path-like
        Directory the scene's relative paths refer to.
    max_overlap_limit : float
        Largest sigma_max to move to.
    periodic : bool
        Measure S_V with periodic boundaries (the image's ``acquire.periodic``, as ``acquire-model`` measures it).

    Returns
    -------
    list of dict
        One record per round: count, max_overlap, k, spheres_kept, packed, porosity, S_V_per_mm, tolerances, misfit;
        a round whose packing ran away has ``ran_away`` (the packer's message) in place of the measured values.
    """
    history: list[dict] = []
    if not 0.0 < porosity < 1.0:
        return history
    has_s_v = s_v_per_mm is not None and np.isfinite(s_v_per_mm) and s_v_per_mm > 0
    targets = _Targets(float(porosity), float(s_v_per_mm) if has_s_v else None)
    start = float(scene_dict["packing"]["types"][0]["max_overlap"])
    bounds = (start, max(start, float(max_overlap_limit)))
    best = None
    for _ in range(iterations):
        history.append(_round(scene_dict, targets, base_dir, periodic))
        last = history[-1]
        if last["packed"] and (best is None or _rank(last, targets) < _rank(best[0], targets)):
            best = (last, copy.deepcopy(scene_dict["packing"]))
        if (last["packed"] and last["misfit"] <= 1.0) or len(history) == iterations:
            break
        _next_parameters(scene_dict, history, targets, bounds)
        if _repeats(scene_dict, history):  # same seed and parameters: the same packing, nothing new to learn
            break
    if best is not None:
        scene_dict["packing"] = best[1]
    record = scene_dict.setdefault("_calibration", {})
    record["matching_rounds"] = history
    record["matched"] = _matched(targets, best, history, scene_dict)
    if best is not None and targets.s_v_per_mm is not None and not record["matched"]["S_V_within_tolerance"]:
        record["matched"]["note"] += _surface_advice(best[0], targets, bounds, len(history) == iterations)
    return history


def _matched(targets: _Targets, best, history: list[dict], scene_dict: dict) -> dict:
    """What the written scene was matched to, and how well (the scene's record)."""
    ptype = scene_dict["packing"]["types"][0]
    out = {
        "porosity_target": targets.porosity,
        "S_V_target_per_mm": targets.s_v_per_mm,
        "rounds": len(history),
        "sphere_count": int(ptype["count"]),
        "max_overlap": float(ptype["max_overlap"]),
        "k": float(scene_dict["packing"]["stages"][0]["k"]["grain"]),
    }
    if best is None:
        out["converged"] = False
        out["note"] = (
            "no round converged (or none ran): the scene is unchecked; raise porosity_iterations or max_overlap_limit"
            if history
            else "porosity_iterations = 0: sphere count from the grain density, porosity and S_V not matched"
        )
        return out
    rec = best[0]
    out.update(
        converged=True,
        spheres_kept=rec["spheres_kept"],
        porosity_model=rec["porosity"],
        porosity_tolerance=rec["porosity_tolerance"],
        porosity_within_tolerance=bool(abs(rec["porosity"] - targets.porosity) <= rec["porosity_tolerance"]),
        S_V_model_per_mm=rec["S_V_per_mm"],
    )
    if targets.s_v_per_mm is None:
        out["note"] = (
            "the statistics carry no S_V_per_mm: the porosity is matched alone, by the sphere count (and "
            "max_overlap raised where the packing did not converge)"
        )
        return out
    out["S_V_tolerance_per_mm"] = rec["S_V_tolerance_per_mm"]
    out["S_V_within_tolerance"] = bool(
        abs(rec["S_V_per_mm"] - targets.s_v_per_mm) <= rec["S_V_tolerance_per_mm"]
    )
    out["note"] = (
        f"the model packs to convergence (>= {MIN_KEPT:.0%} of the spheres converged, the rest deleted); its porosity "
        "and S_V, measured as acquire-model measures them, are matched to the image's by the sphere count and "
        "max_overlap (tolerances: the realisation scatter of a box of this many spheres)"
    )
    return out


def _surface_advice(rec: dict, targets: _Targets, bounds: tuple[float, float], rounds_ran_out: bool) -> str:
    """Why the S_V of the round kept missed its tolerance, and the setting that can help: the bound of sigma_max it
    pressed against (a lower max_overlap exposes more surface, a higher max_overlap_limit hides more), else the rounds.
    """
    sigma, below = rec["max_overlap"], rec["S_V_per_mm"] < targets.s_v_per_mm
    text = (
        f"; S_V not within its tolerance (model {rec['S_V_per_mm']:.4g}, image {targets.s_v_per_mm:.4g} /mm) "
    )
    if below and sigma <= bounds[0]:
        return text + (
            f"at the smallest max_overlap matching uses ({bounds[0]:g}): lower acquire.calibration.max_overlap "
            "(shallower overlaps expose more surface)"
        )
    if not below and sigma >= bounds[1] and bounds[1] < 1.0:
        return text + (
            f"at the largest max_overlap matching may use ({bounds[1]:g}): raise "
            "acquire.calibration.max_overlap_limit (deeper overlaps hide more surface)"
        )
    if rounds_ran_out:
        return text + "when the rounds ran out: raise acquire.calibration.porosity_iterations"
    return text + "and no further round would differ: converged packings of this radius law do not reach it"
