"""Overlap Minimizer (Zauner 2020, §8.2.2; Table 8.3): grain orientations and sizes chosen to reduce neighbour overlap.

The thesis gives the outline only (details are in Afach's unpublished MSc thesis [3]): the box is divided into
overlapping cells of volume V^OM; grain sizes and orientations are optimised over N_Z^OM passes per cell and N_K^OM
trials per grain, counting only grains in the same cell. Our reading, stated so it can be checked:

- Cells: a grid of cubes of edge ≈ (V^OM)^(1/3) (rounded so whole cells tile the box) and a second grid shifted by
  half a cell along every axis; every grain lies in one cell of each grid, so pairs cut by a face of one grid meet in
  the other. Without V^OM the exact neighbour list (circumscribed spheres that can meet) replaces the cells.
- Trials: the current pose and N_K^OM − 1 random ones (rotation uniform on SO(3); with a size window w, the scale
  uniform in s_nom·[1 − w, 1 + w] about the size the scaling rule gives the grain).
- Objective of grain i: J_i = Σ_j |G_i ∩ G_j| − μ |G_i|, μ the ``volume_weight``. Minimising Σ_pairs overlap alone
  would shrink every grain; J_i is the Lagrangian of "least total overlap at a given total grain volume", so a grain
  grows while less than the fraction μ of its growth lands in neighbours, and shrinks otherwise.
- After the passes the sizes are scaled by one common factor so that the total grain volume is the scaling rule's
  again: the minimiser moves volume between grains but does not change it (orientation-only runs keep it anyway).

The overlap Σ_j |G_i ∩ G_j| of a trial is estimated from fixed quadrature points of the grain's type (uniform in the
body, the same for every trial: common random numbers), scaled with the trial's size.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.progress import Progress
from porepipe.decorate._api import (
    _STREAM_MINIMISER,
    Decoration,
    _check_box,
    _grain_planes,
    _rng,
    _separation,
    _type_points,
    pairs_within,
    world_grains,
)
from porepipe.decorate._kernels import _points_inside_serial
from porepipe.decorate._library import Kind
from porepipe.decorate._rotation import uniform_rotations


@dataclasses.dataclass(frozen=True)
class Trials:
    """Per-grain search of the minimiser: N_K^OM trials, size window w about the nominal scale, volume weight μ."""

    count: int = 5
    size_window: float = 0.0
    volume_weight: float = 0.3


def om_cells(centres, box, periodic: bool, cell_volume_um3: float) -> list[np.ndarray]:
    """Grain indices of every cell of the two staggered grids of cells of volume ≈ ``cell_volume_um3``."""
    if not 0 < cell_volume_um3 < np.inf:
        raise PorepipeError(f"cell_volume_um3 must be positive and finite, got {cell_volume_um3}")
    box = _check_box(box, "om_cells", "box")
    n = np.maximum(1, np.floor(box / cell_volume_um3 ** (1.0 / 3.0))).astype(np.int64)
    edge = box / n
    grids = [np.zeros(3)] if np.all(n == 1) and periodic else [np.zeros(3), 0.5 * edge]
    cells = []
    for shift in grids:
        key = np.floor((centres + shift) / edge).astype(np.int64)
        key = np.mod(key, n) if periodic else np.clip(key, 0, n)
        flat = np.ravel_multi_index(key.T, n + 1)
        order = np.argsort(flat, kind="stable")
        bounds = np.flatnonzero(np.diff(flat[order])) + 1
        cells += [c for c in np.split(order, bounds) if len(c) > 1]
    return cells


def _neighbour_lists(n: int, pairs: np.ndarray) -> list[np.ndarray]:
    nbrs: list[list[int]] = [[] for _ in range(n)]
    for i, j in pairs:
        nbrs[i].append(j)
        nbrs[j].append(i)
    return [np.array(v, dtype=np.int64) for v in nbrs]


def minimise_overlap(
    deco: Decoration,
    box_um,
    periodic: bool = True,
    trials: int = 5,
    passes: int = 3,
    points_per_grain: int = 512,
    rng=None,
    progress: bool = False,
    *,
    size_window: float = 0.0,
    volume_weight: float = 0.3,
    cell_volume_um3: float | None = None,
) -> Decoration:
    """Overlap Minimizer (§8.2.2; module docstring): ``passes`` (N_Z^OM) sweeps, ``trials`` (N_K^OM) poses per grain.

    ``size_window`` w = 0 optimises orientations only (sizes and volumes unchanged); w > 0 also sizes, in
    s_nom·[1 − w, 1 + w], with the total grain volume restored at the end. ``cell_volume_um3`` (V^OM) switches from
    exact neighbour lists to the thesis's overlapping cells.
    """
    box = _check_box(box_um, "minimise_overlap")
    rng = _rng(0, _STREAM_MINIMISER) if rng is None else rng
    spec = Trials(trials, size_window, volume_weight)
    cur = dataclasses.replace(deco, rotations=deco.rotations.copy(), scales=deco.scales.copy())
    nominal = deco.scales.copy()
    world = world_grains(cur)
    reach = world.radius * (1.0 + size_window)
    if cell_volume_um3 is None:
        groups = [np.arange(len(cur))]
        lists = [_neighbour_lists(len(cur), pairs_within(cur.centres_um, reach, box, periodic))]
    else:
        groups = om_cells(cur.centres_um, box, periodic, cell_volume_um3)
        lists = [
            _neighbour_lists(len(cur), pairs_within(cur.centres_um, reach, box, periodic, g)) for g in groups
        ]
    local = [_type_points(t, points_per_grain, rng) for t in cur.library]
    bar = Progress("overlap minimiser", total=passes * len(groups)) if progress else None
    for p in range(passes):
        for c, (members, nbrs) in enumerate(zip(groups, lists)):
            for i in rng.permutation(members):
                if len(nbrs[i]):
                    best_pose(
                        cur, world, i, nbrs[i], local[cur.types[i]], nominal[i], spec, box, periodic, rng
                    )
            if bar is not None:
                bar.update(p * len(groups) + c + 1)
    if size_window > 0:
        vol = np.array([t.volume for t in cur.library])[cur.types]
        cur.scales[:] *= (np.sum(vol * nominal**3) / np.sum(vol * cur.scales**3)) ** (1.0 / 3.0)
    return cur


def _trial_poses(deco, i, nominal, spec: Trials, rng) -> tuple[np.ndarray, np.ndarray]:
    """Rotations and scales of the trials: the current pose first."""
    rotations = np.concatenate([deco.rotations[i][None], uniform_rotations(rng, spec.count - 1)])
    scales = np.full(spec.count, deco.scales[i])
    if spec.size_window > 0:
        w = spec.size_window
        scales[1:] = nominal * rng.uniform(1.0 - w, 1.0 + w, spec.count - 1)
    return rotations, scales


def trial_objectives(
    deco, world, i, nb, local, rotations, scales, box, periodic
) -> tuple[np.ndarray, np.ndarray]:
    """Estimated Σ_j |G_i ∩ G_j| (µm³) and the volume |G_i| of grain i in each trial pose (neighbours ``nb``)."""
    d = np.ascontiguousarray(_separation(deco.centres_um, np.full(len(nb), i), nb, box, periodic))
    volume = deco.library[deco.types[i]].volume * scales**3
    hits = np.zeros(len(local), dtype=np.int64)
    overlap = np.empty(len(scales))
    for c, (rot, s) in enumerate(zip(rotations, scales)):
        pts = np.ascontiguousarray(local @ rot.T * s)
        _points_inside_serial(pts, d, world.kind, world.radius, world.plane_ptr, world.planes, nb, hits)
        overlap[c] = hits.sum() / len(local) * volume[c]
    return overlap, volume


def best_pose(deco, world, i, nb, local, nominal, spec: Trials, box, periodic, rng) -> None:
    """Replace grain i's pose (and its world planes) by the trial of least J = overlap − μ·volume."""
    rotations, scales = _trial_poses(deco, i, nominal, spec, rng)
    overlap, volume = trial_objectives(deco, world, i, nb, local, rotations, scales, box, periodic)
    best = int(np.argmin(overlap - spec.volume_weight * volume))
    if best:
        set_pose(deco, world, i, rotations[best], scales[best])


def set_pose(deco, world, i, rotation, scale) -> None:
    """Give grain i a new rotation and scale, in the decoration and in its world geometry."""
    deco.rotations[i] = rotation
    deco.scales[i] = scale
    t = deco.library[deco.types[i]]
    world.radius[i] = t.circumradius * scale
    if t.kind is Kind.POLYHEDRON:
        world.planes[world.plane_ptr[i] : world.plane_ptr[i + 1]] = _grain_planes(t, rotation, scale)
        world.half_um[i] = np.abs(t.vertices @ rotation.T).max(axis=0) * scale * (1 + 1e-12)
    else:
        world.half_um[i] = world.radius[i]
