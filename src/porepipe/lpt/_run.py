"""File in, compute, file out: ``lpt_a{a}.h5`` (and its PNG plots) from a binary volume."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.budget import fits
from porepipe._shared.chunked import volume_bytes
from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.progress import Progress
from porepipe._shared.store import ResultWriter, open_volume, read_attrs, result_hash, volume_meta
from porepipe.lpt._api import cell_sizes, local_porosity_analysis
from porepipe.lpt._chunked import local_porosity_analysis_chunked
from porepipe.lpt._plot import plot_lpt
from porepipe.lpt._settings import Settings


def read_binary(
    path, subsample_um: float | None = None
) -> tuple[np.ndarray, float, tuple[bool, bool, bool], str]:
    """Pore volume, voxel edge (µm), periodicity and a note; optionally only the corner cube of edge ``subsample_um``.

    Parameters
    ----------
    path : path-like
        Binary volume (volume ``pore``); a file written by ``porepipe subsample`` (root attribute ``sample_um``) is
        itself a corner sub-sample.
    subsample_um : float, optional
        Edge of the corner cube to read (µm); its cut faces are not periodic.

    Returns
    -------
    pore : (X, Y, Z) ndarray of uint8
    voxel_um : float
    periodic : (bool, bool, bool)
    note : str
        What part of the sample was read.
    """
    root = read_attrs(path)
    with open_volume(path, "pore") as dset:
        meta = volume_meta(dset, path)
        voxel_um = meta.voxel_um
        if subsample_um is None:
            note = "whole sample"
            if "sample_um" in root:
                note = f"sub-sample: corner cube of {float(root['sample_um']):g} µm edge from {root.get('source', '?')}"
            return dset[...], voxel_um, meta.periodic, note
        edge = int(np.floor(subsample_um / voxel_um + 0.5))
        if not 1 <= edge <= min(dset.shape):
            raise PorepipeError(
                f"--subsample-um {subsample_um} is {edge} voxels of {voxel_um} µm; allowed 1 .. "
                f"{min(dset.shape)} voxels for the volume of shape {dset.shape} in {path}"
            )
        note = (
            f"sub-sample: corner cube [0, {edge})^3 voxels = {edge * voxel_um:g} µm edge, not periodic "
            "(the cut breaks the periodicity)"
        )
        return dset[:edge, :edge, :edge], voxel_um, (False, False, False), note


def _stored_whole(path, budget_mb: int | None) -> tuple | None:
    """(shape, voxel_um, periodic, note) of a whole stored volume that does not fit the budget, else None."""
    if budget_mb is None:
        return None
    root = read_attrs(path)
    with open_volume(path, "pore") as dset:
        meta, shape = volume_meta(dset, path), dset.shape
    if fits(volume_bytes(shape), budget_mb):
        return None
    note = "whole sample"
    if "sample_um" in root:
        note = (
            f"sub-sample: corner cube of {float(root['sample_um']):g} µm edge from {root.get('source', '?')}"
        )
    return shape, meta.voxel_um, meta.periodic, note + " (read in boxes: resources.memory_budget_mb)"


def _analyse(binary_path, settings, subsample_um, is_part, budget_mb, name):
    """The analysis in memory, or box by box when the whole volume does not fit the budget; (Dataset, note)."""
    stored = None if subsample_um is not None else _stored_whole(binary_path, budget_mb)
    if stored is None:
        pore, voxel_um, periodic, note = read_binary(binary_path, subsample_um)
        shape = pore.shape
    else:
        shape, voxel_um, periodic, note = stored
    sizes, _ = cell_sizes(settings, voxel_um, shape)
    progress = Progress(f"lpt {name}", total=sum(s <= min(shape) for s in sizes))
    common = dict(
        voxel_um=voxel_um, periodic=periodic, settings=settings, skip_too_large=is_part, progress=progress
    )
    if stored is None:
        ds = local_porosity_analysis(pore, **common)
    else:
        ds = local_porosity_analysis_chunked(binary_path, shape, budget_mb=budget_mb, **common)
    progress.close(f"local porosity distributions for {progress.total} cell sizes")
    return ds, note


def run(
    binary_path,
    out,
    settings: Settings,
    *,
    subsample_um: float | None = None,
    threads: int | None = None,
    plots: bool | None = None,
    memory_budget_mb: int | None = None,
) -> xr.Dataset:
    """Write ``lpt_a{a}.h5`` (the Dataset of :func:`local_porosity_analysis` at the root) and its PNG plots.

    Parameters
    ----------
    binary_path : path-like
        Binary volume (1 = pore) with ``voxel_um``, ``origin_um``, ``periodic``.
    out : path-like
        The result file; the plots go beside it (``<name>_*.png``).
    settings : Settings
        The ``lpt`` settings (scene section with command-line options laid over it).
    subsample_um : float, optional
        Analyse only the corner cube of this edge (µm); cells that do not fit are left out.
    threads : int, optional
        Numba threads (default: all).
    plots : bool, optional
        Write the PNG plots (default: ``settings.plots``).
    memory_budget_mb : int, optional
        The scene's ``resources.memory_budget_mb``: a whole volume larger than it is analysed box by box
        (:mod:`porepipe.lpt._chunked`; the same Dataset).

    Returns
    -------
    xarray.Dataset
        μ(φ, L), μ(S_V, L), λ_α(φ, L), p_α(L) and their moments.
    """
    threads = set_threads(threads)
    src = read_attrs(binary_path)
    is_part = (
        subsample_um is not None or "sample_um" in src
    )  # a sub-sample leaves out the cells that do not fit
    ds, note = _analyse(
        binary_path, settings, subsample_um, is_part, memory_budget_mb, Path(binary_path).name
    )
    voxel_um = ds.attrs["voxel_um"]
    ds.attrs["sample"] = note
    digest = result_hash("lpt", settings=settings, inputs=[binary_path], subsample_um=subsample_um)
    with ResultWriter(out, stage="lpt", scene=src.get("scene", ""), scene_hash=digest, threads=threads) as w:
        w.write_table(ds)
        w.attrs.update(
            voxel_um=voxel_um, phi_bar=ds.attrs["phi_bar"], L_star_um=ds.attrs["L_star_um"], sample=note
        )
    if settings.plots if plots is None else plots:
        out = Path(out)
        plot_lpt(ds, out.with_name(out.name.removesuffix(".h5")))
    return ds
