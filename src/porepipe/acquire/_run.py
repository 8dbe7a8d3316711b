"""File in, compute, file out for the acquire stage: image -> statistics, binary, calibrated scene, model, comparison."""

from __future__ import annotations

import sys
from pathlib import Path

import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import read_table, result_hash
from porepipe.acquire._api import acquire, write_binary
from porepipe.acquire._calibrate import calibrated_scene, write_scene_yaml
from porepipe.acquire._compare import write_comparison
from porepipe.acquire._matching import match_statistics
from porepipe.acquire._model import run_model
from porepipe.acquire._settings import SCENE_KEYS, SettingNames, Settings

#: porosity above which acquire-calibrate warns that the grey phases may be swapped (a rock of porosity 0.2 whose
#: pores are bright reads as 0.8; the project's own loose-packing validation case has 0.54)
_LOOSE_POROSITY = 0.6


def _section(scene) -> Settings:
    return scene.acquire if scene is not None and scene.acquire is not None else Settings()


def run(
    settings: Settings,
    out,
    *,
    scene=None,
    image_path=None,
    base_dir=".",
    threads: int | None = None,
    names: SettingNames = SCENE_KEYS,
) -> dict[str | None, xr.Dataset]:
    """Read, prepare, segment and measure an image; write ``statistics.h5``.

    Parameters
    ----------
    settings : Settings
        The ``acquire`` settings (scene section with command-line options laid over it).
    out : path-like
        ``statistics.h5``.
    scene : Scene, optional
        The image scene (its name, ``lpt`` and ``permeability`` sections).
    image_path : path-like, optional
        The image, as given (relative to the working directory); default: ``settings.image``.
    base_dir : path-like
        Directory a relative ``settings.image`` refers to (the scene file's).
    threads : int, optional
        Numba threads (default: all).
    names : SettingNames
        How messages name the settings (default: the scene keys; the command line: its options).

    Returns
    -------
    dict of str or None -> xarray.Dataset
        The tables by group (None = root).
    """
    set_threads(threads)
    return acquire(
        settings,
        out,
        base_dir=base_dir,
        image_path=image_path,
        scene_name=scene.name if scene else "",
        scene_hash=result_hash("acquire", settings=settings, image=str(image_path or "")),
        lpt_settings=getattr(scene, "lpt", None),
        permeability_settings=getattr(scene, "permeability", None),
        names=names,
    )


def run_binary(statistics_path, out, a_um: float | None = None) -> float:
    """Write ``binary_a{a}.h5`` of an acquired image; returns its porosity (see :func:`acquire.write_binary`)."""
    return write_binary(statistics_path, out, a_um)


def run_calibrate(statistics_path, out, *, scene=None, name: str | None = None) -> Path:
    """Write a model scene YAML calibrated to the image statistics (packing + decoration; porosity and S_V matched).

    Parameters
    ----------
    statistics_path : path-like
        ``statistics.h5`` of the image.
    out : path-like
        The scene YAML to write.
    scene : Scene, optional
        The image scene (its ``acquire.calibration`` settings and seed).
    name : str, optional
        Name of the model scene (default ``<scene>-model``).

    Returns
    -------
    pathlib.Path
    """
    settings = _section(scene)
    name = name or (f"{scene.name}-model" if scene else "calibrated-model")
    stats = read_table(statistics_path)
    if int(stats.attrs.get("is_2d", 0)):  # before: "the statistics have no grains (image all pore, or ...)"
        raise PorepipeError(
            f"{statistics_path} comes from a 2-D section; the calibration needs grains, which are measured on a "
            "3-D image or a stack of serial sections"
        )
    if float(stats.porosity) > _LOOSE_POROSITY:
        print(
            f"porepipe acquire-calibrate: warning: {statistics_path} has porosity {float(stats.porosity):.3g}, "
            "looser than granular media usually are: if the pores are the bright phase, the grains calibrated "
            "here are pores; set acquire.segmentation.invert: true and rerun acquire",
            file=sys.stderr,
        )
    model = calibrated_scene(stats, settings.calibration, name=name, seed=scene.seed if scene else 0)
    match_statistics(  # records its rounds and what was matched in model["_calibration"]
        model,
        model["_calibration"]["target_porosity"],
        model["_calibration"]["S_V_per_mm"],
        settings.calibration.porosity_iterations,
        Path(out).parent,
        max_overlap_limit=settings.calibration.overlap_limit,
        periodic=settings.periodic,
    )
    return write_scene_yaml(model, out)


def run_calibrated_model(
    model_scene, model_path, out, *, scene=None, threads: int | None = None
) -> dict[str | None, xr.Dataset]:
    """Pack, voxelise and measure a calibrated model scene; write ``model_statistics.h5``.

    Parameters
    ----------
    model_scene : Scene
        The calibrated scene.
    model_path : path-like
        Its file (relative paths refer to its directory).
    out : path-like
        ``model_statistics.h5``.
    scene : Scene, optional
        The image scene (which statistics to measure).
    threads : int, optional
        Numba threads (default: all).

    Returns
    -------
    dict of str or None -> xarray.Dataset
    """
    set_threads(threads)
    return run_model(
        model_scene,
        _section(scene),
        out,
        base_dir=Path(model_path).parent,
        lpt_settings=getattr(scene, "lpt", None),
        permeability_settings=getattr(scene, "permeability", None),
    )


def run_compare(experiment_path, model_path, out) -> xr.Dataset:
    """Write ``comparison.h5`` (+ PNG and Markdown beside it): model against experiment."""
    return write_comparison(experiment_path, model_path, out)
