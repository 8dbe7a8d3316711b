"""Volumes larger than memory: cut a stored volume into boxes (a core plus a halo), run one function per box as a
Dask task, and merge the parts.

A box's core tiles the volume; its halo is the ``halo`` voxels after the core on every axis, which a local operator
of reach ``halo`` needs (the 2x2x2 cells of the Minkowski histogram: 1; LPT cells of edge L: L - 1). Along a
periodic axis the halo wraps to the start of the volume; along the others it stops at the last voxel. A function
run on a box without wrapping then sees exactly the cells whose first voxel lies in the core, so a count over the
whole volume is the sum of the counts over the boxes, bit for bit.

Each task reads its own box straight from the HDF5 file, so the memory held is one box per Dask worker (plus what
the function allocates), whatever the size of the volume.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Sequence

import numba
import numpy as np

from porepipe._shared.budget import budget_bytes, chunk_too_large


@dataclasses.dataclass(frozen=True)
class Box:
    """One box of a volume: core voxels ``start .. start + core`` and ``read`` voxels read from ``start`` on.

    ``read`` is ``core + halo`` (wrapping on periodic axes), or less where a non-periodic axis ends.
    """

    start: tuple[int, int, int]
    core: tuple[int, int, int]
    read: tuple[int, int, int]


def axis_ranges(n: int, edge: int, halo: int, wrap: bool) -> list[tuple[int, int, int]]:
    """(start, core, read) of the boxes along one axis of ``n`` voxels with cores of ``edge`` voxels."""
    out = []
    for lo in range(0, n, edge):
        core = min(edge, n - lo)
        out.append((lo, core, core + halo if wrap else min(core + halo, n - lo)))
    return out


def plan_boxes(shape: Sequence[int], edge: int, halo: int, wrap: Sequence[bool]) -> list[Box]:
    """Every box of a volume of ``shape``, in C order, with cores of ``edge`` voxels (less at the far ends)."""
    axes = [axis_ranges(int(n), int(edge), int(halo), bool(w)) for n, w in zip(shape, wrap)]
    return [Box(*(tuple(int(r[i]) for r in ranges) for i in range(3))) for ranges in itertools.product(*axes)]


def largest_read(shape: Sequence[int], edge: int, halo: int, wrap: Sequence[bool]) -> tuple[int, int, int]:
    """The read shape of the largest box of the plan (:func:`plan_boxes`)."""
    return tuple(min(edge, n) + halo if w else min(min(edge, n) + halo, n) for n, w in zip(shape, wrap))


def _wrapped(lo: int, count: int, n: int) -> list[tuple[slice, slice]]:
    """(source, destination) slices that read ``count`` voxels from ``lo`` on an axis of ``n``, wrapping at n."""
    pieces, done = [], 0
    while done < count:
        a = (lo + done) % n
        take = min(count - done, n - a)
        pieces.append((slice(a, a + take), slice(done, done + take)))
        done += take
    return pieces


def read_box(dset, box: Box) -> np.ndarray:
    """The ``box.read`` voxels of ``dset`` (an h5py dataset or array) from ``box.start`` on, wrapping at its ends."""
    out = np.empty(box.read, dtype=dset.dtype)
    axes = [_wrapped(lo, count, n) for lo, count, n in zip(box.start, box.read, dset.shape)]
    for pieces in itertools.product(*axes):
        out[tuple(dst for _, dst in pieces)] = dset[tuple(src for src, _ in pieces)]
    return out


def _edges(shape: Sequence[int], align: int) -> list[int]:
    """Candidate core edges, largest first: the whole volume, then halving, each a multiple of ``align``."""
    edge = -(-max(shape) // align) * align
    out = [edge]
    while edge > align:
        edge = max(align, -(-(edge // 2) // align) * align)
        out.append(edge)
    return out


def choose_edge(
    shape: Sequence[int],
    halo: int,
    wrap: Sequence[bool],
    cost: Callable[[tuple[int, int, int]], int],
    budget_mb: int,
    *,
    align: int = 1,
    workers: int = 1,
    what: str = "a box",
) -> int:
    """The largest core edge (a multiple of ``align``) whose box costs at most the budget per worker.

    Parameters
    ----------
    shape : 3 ints
        The volume's shape.
    halo : int
        Voxels after the core a box needs.
    wrap : 3 bools
        Periodic axes (the halo wraps there).
    cost : callable
        Bytes a task holds for a box of a given read shape (the box itself and what the function allocates).
    budget_mb : int or None
        The scene's ``resources.memory_budget_mb`` (None: one box holds the whole volume).
    align : int
        Core edges are multiples of it (e.g. the stride of a cell grid, so every box starts on the grid).
    workers : int
        Boxes held at once (Dask workers); each gets ``budget / workers``.
    what : str
        What a box is, for the error message.

    Returns
    -------
    int
        The core edge in voxels.

    Raises
    ------
    PorepipeError
        The budget cannot hold even a box of core edge ``align``; the message names the budget and the box.
    """
    if budget_bytes(budget_mb) is None:
        return _edges(shape, align)[0]
    limit = budget_bytes(budget_mb) // max(1, workers)
    for edge in _edges(shape, align):
        if cost(largest_read(shape, edge, halo, wrap)) <= limit:
            return edge
    read = largest_read(shape, align, halo, wrap)
    smallest = cost(read) * max(1, workers)
    raise chunk_too_large(
        smallest, budget_mb, f"{what} of {'x'.join(map(str, read))} voxels (core edge {align} + halo {halo})"
    )


def _run_box(open_volume: Callable, box: Box, func: Callable, threads: int):
    """Read one box and apply ``func(block, box)`` with ``threads`` numba threads (a Dask task)."""
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    with open_volume() as dset:
        block = read_box(dset, box)
    return func(block, box)


def _merge(parts: list, combine: Callable):
    out = parts[0]
    for part in parts[1:]:
        out = combine(out, part)
    return out


def map_boxes(
    open_volume: Callable,
    boxes: Sequence[Box],
    func: Callable,
    combine: Callable = np.add,
    *,
    workers: int = 1,
    threads: int | None = None,
):
    """Run ``func(block, box)`` on every box as a Dask task and merge the results with ``combine``.

    Parameters
    ----------
    open_volume : callable
        Returns a context manager yielding the stored volume (an h5py dataset); each task opens it for itself.
    boxes : sequence of Box
        From :func:`plan_boxes`.
    func : callable
        ``func(block, box)`` -> a part of the result (an array of counts, or anything ``combine`` adds).
    combine : callable
        ``combine(a, b)`` -> the merge of two parts (default: ``np.add``, exact for integer counts).
    workers : int
        Dask threads (boxes in memory at once).
    threads : int, optional
        Numba threads in all (default: the current count), shared out among the workers.

    Returns
    -------
    The merged result.
    """
    import dask

    threads = numba.get_num_threads() if threads is None else int(threads)
    per_task = max(1, threads // max(1, workers))
    parts = [dask.delayed(_run_box, pure=False)(open_volume, box, func, per_task) for box in boxes]
    total = dask.delayed(_merge, pure=False)(parts, combine)
    return dask.compute(total, scheduler="threads", num_workers=max(1, workers))[0]


def volume_bytes(shape: Sequence[int], itemsize: int = 1) -> int:
    """Bytes of a volume of ``shape`` with ``itemsize`` bytes per voxel."""
    return math.prod(int(n) for n in shape) * int(itemsize)
