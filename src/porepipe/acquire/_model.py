"""Run a calibrated model scene in-process (pack -> voxelise -> Otsu -> the same statistics as the image).

The model is measured by exactly the code that measured the image (:func:`image_statistics`), so the comparison is
like for like. A ``decoration`` section of the scene replaces every sphere by its polyhedral grain (decorate stage).
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, hash_of
from porepipe.acquire._api import PHASES_VOLUME, image_statistics
from porepipe.acquire._prepare import GreyHistogram, Phases
from porepipe.acquire._settings import Method, Settings


def model_phases(grey: np.ndarray) -> Phases:
    """Pore/matrix phases of a model grey volume (0..216 = matrix sample points) by the segment stage's Otsu rule."""
    from porepipe.scene import SegmentationMethod
    from porepipe.segment import choose_threshold
    from porepipe.voxelize import grey_histogram

    hist = grey_histogram(grey)
    decision = choose_threshold(hist, SegmentationMethod.otsu)
    labels = (grey > decision.value).astype(np.uint8)  # 0 = pore (g <= g_th), 1 = matrix
    return Phases(
        labels,
        np.array([float(decision.value)]),
        GreyHistogram(hist, np.arange(hist.size, dtype=float)),
        ["pore", "matrix"],
        [0],
        Method.otsu,
    )


def model_grey(scene, base_dir: Path | str = "."):
    """Pack, decorate (if the scene says so) and voxelise a model scene at its finest resolution.

    Returns (grey, packing, voxel_um).
    """
    from porepipe.packing import pack_spheres
    from porepipe.voxelize import voxelize

    if getattr(scene, "packing", None) is None or scene.domain is None:
        raise PorepipeError(f"scene {scene.name!r} has no packing/domain section to run as a model")
    a = float(scene.resolutions_um[-1])
    box = np.asarray(scene.domain.size_um, dtype=np.float64)
    per = bool(scene.domain.periodic)
    packing = pack_spheres(scene.packing, box, per, seed=scene.seed, base_dir=base_dir)
    if getattr(scene, "decoration", None) is not None:
        from porepipe.decorate import decorate, voxelize_grains

        deco = decorate(
            packing.centres_um,
            packing.radii_um,
            scene.decoration,
            seed=scene.seed,
            box_um=box,
            periodic=per,
            base_dir=base_dir,
        )
        return voxelize_grains(deco, box, a, per), packing, a
    return voxelize(packing.centres_um, packing.radii_um, box, a, per), packing, a


#: a pack-and-measure round counts as packed when at least this fraction of the inserted spheres converged (the
#: stage deletes the others); below it the count is past what sigma_max lets converge, and sigma_max is raised
MIN_KEPT = 0.95
#: step by which porosity matching raises sigma_max of a packing that does not converge
_OVERLAP_STEP = 0.1


def _measure(scene_dict: dict, base_dir) -> tuple[float, int]:
    """Pack, voxelise and segment the scene: (porosity, spheres kept)."""
    from porepipe.scene import parse_scene

    scene = parse_scene({k: v for k, v in scene_dict.items() if not k.startswith("_")}, base_dir)
    grey, packing, _ = model_grey(scene, base_dir)
    return float(model_phases(grey).pore().mean(dtype=np.float64)), int(packing.radii_um.size)


def _raise_overlap(scene_dict: dict, limit: float) -> bool:
    """Raise sigma_max of the grain type by one step (at most to ``limit``), with the stage's k, dt and damping."""
    from porepipe.acquire._calibrate import stage_dynamics

    ptype, stage = scene_dict["packing"]["types"][0], scene_dict["packing"]["stages"][0]
    if ptype["max_overlap"] >= limit:
        return False
    ptype["max_overlap"] = round(min(limit, ptype["max_overlap"] + _OVERLAP_STEP), 6)
    stage.update(stage_dynamics(ptype["radius_um"], ptype["max_overlap"]))
    return True


def match_porosity(
    scene_dict: dict,
    target: float,
    iterations: int,
    base_dir: Path | str = ".",
    *,
    max_overlap_limit: float = 0.4,
) -> list[dict]:
    """Adjust a calibrated scene (in place) until its packing converges and its porosity matches ``target``.

    Each round packs, voxelises and segments the model exactly as ``acquire-model`` will (same seed, so the same
    packing). A round that keeps fewer than 95 % of its spheres converged (``MIN_KEPT``; the stage deletes the rest)
    has more spheres than sigma_max lets converge: sigma_max is raised by 0.1 (at most to ``max_overlap_limit``),
    with the stage's k, dt and damping (``stage_dynamics``). Otherwise the count is set to n (1 - φ_t) / (1 - φ),
    the update that is exact when the solid fraction grows in proportion to the sphere count, as in a packing of
    bounded overlap (the Boolean-model update n ln φ_t / ln φ assumed free overlap, and drove dense images to counts
    that cannot converge). The rounds stop when |φ - φ_t| is within the realisation scatter ``porosity_tolerance``.
    The scene left is the measured one closest to the target among those that converged (the last one if none did).

    Parameters
    ----------
    scene_dict : dict
        The calibrated scene (:func:`calibrated_scene`), changed in place.
    target : float
        The image's porosity.
    iterations : int
        Largest number of pack-and-measure rounds.
    base_dir : path-like
        Directory the scene's relative paths refer to.
    max_overlap_limit : float
        Largest sigma_max to raise to.

    Returns
    -------
    list of dict
        One record per round: count, max_overlap, k, spheres_kept, porosity.
    """
    from porepipe.acquire._calibrate import porosity_tolerance

    history: list[dict] = []
    if not 0.0 < target < 1.0:
        return history
    best = None
    packing = scene_dict["packing"]
    for _ in range(iterations):
        ptype = packing["types"][0]
        phi, kept = _measure(scene_dict, base_dir)
        packed = kept >= MIN_KEPT * ptype["count"]
        tol = porosity_tolerance(ptype["radius_um"], kept, scene_dict["domain"]["size_um"])
        history.append(
            {
                "count": int(ptype["count"]),
                "max_overlap": float(ptype["max_overlap"]),
                "k": float(packing["stages"][0]["k"]["grain"]),
                "spheres_kept": kept,
                "porosity": phi,
            }
        )
        if packed and (best is None or abs(phi - target) < abs(best[0] - target)):
            best = (phi, kept, tol, copy.deepcopy(packing))
        if packed and abs(phi - target) <= tol:
            break
        if not packed:
            if not _raise_overlap(scene_dict, max_overlap_limit):
                ptype["count"] = max(1, kept)  # at the limit: no more spheres than did converge
        elif phi < 1.0:
            ptype["count"] = max(1, int(round(ptype["count"] * (1.0 - target) / (1.0 - phi))))
        else:
            ptype["count"] *= 2
    if best is not None:
        scene_dict["packing"] = best[3]
    record = scene_dict.setdefault("_calibration", {})
    record["porosity_matching"] = history
    record["matched"] = _matched(target, best, history, scene_dict)
    return history


def _matched(target: float, best, history: list[dict], scene_dict: dict) -> dict:
    """What the written scene was matched to, and how well (the scene's record)."""
    ptype = scene_dict["packing"]["types"][0]
    out = {
        "porosity_target": float(target),
        "sphere_count": int(ptype["count"]),
        "max_overlap": float(ptype["max_overlap"]),
        "k": float(scene_dict["packing"]["stages"][0]["k"]["grain"]),
    }
    if best is None:
        out["converged"] = False
        out["note"] = (
            "no round converged (or none ran): the scene is unchecked; raise porosity_iterations or max_overlap_limit"
            if history
            else "porosity_iterations = 0: sphere count from the grain density, porosity not matched"
        )
        return out
    phi, kept, tol, _ = best
    out.update(
        converged=True,
        porosity_model=phi,
        porosity_tolerance=tol,
        porosity_within_tolerance=bool(abs(phi - target) <= tol),
        spheres_kept=kept,
        note=f"the model packs to convergence (>= {MIN_KEPT:.0%} of the spheres converged, the rest deleted) and "
        "its porosity, measured as acquire-model measures it, is matched to the image's by the sphere count"
        + ("" if out["max_overlap"] == history[0]["max_overlap"] else " and a raised max_overlap"),
    )
    return out


def run_model(
    scene,
    acquire_settings: Settings,
    out,
    *,
    base_dir: Path | str = ".",
    lpt_settings=None,
    permeability_settings=None,
) -> dict[str | None, xr.Dataset]:
    """Pack, voxelise and measure a (calibrated) model scene; write ``model_statistics.h5``.

    Parameters
    ----------
    scene : Scene
        A validated model scene with a ``packing`` section and ``spheres: {pack: true}``.
    acquire_settings : Settings
        The image's ``acquire`` section: the same statistics are measured on the model.
    out : path
        Output file.
    """
    # measured like the image (same boundary treatment), so that model and experiment are compared like for like
    settings = acquire_settings
    with ResultWriter(
        out, stage="acquire-model", scene=scene.name, scene_hash=hash_of(scene.model_dump(mode="json"))
    ) as w:
        grey, packing, a = model_grey(scene, base_dir)
        phases = model_phases(grey)
        del grey
        tables = image_statistics(
            phases, a, settings, lpt_settings=lpt_settings, permeability_settings=permeability_settings
        )
        w.write_volume(
            PHASES_VOLUME,
            phases.labels,
            voxel_um=a,
            periodic=(settings.periodic,) * 3,
            attrs={
                "phases": "pore,matrix",
                "pore_index": np.array([0]),
                "thresholds": phases.thresholds,
                "method": "otsu",
            },
        )
        w.write_array("sphere_radii_um", packing.radii_um, dims=("sphere",))
        for group, ds in tables.items():
            w.write_table(ds, group)
        w.attrs.update(
            voxel_um=a,
            porosity=float(tables[None].porosity),
            n_spheres=int(packing.radii_um.size),
            packing_converged=int(packing.all_converged),
            decoration_applied=int(getattr(scene, "decoration", None) is not None),
            is_2d=0,
            source=f"model scene {scene.name}",
        )
    return tables
