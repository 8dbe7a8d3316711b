"""Which pore voxels can carry flow along the flow axis (axis 0): percolation and pruning.

Connectivity is the D3Q19 link set (faces and edges, 18-neighbourhood). A cluster *spans* the sample if it
touches the first and the last layer. With a body force on every node (periodic set-up) a cluster that does
not wind around the periodic flow axis is static in steady Stokes flow (the uniform force is the gradient of a
single-valued potential on it), so dropping it is exact; such a component winds iff it contains a spanning
cluster of the unwrapped sample.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from porepipe.lbm._lattice import C

_STRUCTURE_18 = ndimage.generate_binary_structure(3, 2)


def _face_links(labels: np.ndarray, axis: int, periodic: tuple[bool, bool, bool]) -> np.ndarray:
    """Label pairs (k, 2) joined by a lattice link across the periodic face of ``axis``."""
    last = np.take(labels, -1, axis=axis)
    first = np.take(labels, 0, axis=axis)
    others = [a for a in range(3) if a != axis]
    pairs = []
    for q in range(1, 19):
        if C[q, axis] != 1:
            continue
        shifted, valid = first, np.ones(first.shape, dtype=bool)
        for dim, a in enumerate(others):
            step = int(C[q, a])
            if step == 0:
                continue
            shifted = np.roll(shifted, -step, axis=dim)
            if not periodic[a]:
                edge = -1 if step > 0 else 0
                sl = [slice(None), slice(None)]
                sl[dim] = edge
                valid = valid.copy()
                valid[tuple(sl)] = False
        ok = valid & (last > 0) & (shifted > 0)
        pairs.append(np.stack([last[ok], shifted[ok]], axis=1))
    return np.concatenate(pairs) if pairs else np.zeros((0, 2), dtype=labels.dtype)


def _merge(labels: np.ndarray, n: int, pairs: np.ndarray) -> np.ndarray:
    """Map label -> component id (label 0 stays 0) after joining the given label pairs."""
    if len(pairs) == 0:
        return np.arange(n + 1)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n + 1, n + 1))
    _, comp = connected_components(graph, directed=False)
    comp = comp + 1
    comp[0] = 0
    return comp


def flow_paths(pore: np.ndarray, lateral_periodic: bool, wrap_flow_axis: bool) -> tuple[np.ndarray, int]:
    """Pore voxels that belong to flow paths along axis 0, and the number of spanning clusters.

    Parameters
    ----------
    pore : (L0, L1, L2) bool ndarray
        Pore space, flow along axis 0.
    lateral_periodic : bool
        Whether axes 1 and 2 wrap.
    wrap_flow_axis : bool
        True for the periodic body-force set-up: keep whole wrapped components that contain a spanning cluster
        (exact). False for the chamber set-up: keep only the spanning clusters themselves.

    Returns
    -------
    keep : (L0, L1, L2) bool ndarray
    n_spanning : int
    """
    labels, n = ndimage.label(pore, structure=_STRUCTURE_18)
    periodic = (False, lateral_periodic, lateral_periodic)
    if lateral_periodic:
        pairs = np.concatenate([_face_links(labels, 1, periodic), _face_links(labels, 2, periodic)])
        comp = _merge(labels, n, pairs)
        labels = comp[labels]
    spanning = np.intersect1d(np.unique(labels[0]), np.unique(labels[-1]))
    spanning = spanning[spanning > 0]
    if spanning.size == 0:
        return np.zeros(pore.shape, dtype=bool), 0
    if wrap_flow_axis:
        n_now = int(labels.max())
        comp = _merge(labels, n_now, _face_links(labels, 0, (True, lateral_periodic, lateral_periodic)))
        keep_ids = np.unique(comp[spanning])
        keep = np.isin(comp[labels], keep_ids) & pore
    else:
        keep = np.isin(labels, spanning)
    return keep, int(spanning.size)
