"""LPT of a stored binary volume larger than the memory budget: boxes with a halo of L - 1 voxels per cell size.

A measurement cell of edge L belongs to the box that holds its origin. The box is read with L - 1 more voxels on
every axis (wrapping where the cells wrap), and the in-memory measurement of one cell size runs on it without
wrapping: it then sees exactly the cells whose origins lie in the box's core, each one whole. The box cores start on
multiples of the μ and λ strides, so the grid of origins is the global one. Counts (μ(φ, L), μ(S_V, L), λ) add
exactly; the sum of k² is a float and agrees to round-off.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import operator

import numpy as np
import xarray as xr

from porepipe._shared.chunked import choose_edge, map_boxes, plan_boxes
from porepipe._shared.store import open_volume
from porepipe.lpt._api import (
    BoxHistogram,
    _one_size,
    _PerSize,
    analysis_of,
    auto_stride,
    cell_grid,
)
from porepipe.lpt._settings import Settings

#: ring slices beyond the window the box-sum kernel holds (its batch, ``_api._BATCH``, plus one)
_RING_EXTRA = 17


def _add_hist(a: BoxHistogram | None, b: BoxHistogram | None) -> BoxHistogram | None:
    if a is None or b is None:
        return a if b is None else b
    return dataclasses.replace(
        a, counts=a.counts + b.counts, k_sum=a.k_sum + b.k_sum, k_sq_sum=a.k_sq_sum + b.k_sq_sum, records=None
    )


def _add_parts(a: _PerSize | None, b: _PerSize | None) -> _PerSize | None:
    """The parts of one cell size from two disjoint sets of cell origins, together."""
    if a is None or b is None:
        return a if b is None else b
    return dataclasses.replace(
        a,
        mu=_add_hist(a.mu, b.mu),
        lam_cells=a.lam_cells + b.lam_cells,
        lam_perc=a.lam_perc + b.lam_perc,
        lam_total=a.lam_total + b.lam_total,
        surface=_add_hist(a.surface, b.surface),
    )


def _box_part(block: np.ndarray, box, size: int, settings: Settings) -> _PerSize | None:
    if min(block.shape) < size:  # the end of a non-inside axis: no cell origin in this box
        return None
    return _one_size(block, size, (False, False, False), settings)


def _box_cost(read, size: int, surface: bool) -> int:
    """Bytes one task holds: the box (twice while it is read), its interface fields, the kernels' ring and row sums,
    a percolation cell.
    """
    voxels = math.prod(read)
    fields = 3 if surface else 0
    plane = (read[1] - size + 1) * (read[2] - size + 1)
    ring = (size + _RING_EXTRA) * plane * 4 * (3 if surface else 1) + plane * 8
    return voxels * (2 + fields) + ring + 16 * (size + 2) ** 3


def _pore_count(block: np.ndarray, box) -> int:
    return int(block.sum(dtype=np.int64))


def _pore_voxels(path, shape, budget_mb: int, threads) -> int:
    """Pore voxels of the stored volume, box by box (no halo)."""
    flat = (False, False, False)
    cost = lambda read: 2 * math.prod(read)  # noqa: E731  (h5py's copy of each piece while it is read)
    edge = choose_edge(shape, 0, flat, cost, budget_mb, what="a box of the pore volume")
    opener = functools.partial(open_volume, path, "pore")
    return map_boxes(opener, plan_boxes(shape, edge, 0, flat), _pore_count, operator.add, threads=threads)


def _one_size_chunked(path, shape, size: int, wrap, settings: Settings, budget_mb: int, threads) -> _PerSize:
    """The parts of one cell size of the stored volume, box by box (Dask tasks), merged."""
    grid = cell_grid(shape, size, wrap)
    lam_stride = settings.lambda_stride or auto_stride(grid, settings.lambda_max_cells)
    fixed = settings.model_copy(update={"lambda_stride": lam_stride})
    align = math.lcm(settings.mu_stride, lam_stride)
    cost = functools.partial(_box_cost, size=size, surface=settings.surface)
    edge = choose_edge(shape, size - 1, wrap, cost, budget_mb, align=align, what=f"an lpt box for L = {size}")
    boxes = plan_boxes(shape, edge, size - 1, wrap)
    part = functools.partial(_box_part, size=size, settings=fixed)
    merged = map_boxes(functools.partial(open_volume, path, "pore"), boxes, part, _add_parts, threads=threads)
    return dataclasses.replace(merged, placement=grid.describe(settings.mu_stride))


def local_porosity_analysis_chunked(
    path,
    shape,
    *,
    voxel_um: float,
    periodic,
    settings: Settings,
    budget_mb: int,
    skip_too_large: bool = False,
    progress=None,
    threads: int | None = None,
) -> xr.Dataset:
    """:func:`porepipe.lpt.local_porosity_analysis` of the stored volume ``pore`` of ``path`` within ``budget_mb``.

    Parameters
    ----------
    path : path-like
        The binary volume's file.
    shape : 3 ints
        Its shape.
    voxel_um, periodic, settings, skip_too_large, progress
        As for :func:`porepipe.lpt.local_porosity_analysis`.
    budget_mb : int
        ``resources.memory_budget_mb``: the most one box (with its halo and work arrays) may take.
    threads : int, optional
        Numba threads.

    Returns
    -------
    xarray.Dataset
        The same Dataset as the in-memory analysis: counts identical, sums of k² to round-off.
    """
    return analysis_of(
        shape,
        _pore_voxels(path, shape, budget_mb, threads),
        lambda size, wrap: _one_size_chunked(path, shape, size, wrap, settings, budget_mb, threads),
        voxel_um=voxel_um,
        periodic=periodic,
        settings=settings,
        skip_too_large=skip_too_large,
        progress=progress,
    )
