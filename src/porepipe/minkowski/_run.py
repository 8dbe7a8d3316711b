"""File in, compute, file out: ``minkowski_a{a}.h5`` from a binary volume (and optionally its grey volume)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from porepipe._shared.budget import fits
from porepipe._shared.chunked import volume_bytes
from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import ResultWriter, open_volume, read_attrs, result_hash, volume_meta
from porepipe.minkowski._api import (
    configuration_histogram_slabs,
    iter_slabs,
    minkowski_from_histogram,
    threshold_dataset,
    threshold_histograms_slabs,
)
from porepipe.minkowski._chunked import configuration_histogram_chunked, threshold_histograms_chunked
from porepipe.minkowski._settings import Settings

#: table group of the Minkowski functions of the grey threshold in the result file
THRESHOLD_GROUP = "threshold"


def _binary_histogram(path, slab_planes: int, budget_mb: int | None, threads: int):
    """Configuration histogram, volume meta and shape: slab by slab, or box by box when over the budget."""
    with open_volume(path, "pore") as pore:
        meta, shape = volume_meta(pore, path), pore.shape
        if fits(volume_bytes(shape), budget_mb):
            return (*configuration_histogram_slabs(iter_slabs(pore, slab_planes), meta.periodic), meta)
    hist = configuration_histogram_chunked(path, "pore", shape, meta.periodic, budget_mb, threads)
    return hist, shape, meta


def _check_grey_grid(grey_path, binary_path, shape, meta) -> None:
    """Refuse a grey volume on another grid than the binary one (another resolution, shape or periodicity): its
    threshold table would describe another sample than the file's root table.
    """
    with open_volume(grey_path, "grey") as grey:
        gmeta, gshape = volume_meta(grey, grey_path), grey.shape

    def grid(shape_, meta_):
        return (
            f"{'x'.join(map(str, shape_))} voxels of {meta_.voxel_um:g} µm, periodic {list(meta_.periodic)}"
        )

    if (gshape, gmeta.voxel_um, tuple(gmeta.periodic)) != (tuple(shape), meta.voxel_um, tuple(meta.periodic)):
        raise PorepipeError(
            f"grey volume {grey_path} ({grid(gshape, gmeta)}) is not on the grid of binary volume {binary_path} "
            f"({grid(shape, meta)}); give the grey volume it was segmented from"
        )


def _grey_histograms(path, slab_planes: int, budget_mb: int | None, threads: int):
    """Threshold histograms and volume meta of a grey volume: slab by slab, or box by box when over the budget."""
    with open_volume(path, "grey") as grey:
        meta, shape = volume_meta(grey, path), grey.shape
        if fits(volume_bytes(shape), budget_mb):
            return threshold_histograms_slabs(iter_slabs(grey, slab_planes), meta.periodic)[0], meta
    return threshold_histograms_chunked(path, "grey", shape, meta.periodic, budget_mb, threads=threads), meta


def run(
    binary_path,
    out,
    settings: Settings | None = None,
    grey_path=None,
    threads: int | None = None,
    memory_budget_mb: int | None = None,
) -> xr.Dataset:
    """Write ``minkowski_a{a}.h5`` from ``binary_a{a}.h5`` (volume ``pore``), reading it slab by slab.

    Parameters
    ----------
    binary_path : path-like
        Binary volume (1 = pore) with ``voxel_um``, ``origin_um``, ``periodic``.
    out : path-like
        The result file.
    settings : Settings, optional
        The scene's ``minkowski`` section (default: the defaults).
    grey_path : path-like, optional
        Grey volume: the group ``threshold`` then holds the same quantities for every threshold g_th.
    threads : int, optional
        Numba threads (default: all).
    memory_budget_mb : int, optional
        The scene's ``resources.memory_budget_mb``: a volume larger than it is read in boxes of at most that size
        (:mod:`porepipe.minkowski._chunked`; identical histograms).

    Returns
    -------
    xarray.Dataset
        The root table (:func:`porepipe.minkowski.minkowski_from_histogram`): φ, S_V (µm⁻¹), K_V (µm⁻²),
        T_V (µm⁻³), χ of pore and matrix.
    """
    settings = settings or Settings()
    threads = set_threads(threads)
    src = read_attrs(binary_path)
    digest = result_hash(
        "minkowski", settings=settings, inputs=[binary_path] + ([grey_path] if grey_path else [])
    )
    if grey_path:  # before any work
        with open_volume(binary_path, "pore") as pore:
            _check_grey_grid(grey_path, binary_path, pore.shape, volume_meta(pore, binary_path))
    hist, shape, meta = _binary_histogram(binary_path, settings.slab_planes, memory_budget_mb, threads)
    table = minkowski_from_histogram(hist, meta.voxel_um, settings.adjacency, meta.periodic)
    thresholds = None
    if grey_path:  # before the result file: a threshold table out of the float64 range is refused without one
        hists, gmeta = _grey_histograms(grey_path, settings.slab_planes, memory_budget_mb, threads)
        all_pore = np.flatnonzero(hists[:, -1] == hists.sum(axis=1))  # thresholds at/above max(grey)
        last = int(all_pore[0]) if len(all_pore) else len(hists) - 1
        thresholds = threshold_dataset(hists[: last + 1], gmeta.voxel_um, gmeta.periodic, settings.adjacency)
    with ResultWriter(
        out, stage="minkowski", scene=src.get("scene", ""), scene_hash=digest, threads=threads
    ) as w:
        w.write_table(table)
        if thresholds is not None:
            w.write_table(thresholds, group=THRESHOLD_GROUP)
        pore_values = table.sel(phase="pore")
        w.attrs.update(
            voxel_um=meta.voxel_um,
            shape=np.asarray(shape),
            periodic=np.asarray(meta.periodic, dtype=np.int8),
            adjacency=settings.adjacency.value,
            boundary=table.attrs["boundary"],
            **{f"{k}_pore": float(pore_values[k]) for k in ("phi", "S_V", "K_V", "T_V", "chi")},
        )
    return table
