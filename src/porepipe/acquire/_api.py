"""Public API of the acquisition stage: image -> prepared grey volume -> phases -> statistics Dataset(s) -> files."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_attrs, read_volume
from porepipe.acquire import _stats
from porepipe.acquire._io import Image, read_image, require_spacing
from porepipe.acquire._prepare import Phases, denoise, load_region, resample_cubic, segment_phases
from porepipe.acquire._settings import SCENE_KEYS, SettingNames, Settings

#: names of the volumes in statistics.h5
PHASES_VOLUME = "phases"


@dataclasses.dataclass
class Prepared:
    """A cropped, filtered, cubic-voxel grey volume ready for segmentation."""

    grey: np.ndarray
    voxel_um: float
    source: str
    is_2d: bool
    spacing_um: tuple[float, float, float]


def image_file(settings: Settings, base_dir: Path | str = ".", image_path=None) -> Path:
    """The image to read: ``image_path`` as given (the command line's, relative to the working directory), else
    ``settings.image`` relative to ``base_dir`` (the scene file's folder).
    """
    # before: joined to base_dir too, so IMAGE with --scene was looked for beside the scene
    if image_path is not None:
        return Path(image_path)
    if settings.image is None:
        raise PorepipeError("acquire.image: no image given (set acquire.image in the scene or pass IMAGE)")
    path = Path(settings.image)
    return path if path.is_absolute() else Path(base_dir) / path


def open_image(
    settings: Settings, base_dir: Path | str = ".", image_path=None, names: SettingNames = SCENE_KEYS
) -> Image:
    """Open the image (``image_path`` as given, else ``settings.image`` relative to ``base_dir``).

    Parameters
    ----------
    settings : Settings
        The ``acquire`` settings (format, RAW layout, dataset, voxel size).
    base_dir : path-like
        The scene file's folder, for a relative ``settings.image``.
    image_path : path-like, optional
        The command line's IMAGE, relative to the working directory.
    names : SettingNames
        How messages name the settings: scene keys (the default) or ``porepipe acquire``'s options.

    Returns
    -------
    Image
        The opened image (read lazily where its format allows).
    """
    path = image_file(settings, base_dir, image_path)
    return read_image(
        path,
        settings.format,
        raw=settings.raw,
        dataset=settings.dataset,
        voxel_um=settings.voxel_um,
        section_um=settings.section_um,
        names=names,
    )


def prepare(image: Image, settings: Settings, names: SettingNames = SCENE_KEYS) -> Prepared:
    """Crop, check finiteness, resample to cubic voxels (if asked and anisotropic) and denoise.

    Parameters
    ----------
    image : Image
        From :func:`open_image`.
    settings : Settings
        The ``acquire`` settings.
    names : SettingNames
        How messages name the settings: scene keys (the default) or ``porepipe acquire``'s options.

    Returns
    -------
    Prepared
        The grey volume or section ready to segment, with its voxel size.
    """
    spacing = require_spacing(image)
    grey = load_region(image, settings.crop, names)
    if image.is_2d:
        if not np.isclose(spacing[0], spacing[1], rtol=1e-9):
            raise PorepipeError(f"section {image.source}: pixels {spacing[:2]} µm are not square")
        voxel = spacing[0]
    elif not np.allclose(spacing, spacing[0], rtol=1e-9):
        if not settings.resample_cubic:
            raise PorepipeError(
                f"image {image.source} has anisotropic voxels {spacing} µm; set "
                "acquire.resample_cubic: true (the stages need cubic voxels)"
            )
        grey, voxel = resample_cubic(grey, spacing)
    else:
        voxel = spacing[0]
    grey = denoise(grey, settings.denoise, settings.denoise_size, names)
    return Prepared(grey, float(voxel), image.source, image.is_2d, spacing)


def image_statistics(
    phases: Phases,
    voxel_um: float,
    settings: Settings,
    *,
    is_2d: bool = False,
    lpt_settings=None,
    permeability_settings=None,
) -> dict[str | None, xr.Dataset]:
    """Every statistic of a segmented image, as Datasets keyed by HDF5 group (None = root).

    Root: phase fractions, porosity, thresholds and histogram, S_V/K_V/T_V (3-D), percolation (3-D), two-point
    correlation and chord lengths per axis, grains (3-D). Groups ``lpt`` and ``permeability`` when asked for.
    """
    stats = settings.statistics
    timing: dict[str, float] = {}

    def timed(name, fn, *args):
        t0 = time.perf_counter()
        result = fn(*args)
        timing[name] = round(time.perf_counter() - t0, 3)
        return result

    pore = phases.pore()
    fractions = _stats.volume_fractions(phases.labels, phases.names)
    porosity = float(pore.mean(dtype=np.float64))
    shape = pore.shape
    max_lag = int(round(stats.max_lag_um / voxel_um)) if stats.max_lag_um else max(1, max(shape) // 4)
    # lags beyond the longest axis hold no pair (NaN); max_lag_um = 1e300 allocated a 5e299-column table before
    max_lag = min(max_lag, max(shape) - 1)
    parts = [
        xr.Dataset(
            {
                "volume_fraction": fractions,
                "porosity": ((), porosity, {"units": "1", "long_name": "volume fraction of the pore phases"}),
                "threshold": (
                    "threshold_index",
                    phases.thresholds,
                    {"long_name": "class k: t_{k-1} < g <= t_k"},
                ),
                "grey_count": ("grey_bin", phases.histogram.counts, {"long_name": "grey histogram"}),
                "grey_value": ("grey_bin", phases.histogram.centres),
            }
        ),
        xr.Dataset({"two_point": timed("two_point", _stats.two_point_correlation, pore, voxel_um, max_lag)}),
        timed("chords", _stats.chord_lengths, pore, voxel_um),
    ]
    skipped = []
    if is_2d:
        skipped = ["minkowski", "percolation", "grains", "lpt", "permeability"]
    else:
        mk = timed("minkowski", _stats.minkowski_numbers, pore, voxel_um, settings.periodic)
        parts.append(xr.Dataset({k: ((), v) for k, v in mk.items()}))
        parts.append(timed("percolation", _stats.percolation, pore))
        if stats.grains:
            window, min_distance = _grain_window(shape, stats, voxel_um)
            grains = timed(
                "grains",
                _stats.grain_statistics,
                _grain_mask(phases, stats.grain_phase)[window],
                voxel_um,
                min_distance,
                settings.periodic and window == tuple(slice(0, n) for n in shape),
            )
            grains.attrs["grain_window_voxels"] = np.asarray([w.stop - w.start for w in window], np.int64)
            grains["grain_window_origin_um"] = ("xyz", np.asarray([w.start for w in window]) * voxel_um)
            parts.append(grains)
    root = xr.merge(parts, combine_attrs="drop_conflicts")
    root.attrs.update(
        voxel_um=voxel_um,
        shape=np.asarray(shape, np.int64),
        method=phases.method.value,
        phases=list(phases.names),
        pore_phases=[phases.names[i] for i in phases.pore_index],
        is_2d=int(is_2d),
        skipped_2d=",".join(skipped),
        timing_s=json.dumps(timing),
    )
    out: dict[str | None, xr.Dataset] = {None: root}
    if not is_2d and stats.lpt:
        from porepipe.lpt import local_porosity_analysis

        out["lpt"] = local_porosity_analysis(
            pore,
            voxel_um=voxel_um,
            periodic=(settings.periodic,) * 3,
            settings=lpt_settings,
            skip_too_large=True,
        )
    if not is_2d and stats.permeability:
        from porepipe.lbm import permeability

        out["permeability"] = permeability(
            pore, settings=permeability_settings, voxel_um=voxel_um, progress=False
        ).to_dataset()
    return out


def central_window(shape, max_voxels: int) -> tuple[slice, slice, slice]:
    """Central sub-box of ``shape`` with at most ``max_voxels`` voxels (same aspect ratio; 0 = the whole box)."""
    total = int(np.prod(shape, dtype=np.int64))
    if max_voxels <= 0 or total <= max_voxels:
        return tuple(slice(0, int(n)) for n in shape)
    scale = (max_voxels / total) ** (1.0 / 3.0)
    size = [max(1, min(int(n), int(n * scale))) for n in shape]
    return tuple(slice((int(n) - s) // 2, (int(n) - s) // 2 + s) for n, s in zip(shape, size))


def _grain_mask(phases: Phases, grain_phase: str | None) -> np.ndarray:
    if grain_phase is None:
        return phases.pore() == 0
    if grain_phase not in phases.names:
        raise PorepipeError(f"acquire.statistics.grain_phase = {grain_phase!r} is not one of {phases.names}")
    return phases.labels == phases.names.index(grain_phase)


def _min_distance(min_distance_um: float | None, voxel_um: float) -> int:
    return 2 if min_distance_um is None else max(1, int(round(min_distance_um / voxel_um)))


def _grain_window(shape, stats, voxel_um: float) -> tuple[tuple[slice, slice, slice], int]:
    """The grain statistics' central window and marker distance (voxels); refuses a window without two voxels per
    axis, and a distance beyond the window (the watershed's peak search would allocate a (2 d + 1)³ footprint).
    """
    window = central_window(shape, stats.grain_max_voxels)
    edges = [w.stop - w.start for w in window]
    if min(edges) < 2:
        raise PorepipeError(
            f"acquire.statistics.grain_max_voxels = {stats.grain_max_voxels} leaves a grain window of "
            f"{'x'.join(map(str, edges))} voxels of the {'x'.join(map(str, shape))} image; give 0 (the whole "
            "image) or a larger value"
        )
    min_distance = _min_distance(stats.grain_min_distance_um, voxel_um)
    if min_distance > max(edges):
        raise PorepipeError(
            f"acquire.statistics.grain_min_distance_um = {stats.grain_min_distance_um} µm is {min_distance:.3g} "
            f"voxels, more than the grain window of {'x'.join(map(str, edges))} voxels; give at most "
            f"{max(edges) * voxel_um:g} µm"
        )
    return window, min_distance


def acquire(
    settings: Settings,
    out,
    *,
    base_dir: Path | str = ".",
    image_path=None,
    scene_name: str = "",
    scene_hash: str = "",
    lpt_settings=None,
    permeability_settings=None,
    names: SettingNames = SCENE_KEYS,
) -> dict[str | None, xr.Dataset]:
    """Read, prepare, segment and measure an image; write ``statistics.h5`` (with the phase volume) to ``out``.

    Parameters
    ----------
    settings : Settings
        The ``acquire`` settings.
    out : path-like
        The statistics file to write.
    base_dir : path-like
        The scene file's folder, for a relative ``settings.image``.
    image_path : path-like, optional
        The command line's IMAGE, relative to the working directory.
    scene_name, scene_hash : str
        Recorded in the result's attributes.
    lpt_settings, permeability_settings : optional
        The scene's ``lpt`` and ``permeability`` sections, for the measurements that use them.
    names : SettingNames
        How messages name the settings: scene keys (the default) or ``porepipe acquire``'s options.

    Returns
    -------
    dict
        The result's tables by group (None: the root).
    """
    image = open_image(settings, base_dir, image_path, names)
    with ResultWriter(out, stage="acquire", scene=scene_name, scene_hash=scene_hash) as w:
        t0 = time.perf_counter()
        prep = prepare(image, settings, names)
        t1 = time.perf_counter()
        phases = segment_phases(prep.grey, settings.segmentation, names)
        t2 = time.perf_counter()
        tables = image_statistics(
            phases,
            prep.voxel_um,
            settings,
            is_2d=prep.is_2d,
            lpt_settings=lpt_settings,
            permeability_settings=permeability_settings,
        )
        w.write_volume(
            PHASES_VOLUME,
            phases.labels,
            voxel_um=prep.voxel_um,
            periodic=(settings.periodic,) * 3,
            attrs={
                "phases": ",".join(phases.names),
                "pore_index": np.asarray(phases.pore_index),
                "thresholds": phases.thresholds,
                "method": phases.method.value,
            },
        )
        for group, ds in tables.items():
            w.write_table(ds, group)
        w.attrs.update(
            source=prep.source,
            voxel_um=prep.voxel_um,
            spacing_um=np.asarray(prep.spacing_um),
            porosity=float(tables[None].porosity),
            is_2d=int(prep.is_2d),
            timing_read_prepare_s=t1 - t0,
            timing_segment_s=t2 - t1,
        )
    return tables


def coarsen_pore(pore: np.ndarray, factor: int) -> np.ndarray:
    """Pore indicator at ``factor`` times the voxel edge: a coarse voxel is pore if less than half of its
    ``factor``³ fine voxels are matrix (the image analogue of the segment stage's trivial threshold, pore if
    g <= 107 of 216, i.e. less than half matrix, §4.7.2).
    Trailing fine voxels that do not fill a whole coarse voxel are dropped.
    """
    n = [s // factor for s in pore.shape]
    if min(n) < 1:
        raise PorepipeError(f"coarsening by {factor:.3g} leaves no voxel of the image of shape {pore.shape}")
    view = pore[: n[0] * factor, : n[1] * factor, : n[2] * factor]
    counts = view.reshape(n[0], factor, n[1], factor, n[2], factor).sum(axis=(1, 3, 5), dtype=np.int64)
    return (2 * counts > factor**3).astype(np.uint8)


def _factor(a_um: float, voxel: float, source: str) -> int:
    ratio = a_um / voxel
    factor = int(round(ratio)) if np.isfinite(ratio) else 0  # NaN or inf: no whole multiple (int() raised)
    if factor < 1 or not np.isclose(a_um, factor * voxel, rtol=1e-6):
        raise PorepipeError(
            f"resolution a = {a_um} µm requested, but the image {source} has voxels of {voxel} µm; "
            f"allowed: whole multiples of {voxel:g} µm (e.g. --a {2 * voxel:g}, or the scene's resolutions_um: "
            f"[{voxel:g}, {2 * voxel:g}])"
        )
    return factor


def write_binary(statistics_path, out, a_um: float | None = None) -> float:
    """Write ``binary_a{a}.h5`` (volume ``pore``) from the phase volume of ``statistics.h5``; returns its porosity.

    ``a_um`` is the image's voxel size (the binary is the image itself) or a whole multiple of it (block rule of
    :func:`coarsen_pore`, for resolution sweeps of an image).
    """
    attrs = read_attrs(statistics_path)
    if int(attrs.get("is_2d", 0)):
        raise PorepipeError(
            f"{statistics_path} comes from a 2-D section; binary volumes (minkowski, lpt, "
            "permeability) need a 3-D image or a stack of serial sections"
        )
    labels, vattrs = read_volume(statistics_path, PHASES_VOLUME)
    voxel = float(vattrs["voxel_um"])
    factor = 1 if a_um is None else _factor(float(a_um), voxel, str(attrs.get("source")))
    lut = np.zeros(len(str(vattrs["phases"]).split(",")), np.uint8)
    lut[np.atleast_1d(vattrs["pore_index"]).astype(np.int64)] = 1
    if factor > min(labels.shape):  # before: coarsen_pore's message printed the factor in full (300 digits)
        raise PorepipeError(
            f"resolution a = {a_um:g} µm is {factor:.3g} voxels of {voxel:g} µm, more than the image's "
            f"shortest edge of {min(labels.shape)} voxels; allowed: whole multiples of {voxel:g} µm up to "
            f"{min(labels.shape) * voxel:g} µm"
        )
    pore = lut[labels]
    del labels
    if factor > 1:
        pore = coarsen_pore(pore, factor)
    thresholds = np.atleast_1d(np.asarray(vattrs["thresholds"], dtype=np.float64))
    porosity = float(pore.mean(dtype=np.float64))
    with ResultWriter(
        out, stage="acquire", scene=attrs.get("scene", ""), scene_hash=attrs.get("scene_hash", "")
    ) as w:
        w.write_volume(
            "pore",
            pore,
            voxel_um=voxel * factor,
            origin_um=vattrs.get("origin_um", (0.0, 0.0, 0.0)),
            periodic=vattrs.get("periodic", (0, 0, 0)),
            attrs={
                "threshold": float(thresholds[0]),
                "method": str(vattrs["method"]),
                "coarsening": factor,
                "meaning": "1 = pore, 0 = matrix (segmented image; coarse voxel pore if less than half "
                "of its fine voxels are matrix)",
            },
        )
        w.write_table(xr.Dataset({"porosity": ((), porosity)}, attrs={"threshold": float(thresholds[0])}))
        w.attrs.update(
            threshold=float(thresholds[0]),
            method=str(vattrs["method"]),
            voxel_um=voxel * factor,
            porosity=porosity,
            source=str(attrs.get("source", "")),
            coarsening=factor,
        )
    return porosity
