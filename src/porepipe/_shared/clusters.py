"""Percolation and cluster selection of a binary volume with little memory, shared by ``lbm`` and ``diffusion``.

The clusters are found by an in-place flood fill of a 1-byte work copy (no label array): beyond the copy, only the
fill's front (int64 flat indices) is held. Connectivity is a parameter: 6 (faces), 18 (faces and edges, the D3Q19
links) or 26. Periodic axes wrap; a cluster *spans* ``axis`` if it touches both its first and its last layer.
"""

from __future__ import annotations

import itertools

import numpy as np

from porepipe._shared import _cluster_kernels as K
from porepipe._shared.errors import PorepipeError

#: allowed neighbourhoods: the number of neighbours -> largest |step| sum (1 faces, 2 edges, 3 corners)
_ORDER = {6: 1, 18: 2, 26: 3}
_QUEUE = 1 << 16


def neighbour_offsets(connectivity: int) -> np.ndarray:
    """(m, 3) int64 steps of the 6-, 18- or 26-neighbourhood."""
    if connectivity not in _ORDER:
        raise PorepipeError(f"connectivity must be 6, 18 or 26, got {connectivity!r}")
    steps = [
        s for s in itertools.product((-1, 0, 1), repeat=3) if 0 < sum(map(abs, s)) <= _ORDER[connectivity]
    ]
    return np.array(steps, dtype=np.int64)


def _work(pore, in_place: bool) -> np.ndarray:
    pore = np.asarray(pore)
    if pore.ndim != 3 or min(pore.shape) < 1:
        raise PorepipeError(f"a pore volume must be 3-D with positive sizes, got shape {pore.shape}")
    if in_place:
        if pore.dtype != np.uint8 or not pore.flags.c_contiguous or not pore.flags.writeable:
            raise PorepipeError("in_place needs a writeable C-contiguous uint8 volume")
        np.minimum(pore, 1, out=pore)
        return pore
    work = np.empty(pore.shape, dtype=np.uint8)
    for i in range(pore.shape[0]):  # slab by slab: no full-size temporary
        np.not_equal(pore[i], 0, out=work[i], casting="unsafe")
    return work


def spanning_clusters(
    pore,
    axis: int | None,
    *,
    connectivity: int = 6,
    periodic=(False, False, False),
    keep: str = "largest",
    wrap_axis: bool = False,
    in_place: bool = False,
) -> tuple[np.ndarray, int]:
    """The pore voxels of the clusters that join the first and the last layer of ``axis``.

    Parameters
    ----------
    pore : (n0, n1, n2) ndarray
        Nonzero = pore.
    axis : int or None
        Axis to span; None: no spanning condition (``keep = "largest"`` gives the largest cluster).
    connectivity : int
        6, 18 or 26 neighbours.
    periodic : (3,) bool
        Axes that wrap while clusters are found (``axis`` itself never does here).
    keep : str
        ``"largest"``: the largest spanning cluster; ``"all"``: every spanning cluster.
    wrap_axis : bool
        Then also keep every voxel connected to a kept one when ``axis`` wraps too (whole periodic components).
    in_place : bool
        Use ``pore`` (writeable C-contiguous uint8) as the work array and return it: no extra volume at all.

    Returns
    -------
    mask : (n0, n1, n2) uint8 ndarray
        1 = kept.
    count : int
        Spanning clusters (with ``axis`` None: clusters).
    """
    if keep not in ("largest", "all"):
        raise PorepipeError(f"keep must be 'largest' or 'all', got {keep!r}")
    if axis is None and (keep == "all" or wrap_axis):
        raise PorepipeError("keep = 'all' and wrap_axis need a spanning axis")
    state = _work(pore, in_place)
    offsets = neighbour_offsets(connectivity)
    per = np.array([bool(p) for p in np.broadcast_to(periodic, (3,))])
    ax = -1 if axis is None else int(axis)
    if ax >= 0:
        per[ax] = False
    queue = np.empty(_QUEUE, dtype=np.int64)
    count = K.spanning(state, offsets, per, ax, keep == "all", queue)
    value = 3
    if wrap_axis and count:
        per[ax] = True
        K.grow_wrapped(state, offsets, per, queue)
        value = 5
    K.keep_value(state, value)
    return state, int(count)
