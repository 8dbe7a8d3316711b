"""Run a calibrated model scene in-process (pack -> voxelise -> Otsu -> the same statistics as the image).

The model is measured by exactly the code that measured the image (:func:`image_statistics`), so the comparison is
like for like. A ``decoration`` section of the scene replaces every sphere by its polyhedral grain (decorate stage).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.run_control import without_run_control
from porepipe._shared.store import ResultWriter, result_hash
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
    # the hash: the model scene and every setting it is measured with, less run control
    measuring = {"lpt": lpt_settings, "permeability": permeability_settings}
    extra = {name: without_run_control(given) for name, given in measuring.items() if given is not None}
    digest = result_hash("acquire-model", scene_part=without_run_control(scene), settings=settings, **extra)
    with ResultWriter(out, stage="acquire-model", scene=scene.name, scene_hash=digest) as w:
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
