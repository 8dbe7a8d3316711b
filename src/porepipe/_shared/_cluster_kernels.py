"""Numba kernels of :mod:`porepipe._shared.clusters`: a breadth-first flood fill that relabels one cluster of a uint8
volume in place (no label array), with per-axis periodic wrap and any neighbour set.

The volume is C-contiguous ``(n0, n1, n2)``; voxels are addressed by their flat index. The queue is a ring of int64
flat indices that doubles when full; it holds the front of the fill, not the cluster.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from porepipe._shared import numba_config  # noqa: F401  (the package-wide cache stamp, before any kernel)

# the values flood() writes, "no axis" and "no seed yet", as typed int64, not literals: numba compiles a callee once
# per literal argument value, so 3, 4, 5 and -1 written into the calls compiled flood five times (~6 CPU-s cold)
_FILLED, _REFILLED, _WRAPPED = np.int64(3), np.int64(4), np.int64(5)
_NO_AXIS = _NO_SEED = np.int64(-1)


@njit(cache=True)
def _grow(queue, head, count):
    """A ring twice as long holding the ``count`` entries of ``queue`` from ``head`` on, in order, at 0.."""
    bigger = np.empty(2 * queue.size, dtype=np.int64)
    for k in range(count):
        bigger[k] = queue[(head + k) % queue.size]
    return bigger


@njit(cache=True, inline="always")
def _push(queue, head, count, g):
    """Append ``g`` to the ring (growing it when full); returns (queue, head, count)."""
    if count == queue.size:
        queue = _grow(queue, head, count)
        head = 0
    queue[(head + count) % queue.size] = g
    return queue, head, count + 1


@njit(cache=True)
def flood(state, seed, take, to_value, offsets, periodic, axis, queue):
    """Relabel to ``to_value`` the cluster of ``seed`` over voxels whose value ``v`` has ``take[v]`` set.

    Parameters
    ----------
    state : (n0, n1, n2) uint8 C-contiguous ndarray
        Changed in place.
    seed : int
        Flat index of the start voxel (``take[state[seed]]`` must hold).
    take : (256,) bool ndarray
        Values that belong to the cluster (``take[to_value]`` must be False).
    to_value : int
        The cluster's new value.
    offsets : (m, 3) int64 ndarray
        Neighbour steps (e.g. the 6 faces).
    periodic : (3,) bool ndarray
        Axes that wrap.
    axis : int
        Axis whose first and last layer are watched (-1: none).
    queue : (q,) int64 ndarray
        Work ring (any size >= 1); a larger one is returned if it had to grow.

    Returns
    -------
    size : int
        Voxels relabelled.
    low, high : bool
        Whether the cluster touches layer 0 / the last layer of ``axis``.
    queue : int64 ndarray
    """
    n0, n1, n2 = state.shape
    flat = state.reshape(-1)
    dims = np.array([n0, n1, n2], dtype=np.int64)
    cur = np.empty(3, dtype=np.int64)
    value = np.uint8(to_value)
    n_off = offsets.shape[0]
    step = np.empty(n_off, dtype=np.int64)  # flat steps, valid away from the box faces
    for m in range(n_off):
        step[m] = (offsets[m, 0] * n1 + offsets[m, 1]) * n2 + offsets[m, 2]
    flat[seed] = value
    queue[0] = seed
    head, count = 0, 1
    size = 0
    low = high = False
    while count > 0:
        f = queue[head]
        head = (head + 1) % queue.size
        count -= 1
        size += 1
        cur[0] = f // (n1 * n2)
        cur[1] = (f // n2) % n1
        cur[2] = f % n2
        if axis >= 0:
            if cur[axis] == 0:
                low = True
            if cur[axis] == dims[axis] - 1:
                high = True
        if (
            0 < cur[0] < n0 - 1 and 0 < cur[1] < n1 - 1 and 0 < cur[2] < n2 - 1
        ):  # interior: no wrap, no bounds
            for m in range(n_off):
                g = f + step[m]
                if take[flat[g]]:
                    flat[g] = value
                    queue, head, count = _push(queue, head, count, g)
            continue
        for m in range(n_off):
            i = cur[0] + offsets[m, 0]
            j = cur[1] + offsets[m, 1]
            k = cur[2] + offsets[m, 2]
            if i < 0 or i >= n0:
                if not periodic[0]:
                    continue
                i %= n0
            if j < 0 or j >= n1:
                if not periodic[1]:
                    continue
                j %= n1
            if k < 0 or k >= n2:
                if not periodic[2]:
                    continue
                k %= n2
            g = (i * n1 + j) * n2 + k
            if take[flat[g]]:
                flat[g] = value
                queue, head, count = _push(queue, head, count, g)
    return size, low, high, queue


@njit(cache=True)
def spanning(state, offsets, periodic, axis, keep_all, queue):
    """Mark the clusters of value-1 voxels that join layer 0 and the last layer of ``axis`` (or, axis -1, the largest).

    Parameters
    ----------
    state : (n0, n1, n2) uint8 C-contiguous ndarray
        0 = solid, 1 = pore; changed in place: the kept cluster(s) get 3, every other visited cluster 4, clusters
        never reached keep 1 (they do not touch layer 0, or axis -1 and none is left).
    offsets, periodic, queue
        As for :func:`flood`.
    axis : int
        Axis to span; -1: no spanning condition (keep the largest cluster).
    keep_all : bool
        Every spanning cluster gets 3; else only the largest one (ties: the first met).

    Returns
    -------
    int
        Spanning clusters (axis -1: clusters).
    """
    n0, n1, n2 = state.shape
    flat = state.reshape(-1)
    fresh = np.zeros(256, dtype=np.bool_)
    fresh[1] = True
    kept = np.zeros(256, dtype=np.bool_)
    kept[3] = True
    best_size, best_seed, found = 0, _NO_SEED, 0
    for f in range(flat.size):
        if flat[f] != 1:
            continue
        if axis == 0 and f >= n1 * n2:  # seeds on layer 0 only: a spanning cluster touches it
            break
        if (axis == 1 and (f // n2) % n1 != 0) or (axis == 2 and f % n2 != 0):
            continue
        # fill straight into "kept" (3); a cluster that is not kept after all is refilled to 4. Distinct clusters
        # never touch, so a fill over value 3 from a seed stays in that seed's cluster. The large (spanning) cluster
        # is filled once; only losers and a dethroned best are filled twice.
        size, low, high, queue = flood(state, f, fresh, _FILLED, offsets, periodic, axis, queue)
        joins = high if axis >= 0 else True
        if joins:
            found += 1
        if joins and (keep_all or size > best_size):
            if not keep_all and best_seed >= 0:
                queue = flood(state, best_seed, kept, _REFILLED, offsets, periodic, axis, queue)[3]
            best_size, best_seed = size, f
        else:
            queue = flood(state, f, kept, _REFILLED, offsets, periodic, axis, queue)[3]
    return found


@njit(cache=True)
def grow_wrapped(state, offsets, periodic, queue):
    """Relabel to 5 every cluster of values {1, 3, 4} (pore) that contains a value-3 voxel, with ``periodic`` wrap."""
    flat = state.reshape(-1)
    pore = np.zeros(256, dtype=np.bool_)
    pore[1] = pore[3] = pore[4] = True
    for f in range(flat.size):
        if flat[f] == 3:
            queue = flood(state, f, pore, _WRAPPED, offsets, periodic, _NO_AXIS, queue)[3]


@njit(cache=True)
def keep_value(state, value):
    """In place: 1 where ``state == value``, else 0; returns the count of 1s."""
    flat = state.reshape(-1)
    n = 0
    for f in range(flat.size):
        if flat[f] == value:
            flat[f] = 1
            n += 1
        else:
            flat[f] = 0
    return n
