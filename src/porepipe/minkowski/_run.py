"""File in, compute, file out: ``minkowski_a{a}.h5`` from a binary volume (and optionally its grey volume)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import ResultWriter, open_volume, read_attrs, result_hash, volume_meta
from porepipe.minkowski._api import (
    configuration_histogram_slabs,
    iter_slabs,
    minkowski_from_histogram,
    threshold_dataset,
    threshold_histograms_slabs,
)
from porepipe.minkowski._settings import Settings

#: table group of the Minkowski functions of the grey threshold in the result file
THRESHOLD_GROUP = "threshold"


def run(
    binary_path, out, settings: Settings | None = None, grey_path=None, threads: int | None = None
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
    with open_volume(binary_path, "pore") as pore:
        meta = volume_meta(pore, binary_path)
        hist, shape = configuration_histogram_slabs(iter_slabs(pore, settings.slab_planes), meta.periodic)
    table = minkowski_from_histogram(hist, meta.voxel_um, settings.adjacency, meta.periodic)
    with ResultWriter(
        out, stage="minkowski", scene=src.get("scene", ""), scene_hash=digest, threads=threads
    ) as w:
        w.write_table(table)
        if grey_path:
            with open_volume(grey_path, "grey") as grey:
                gmeta = volume_meta(grey, grey_path)
                hists, _ = threshold_histograms_slabs(iter_slabs(grey, settings.slab_planes), gmeta.periodic)
            all_pore = np.flatnonzero(hists[:, -1] == hists.sum(axis=1))  # thresholds at/above max(grey)
            last = int(all_pore[0]) if len(all_pore) else len(hists) - 1
            w.write_table(
                threshold_dataset(hists[: last + 1], gmeta.voxel_um, gmeta.periodic, settings.adjacency),
                group=THRESHOLD_GROUP,
            )
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
