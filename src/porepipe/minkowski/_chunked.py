"""Configuration histograms of stored volumes larger than the memory budget: boxes with a halo of one voxel.

A 2x2x2 cell belongs to the box that holds its first voxel; the box is read with one more voxel on every axis
(wrapping on periodic axes), and the in-memory counters run on it without wrapping, so the sum over boxes equals the
histogram of the whole volume exactly (integers; the merge is :func:`numpy.add`).
"""

from __future__ import annotations

import functools

import numpy as np

from porepipe._shared.chunked import choose_edge, map_boxes, plan_boxes
from porepipe._shared.store import open_volume
from porepipe.minkowski._api import _periodic3, configuration_histogram, threshold_histograms
from porepipe.minkowski._weights import N_CODES

#: a 2x2x2 cell reaches one voxel past its first one
HALO = 1
#: a box is held twice while it is read (h5py's array of each piece, copied into the box)
_READ_COPIES = 2


def _binary_part(block: np.ndarray, box) -> np.ndarray:
    if min(block.shape) < 2:  # a box at the end of a non-periodic axis with no complete cell
        return np.zeros(N_CODES, np.int64)
    return configuration_histogram(block, periodic=False)


def _grey_part(block: np.ndarray, box, n_levels: int) -> np.ndarray:
    if min(block.shape) < 2:
        return np.zeros((n_levels, N_CODES), np.int64)
    return threshold_histograms(block, periodic=False, n_levels=n_levels)


def _plan(shape, periodic, budget_mb: int, per_task: int, what: str):
    flags = _periodic3(periodic)
    cost = lambda read: _READ_COPIES * int(np.prod(read, dtype=np.int64)) + per_task  # noqa: E731
    edge = choose_edge(shape, HALO, flags, cost, budget_mb, what=what)
    return plan_boxes(shape, edge, HALO, flags)


def configuration_histogram_chunked(
    path, name: str, shape, periodic, budget_mb: int, threads: int | None = None
) -> np.ndarray:
    """:func:`configuration_histogram` of ``/volumes/<name>`` of ``path``, box by box within ``budget_mb``.

    Parameters
    ----------
    path : path-like
        The result file holding the binary volume.
    name : str
        The volume's name (``pore``).
    shape : 3 ints
        Its shape.
    periodic : bool or 3 bools
        Periodic axes.
    budget_mb : int
        ``resources.memory_budget_mb``: the largest box held at once.
    threads : int, optional
        Numba threads.

    Returns
    -------
    (256,) int64 ndarray
        Identical to :func:`configuration_histogram` of the whole volume.
    """
    boxes = _plan(shape, periodic, budget_mb, 0, "a Minkowski box")
    return map_boxes(functools.partial(open_volume, path, name), boxes, _binary_part, threads=threads)


def threshold_histograms_chunked(
    path, name: str, shape, periodic, budget_mb: int, n_levels: int = 256, threads: int | None = None
) -> np.ndarray:
    """:func:`threshold_histograms` of a stored grey volume, box by box within ``budget_mb``.

    Parameters
    ----------
    path, name, shape, periodic, budget_mb, threads
        As for :func:`configuration_histogram_chunked` (``name`` is ``grey``).
    n_levels : int
        Thresholds t = 0 .. n_levels - 1 (rows of the result).

    Returns
    -------
    (n_levels, 256) int64 ndarray
        Identical to :func:`threshold_histograms` of the whole volume.
    """
    per_task = n_levels * N_CODES * 8 * (1 + (threads or 1))
    boxes = _plan(shape, periodic, budget_mb, per_task, "a grey Minkowski box")
    part = functools.partial(_grey_part, n_levels=n_levels)
    return map_boxes(functools.partial(open_volume, path, name), boxes, part, threads=threads)
