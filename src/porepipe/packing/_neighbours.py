"""Neighbour (Verlet) lists from hierarchical cell grids: one grid per radius class, so a radius ratio of 100 : 1
costs O(N) and not all-pairs work.

Spheres are sorted into radius classes ``floor(log2(r / r_min))``. Each class has its own cell grid whose cells
are about one same-class interaction reach wide. A sphere looks for partners only in its own class (partners with
a larger index) and in the classes of *smaller* spheres, scanning the cells within its own reach
``cutoff * (r_i + R_max,class) + skin`` (Ogarko & Luding 2012: the large sphere covers many small cells, which
costs about as many cell visits as it has partners, while a small sphere querying a large class would visit
every large sphere within the large reach). Each unordered pair is found once (the half list). The step kernel
evaluates each pair once and applies it to both ends (Newton's third law); to do so without write races it runs the
spheres by slabs at least one pair reach wide, three colours of slabs one after the other (:func:`slabs`).
The full list (both ends of each pair) is the half list's symmetric completion.
"""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.spheres import check_spheres
from porepipe.packing import _kernels as K

#: cells per class grid at most this many times its members (+ a constant), bounding memory for sparse classes
_MAX_CELLS_PER_SPHERE = 8
#: cell edge of a class grid in units of the class's own pair reach cutoff * 2 R_max + skin
_CELL_PER_REACH = 1.0


def check_box(
    radii_um: np.ndarray, box_um: np.ndarray, periodic: np.ndarray, cutoff: float, skin_um: float
) -> None:
    """Raise if the box is too small for the largest spheres (the minimum-image convention would break)."""
    if radii_um.size == 0:
        return
    top = np.partition(radii_um, radii_um.size - 2)[-2:] if radii_um.size > 1 else radii_um.copy()
    rmax = float(top[-1])
    reach = cutoff * float(top.sum() if top.size == 2 else 2 * top[0]) + skin_um
    for axis in range(3):
        if box_um[axis] < 2.0 * rmax:
            raise PorepipeError(
                f"box edge {axis} ({'xyz'[axis]}) = {box_um[axis]} µm is smaller than 2 R_max = {2 * rmax} µm: a "
                "sphere would overlap its own periodic image; enlarge domain.size_um or reduce the radii"
            )
        if periodic[axis] and box_um[axis] <= 2.0 * reach:
            raise PorepipeError(
                f"box edge {axis} ({'xyz'[axis]}) = {box_um[axis]} µm is too small for the interaction reach "
                f"cutoff * (r_1 + r_2) + skin = {reach:.6g} µm of the two largest spheres (needs more than twice "
                "that with periodic faces); enlarge domain.size_um, lower packing.cutoff or the largest radii"
            )


def _check_inputs(x_um, r_um, types, box_um, periodic, pair_on, cutoff, skin_um) -> None:
    """Refuse what the kernels would read out of bounds or silently get wrong: shapes, NaN/Inf, r <= 0, a type
    outside ``pair_on``, a bad box, cutoff or skin (one line each, naming the argument).
    """
    check_spheres(x_um, r_um, "neighbour search")
    types, pair_on = np.asarray(types), np.asarray(pair_on)
    nt = pair_on.shape[0] if pair_on.ndim == 2 and pair_on.shape[0] == pair_on.shape[1] else -1
    if nt < 1:
        raise PorepipeError(f"neighbour search: pair_on needs shape (T, T) with T >= 1, got {pair_on.shape}")
    if types.shape != np.shape(r_um) or types.dtype.kind not in "iu":
        raise PorepipeError(
            f"neighbour search: types need {np.shape(r_um)} integers, got {types.shape} {types.dtype}"
        )
    if types.size and (types.min() < 0 or types.max() >= nt):
        raise PorepipeError(
            f"neighbour search: types span {types.min()}..{types.max()}, outside 0..{nt - 1} (the {nt} type(s) of "
            "pair_on)"
        )
    box = np.asarray(box_um, dtype=np.float64)
    if box.shape != (3,) or not np.all(np.isfinite(box)) or np.any(box <= 0) or np.shape(periodic) != (3,):
        raise PorepipeError(
            f"neighbour search: box_um needs 3 positive finite edges and periodic 3 flags, got {box_um!r} and "
            f"{periodic!r}"
        )
    if not (np.isfinite(cutoff) and cutoff > 0 and np.isfinite(skin_um) and skin_um >= 0):
        raise PorepipeError(
            f"neighbour search: cutoff must be positive and skin >= 0 (both finite), got {cutoff} and {skin_um}"
        )


def _check_in_box(x_um, box_um, periodic) -> None:
    """Refuse periodic coordinates outside [0, L): the kernels' minimum image assumes |x_i - x_j| < L."""
    lo, hi = x_um.min(axis=0), x_um.max(axis=0)
    for axis in np.flatnonzero(np.asarray(periodic, dtype=bool) & ((lo < 0) | (hi >= box_um))):
        raise PorepipeError(
            f"sphere centres along periodic axis {'xyz'[axis]} span [{lo[axis]:.6g}, {hi[axis]:.6g}] "
            f"µm, outside [0, {box_um[axis]:.6g}) µm; wrap them into the box first (np.mod)"
        )


def _class_grids(x, r, box, cutoff, skin):
    cls = np.floor(np.log2(r / r.min())).astype(np.int64)
    np.maximum(cls, 0, out=cls)
    ncls = int(cls.max()) + 1
    side = np.zeros((ncls, 4))  # cell edge x, y, z; column 3 = R_max of the class (0: empty class)
    ncell = np.ones((ncls, 3), dtype=np.int64)
    members = np.bincount(cls, minlength=ncls)
    rmax_c = np.zeros(ncls)
    np.maximum.at(rmax_c, cls, r)
    for c in range(ncls):
        if members[c] == 0:
            continue
        target = _CELL_PER_REACH * (2.0 * cutoff * rmax_c[c] + skin)
        target = max(target, (np.prod(box) / (_MAX_CELLS_PER_SPHERE * members[c] + 64)) ** (1.0 / 3.0))
        ncell[c] = np.maximum(1, np.floor(box / target)).astype(np.int64)
        side[c, :3] = box / ncell[c]
        side[c, 3] = rmax_c[c]
    cell_off = np.zeros(ncls + 1, dtype=np.int64)
    cell_off[1:] = np.cumsum(np.prod(ncell, axis=1))
    return cls, ncls, side, ncell, cell_off


def build_neighbours(
    x_um, r_um, types, box_um, periodic, pair_on, cutoff, skin_um, reorder=False, half=False
):
    """Full CSR neighbour list: partners j of i with |x_i - x_j| <= cutoff * (r_i + r_j) + skin (minimum image).

    Periodic coordinates must lie in [0, L) (the engine keeps them there); others raise a PorepipeError.

    With ``reorder`` the spheres are first put in slab-tiled cell order (:func:`_tile_order`), so that partners
    sit close in memory; the list then refers to the reordered spheres ``x_um[order]``.

    Returns
    -------
    start : (N + 1,) int64
        Offsets; the partners of i are ``idx[start[i]:start[i + 1]]``.
    idx : (E,) int64
        Partner indices, each unordered pair listed from both ends.
    order : (N,) int64
        Only with ``reorder``: the permutation applied (new sphere k is old sphere ``order[k]``).

    With ``half`` the step kernel's lists come instead of (start, idx): the half list (half_start, half_idx; each
    unordered pair once) and the slabs (slab_start, slab_items) of :func:`slabs`.
    """
    _check_inputs(x_um, r_um, types, box_um, periodic, pair_on, cutoff, skin_um)
    n = x_um.shape[0]
    if n == 0:
        empty = (np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64))
        empty = (*empty, *empty) if half else empty
        return (*empty, np.zeros(0, dtype=np.int64)) if reorder else empty
    _check_in_box(x_um, box_um, periodic)
    cls, ncls, side, ncell, cell_off = _class_grids(x_um, r_um, box_um, cutoff, skin_um)
    cell_of = np.empty(n, dtype=np.int64)
    K._assign_cells(x_um, cls, side, ncell, cell_off, cell_of)
    cell_start = np.empty(cell_off[-1] + 1, dtype=np.int64)
    cell_items = np.empty(n, dtype=np.int64)
    K._counting_sort(cell_of, cell_off[-1], cell_start, cell_items)
    order = None
    if reorder:
        order = _tile_order(
            cell_of, cls, ncell, cell_off, *_slab_ids(x_um, r_um, box_um, periodic, cutoff, skin_um)
        )
        x_um, r_um, types, cls = x_um[order], r_um[order], types[order], cls[order]
        cell_of = cell_of[order]
        K._counting_sort(cell_of, cell_off[-1], cell_start, cell_items)
    per = np.array(periodic, dtype=np.bool_)  # a copy: a read-only array would compile the kernels once more
    args = (
        x_um,
        r_um,
        types,
        cls,
        ncls,
        side,
        ncell,
        cell_off,
        cell_start,
        cell_items,
        box_um,
        per,
        pair_on,
        float(cutoff),
        float(skin_um),
    )
    counts = np.empty(n, dtype=np.int64)
    K._half_counts(*args, counts)
    half_start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=half_start[1:])
    half_idx = np.empty(half_start[-1], dtype=np.int64)
    K._half_fill(*args, half_start, half_idx)
    if half:
        lists = (half_start, half_idx, *slabs(x_um, r_um, box_um, periodic, cutoff, skin_um))
        return (*lists, order) if reorder else lists
    start = np.empty(n + 1, dtype=np.int64)
    idx = np.empty(2 * half_idx.size, dtype=np.int64)
    K._full_from_half(half_start, half_idx, start, idx)
    return (start, idx, order) if reorder else (start, idx)


def _tile_order(cell_of, cls, ncell, cell_off, slab, nslab, axis):
    """Permutation into slab-tiled cell order: by radius class, then slab of :func:`slabs`, then cell with the
    slab axis varying fastest (stable, so spheres of one cell keep their order).

    Plain row-major cell order puts a sphere's partners one cell further along the first axis a whole plane of cells
    away in memory (1.6 MB of positions for 10^6 spheres); with the slab axis innermost they sit one short column
    of cells away, and every slab's spheres of one class are one contiguous block, walked in memory order by the
    step kernel's slab loop. Measured at 10^6 spheres, one thread, in one run (benchmarks/pack.py --full): 3-7 %
    fewer CPU seconds per step than row-major order (Morton order: 20 % more, its slabs are not contiguous in
    memory). The gain is small because the step is not bound by memory locality: with each partner replaced by a
    neighbour in memory, the pair pass costs the same.
    """
    lin = cell_of - cell_off[cls]
    n = ncell[cls]
    q = np.empty((3, lin.size), dtype=np.int64)
    q[2] = lin % n[:, 2]
    rest = lin // n[:, 2]
    q[1] = rest % n[:, 1]
    q[0] = rest // n[:, 1]
    b, c = (a for a in range(3) if a != axis)
    return np.lexsort((q[axis], q[c], q[b], slab, cls))


def _slab_ids(x_um, r_um, box_um, periodic, cutoff, skin_um):
    """Slab of every sphere for :func:`slabs`, the slab count and the slab axis."""
    reach = (cutoff * 2.0 * float(r_um.max()) + skin_um) * (
        1.0 + 1e-9
    )  # margin: slab ids come from rounded x m / L
    counts = np.floor(np.asarray(box_um, dtype=np.float64) / reach).astype(np.int64)
    per = np.asarray(periodic, dtype=bool)
    counts = np.where(per & (counts > 2), counts - counts % 3, counts)
    counts = np.maximum(counts, 1)
    axis = int(np.argmax(counts))
    m = int(counts[axis])
    slab = np.clip(np.floor(x_um[:, axis] * (m / box_um[axis])).astype(np.int64), 0, m - 1)
    return slab, m, axis


def slabs(x_um, r_um, box_um, periodic, cutoff, skin_um):
    """Spheres by slab along the axis that holds the most slabs at least one pair reach (cutoff 2 R_max + skin)
    wide: slab s holds spheres ``items[start[s]:start[s + 1]]``, in increasing order.

    A listed pair then spans two neighbouring slabs at most, so slabs of one colour (s mod 3) share no sphere. With
    periodic faces the slab count is 1, 2 or a multiple of 3 (the colouring must also hold across the wrap).
    """
    slab, m, _ = _slab_ids(x_um, r_um, box_um, periodic, cutoff, skin_um)
    start = np.empty(m + 1, dtype=np.int64)
    items = np.empty(slab.size, dtype=np.int64)
    K._counting_sort(slab, m, start, items)
    return start, items
