"""Decoration of a sphere packing with grain types, and the grey-value voxelisation of the grain model."""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError, cKDTree

from porepipe._shared.errors import PorepipeError
from porepipe._shared.progress import Progress
from porepipe._shared.rng import stream as rng_stream
from porepipe._shared.sample_points import SUB
from porepipe.decorate._kernels import KIND_POLYHEDRON, KIND_SPHERE, _points_inside, _voxelize_grains_slab
from porepipe.decorate._library import (
    GrainType,
    Kind,
    chebyshev_ball,
    quartz_type,
    random_type,
    read_plane_file,
    sphere_type,
)
from porepipe.decorate._settings import Generator, Settings
from porepipe.voxelize import VoxelizeMethod, grid_shape

#: sub-streams of the scene seed
#: sub-streams of the stage's random stream (porepipe._shared.rng, stage name "decorate")
_STREAM_LIBRARY, _STREAM_ASSIGN, _STREAM_ORIENT, _STREAM_MINIMISER = 0, 1, 2, 3


def _rng(seed: int, stream: int) -> np.random.Generator:
    return rng_stream(seed, "decorate", stream)


def _check_box(box_um, what: str, name: str = "box_um") -> np.ndarray:
    """``box_um`` as a float64 (3,) array if it holds 3 positive finite edges, else one line naming the argument."""
    try:
        box = np.asarray(box_um, dtype=np.float64)
    except (TypeError, ValueError):
        box = None
    if box is None or box.shape != (3,) or not np.all(np.isfinite(box)) or np.any(box <= 0):
        raise PorepipeError(f"{what}: {name} must be 3 positive finite edge lengths (µm), got {box_um!r}")
    return box


@dataclasses.dataclass(frozen=True)
class Decoration:
    """Grains on spheres: ``types[i]`` indexes ``library``; grain i is c_i + scales[i] · rotations[i] · (type body).

    Attributes
    ----------
    centres_um : (N, 3) ndarray
    types : (N,) int64 ndarray
    rotations : (N, 3, 3) ndarray
        Local (type) frame -> world frame.
    scales : (N,) ndarray
        Length scale factor (type bodies are at unit scale), in µm per type unit.
    library : list of GrainType
    families : (T,) int64 ndarray
        Family index of each library type.
    """

    centres_um: np.ndarray
    types: np.ndarray
    rotations: np.ndarray
    scales: np.ndarray
    library: list
    families: np.ndarray

    def __len__(self) -> int:
        return len(self.types)

    def volumes_um3(self) -> np.ndarray:
        """Exact volume of every grain."""
        return np.array([t.volume for t in self.library])[self.types] * self.scales**3


# -- library ---------------------------------------------------------------------------------------------------------
def build_library(settings: Settings, seed: int = 0, base_dir=".") -> tuple[list[GrainType], np.ndarray]:
    """Grain types of every family of the scene, and the family index of each type."""
    rng = _rng(seed, _STREAM_LIBRARY)
    library, family_of = [], []
    for f_index, fam in enumerate(settings.families):
        if fam.generator is Generator.sphere:
            types = [sphere_type(fam.name)]
        elif fam.generator is Generator.file:
            path = fam.file if Path(fam.file).is_absolute() else Path(base_dir) / fam.file
            types = read_plane_file(path)
        else:
            types = []
            for t in range(fam.count):
                e = rng.uniform(*fam.elongation)
                name = f"{fam.name}-{t}"
                if fam.generator is Generator.quartz:
                    types.append(quartz_type(name, rng, e, fam.perturbation))
                else:
                    types.append(random_type(name, rng, fam.facets, e, fam.perturbation))
        library += types
        family_of += [f_index] * len(types)
    return library, np.array(family_of, dtype=np.int64)


# -- world geometry --------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class WorldGrains:
    """Flat arrays the kernels read: per grain kind, radius (sphere r or circumradius), planes (n, d) about c."""

    kind: np.ndarray  # (N,) int64
    radius: np.ndarray  # (N,)
    plane_ptr: np.ndarray  # (N + 1,) int64
    planes: np.ndarray  # (P, 4): world normal (3), offset d (µm) relative to the grain centre
    half_um: np.ndarray  # (N, 3) half-edges of a box about the centre that holds the grain

    @property
    def max_planes(self) -> int:
        return int(np.diff(self.plane_ptr).max(initial=0))


def _grain_planes(t: GrainType, rotation, scale) -> np.ndarray:
    return np.column_stack([t.normals @ rotation.T, t.offsets * scale])


def world_grains(deco: Decoration) -> WorldGrains:
    """Rotated, scaled planes and bounding half-edges of every grain."""
    kind = np.array([KIND_SPHERE if t.kind is Kind.SPHERE else KIND_POLYHEDRON for t in deco.library])[
        deco.types
    ]
    circ = np.array([t.circumradius for t in deco.library])[deco.types] * deco.scales
    counts = np.array([t.n_faces for t in deco.library], dtype=np.int64)[deco.types]
    ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    planes = np.zeros((ptr[-1], 4))
    half = np.repeat(circ[:, None], 3, axis=1)
    for g, (t, rot, s) in enumerate(zip((deco.library[k] for k in deco.types), deco.rotations, deco.scales)):
        if t.kind is Kind.POLYHEDRON:
            planes[ptr[g] : ptr[g + 1]] = _grain_planes(t, rot, s)
            half[g] = np.abs(t.vertices @ rot.T).max(axis=0) * s * (1.0 + 1e-12)
    return WorldGrains(kind.astype(np.int64), circ, ptr, np.ascontiguousarray(planes), half)


def grain_images(centres_um, half_um, box_um, periodic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Rows (cx, cy, cz, hx, hy, hz) of every periodic image of every grain box that reaches into the box, and the
    grain index of each row. Without periodicity, the grains themselves (those reaching into the box).
    """
    box = _check_box(box_um, "grain_images")
    c = np.asarray(centres_um, dtype=np.float64)
    if not periodic:
        keep = np.flatnonzero(np.all((c + half_um >= 0) & (c - half_um <= box), axis=1))
        return np.ascontiguousarray(np.column_stack([c[keep], half_um[keep]])), keep.astype(np.int64)
    lo = np.floor(-(c + half_um) / box).astype(np.int64) + 1
    hi = np.floor((box - (c - half_um)) / box).astype(np.int64)
    rows, ids = [], []
    for shift in itertools.product(range(int(lo.min(initial=0)), int(hi.max(initial=0)) + 1), repeat=3):
        s = np.array(shift)
        ok = np.flatnonzero(np.all((s >= lo) & (s <= hi), axis=1))
        if ok.size:
            rows.append(np.column_stack([c[ok] + s * box, half_um[ok]]))
            ids.append(ok)
    if not rows:
        return np.zeros((0, 6)), np.zeros(0, dtype=np.int64)
    return np.ascontiguousarray(np.concatenate(rows)), np.concatenate(ids).astype(np.int64)


# -- voxelisation ----------------------------------------------------------------------------------------------------
def iter_grain_slabs(
    deco: Decoration,
    box_um,
    voxel_um: float,
    periodic: bool = True,
    method: VoxelizeMethod = VoxelizeMethod.boundary,
    slab_planes: int = 32,
    progress: bool = False,
):
    """Yield ``(i0, slab)``: uint8 grey values (sample points in the matrix) of voxel planes ``i0 .. i0 + len(slab)``.

    Same sample points and conventions as :func:`porepipe.voxelize.voxelize` (a grain boundary point is matrix);
    memory stays at one slab.
    """
    shape = grid_shape(_check_box(box_um, "iter_grain_slabs"), voxel_um)
    world = world_grains(deco)
    img_pos, img_grain = grain_images(deco.centres_um, world.half_um, box_um, periodic)
    xmin = img_pos[:, 0] - img_pos[:, 3]
    order = np.argsort(xmin, kind="stable").astype(np.int64)
    xmin_sorted = np.ascontiguousarray(xmin[order])
    hx_max = float(img_pos[:, 3].max()) if len(img_pos) else 0.0
    boundary_only = VoxelizeMethod(method) is VoxelizeMethod.boundary
    h = voxel_um / SUB
    bar = Progress(f"voxelize grains a={voxel_um:g}um", total=shape[0]) if progress else None
    for i0 in range(0, shape[0], slab_planes):
        i1 = min(i0 + slab_planes, shape[0])
        slab = np.zeros((i1 - i0, shape[1], shape[2]), dtype=np.uint8)
        if len(img_pos):
            _voxelize_grains_slab(
                i0,
                i1,
                img_pos,
                img_grain,
                order,
                xmin_sorted,
                hx_max,
                world.kind,
                world.radius,
                world.plane_ptr,
                world.planes,
                world.max_planes,
                h,
                shape[1],
                shape[2],
                boundary_only,
                slab,
            )
        if bar is not None:
            bar.update(i1)
        yield i0, slab


def voxelize_grains(
    deco: Decoration,
    box_um,
    voxel_um: float,
    periodic: bool = True,
    method: VoxelizeMethod = VoxelizeMethod.boundary,
) -> np.ndarray:
    """Grey values (nx, ny, nz) uint8 0..216 of the union of the decorated grains (see :func:`iter_grain_slabs`)."""
    shape = grid_shape(_check_box(box_um, "voxelize_grains"), voxel_um)
    out = np.empty(shape, dtype=np.uint8)
    for i0, slab in iter_grain_slabs(deco, box_um, voxel_um, periodic, method, slab_planes=shape[0]):
        out[i0 : i0 + len(slab)] = slab
    return out


def points_in_grains(points_um, deco: Decoration, box_um, periodic: bool = True) -> np.ndarray:
    """Boolean (M,): is each point in the union of the grains (the continuum model)? For Monte Carlo checks."""
    pts = np.ascontiguousarray(points_um, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise PorepipeError(
            f"points_in_grains: points need shape (M, 3) and finite values, got shape {pts.shape}"
        )
    box = _check_box(box_um, "points_in_grains")
    world = world_grains(deco)
    img_pos, img_grain = grain_images(deco.centres_um, world.half_um, box, periodic)
    hits = np.zeros(len(pts), dtype=np.int64)
    if len(img_pos):
        _points_inside(
            pts,
            np.ascontiguousarray(img_pos[:, :3]),
            world.kind,
            world.radius,
            world.plane_ptr,
            world.planes,
            img_grain,
            hits,
        )
    return hits > 0


# -- overlap ---------------------------------------------------------------------------------------------------------
def _wrap(centres, box, periodic):
    return np.mod(centres, box) if periodic else centres


def neighbour_pairs(deco: Decoration, box_um, periodic: bool = True) -> np.ndarray:
    """(K, 2) pairs i < j whose circumscribed spheres overlap (nearest periodic image)."""
    box = _check_box(box_um, "neighbour_pairs")
    circ = np.array([t.circumradius for t in deco.library])[deco.types] * deco.scales
    return pairs_within(deco.centres_um, circ, box, periodic)


def pairs_within(centres, reach, box, periodic: bool, subset=None) -> np.ndarray:
    """(K, 2) index pairs (into ``centres``) of grains closer than reach_i + reach_j (nearest periodic image).

    ``subset`` restricts the search to those grain indices (a cell); pairs are returned in global indices.
    """
    idx = np.arange(len(centres)) if subset is None else np.asarray(subset, dtype=np.int64)
    if len(idx) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    pts = _wrap(centres[idx], box, periodic)
    tree = cKDTree(pts, boxsize=box if periodic else None)
    cand = tree.query_pairs(2.0 * float(reach[idx].max()), output_type="ndarray")
    if len(cand) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    i, j = idx[cand[:, 0]], idx[cand[:, 1]]
    d = np.linalg.norm(_separation(centres, i, j, box, periodic), axis=1)
    keep = d < reach[i] + reach[j]
    return np.column_stack([i[keep], j[keep]]).astype(np.int64)


def _separation(centres, i, j, box, periodic):
    """c_j - c_i to the nearest image."""
    d = centres[j] - centres[i]
    return d - box * np.round(d / box) if periodic else d


def _halfspaces(deco, g, shift):
    t = deco.library[deco.types[g]]
    if t.kind is Kind.SPHERE:
        raise PorepipeError("exact overlap volumes need polyhedral grains (sphere grain found)")
    planes = _grain_planes(t, deco.rotations[g], deco.scales[g])
    return planes[:, :3], planes[:, 3] + planes[:, :3] @ shift


def pair_overlap_volume(deco: Decoration, i: int, j: int, box_um, periodic: bool = True) -> float:
    """Exact volume of grain i ∩ grain j (nearest image of j), by vertex enumeration of the joint half-spaces."""
    if not (0 <= i < len(deco) and 0 <= j < len(deco)):
        raise PorepipeError(f"pair_overlap_volume: grains i = {i}, j = {j}; allowed: 0..{len(deco) - 1}")
    box = _check_box(box_um, "pair_overlap_volume")
    d = _separation(deco.centres_um, np.array([i]), np.array([j]), box, periodic)[0]
    ni, oi = _halfspaces(deco, i, np.zeros(3))
    nj, oj = _halfspaces(deco, j, d)
    normals, offsets = np.vstack([ni, nj]), np.concatenate([oi, oj])
    try:
        centre, radius = chebyshev_ball(f"overlap {i}-{j}", normals, offsets)
    except PorepipeError:
        return 0.0  # empty (or flat) intersection
    if radius < 1e-9 * deco.scales[i]:
        return 0.0
    try:
        verts = HalfspaceIntersection(np.column_stack([normals, -offsets]), centre).intersections
        return float(ConvexHull(verts).volume)
    except QhullError:
        return 0.0


def mean_overlap_volume(deco: Decoration, box_um, periodic: bool = True) -> float:
    """Σ_{pairs} |G_i ∩ G_j| / N: mean exact pairwise overlap volume per grain (µm³)."""
    box = _check_box(box_um, "mean_overlap_volume")
    pairs = neighbour_pairs(deco, box, periodic)
    total = sum(pair_overlap_volume(deco, int(i), int(j), box, periodic) for i, j in pairs)
    return total / max(len(deco), 1)


def _type_points(t: GrainType, n: int, rng) -> np.ndarray:
    """N points uniform in the unit-scale body of type t (rejection from its bounding box)."""
    if t.kind is Kind.SPHERE:
        v = rng.normal(size=(n, 3))
        return v / np.linalg.norm(v, axis=1)[:, None] * rng.uniform(size=(n, 1)) ** (1.0 / 3.0)
    lo, hi = t.vertices.min(axis=0), t.vertices.max(axis=0)
    out = np.zeros((0, 3))
    while len(out) < n:
        p = rng.uniform(lo, hi, size=(4 * n, 3))
        out = np.vstack([out, p[np.all(p @ t.normals.T <= t.offsets, axis=1)]])
    return out[:n]
