"""Sub-voxel walls: the wall distance q of every boundary link and the interpolated bounce-back coefficients.

A boundary link is population p of fluid node x whose upstream voxel x − c_p is solid. The wall cuts the link at
x − q c_p, q ∈ (0, 1] (halfway bounce-back puts it at q = ½ whatever the geometry). The pulled value is

    f_p(x, t + 1) = a f*_ō(x) + b f*_ō(x + c_p) + c f*_p(x),  a = 1 − b − c   (ō = opposite of p, f* = post-collision)

(weights summing to 1: a uniform state is reflected unchanged) with, for q and the node behind x + c_p fluid,

* ``bfl`` (Bouzidi, Firdaouss & Lallemand 2001, Phys. Fluids 13, 3452, linear): q < ½: (2q, 1 − 2q, 0);
  q ≥ ½: (1/(2q), 0, 1 − 1/(2q)) — convex weights, so no link amplifies a population;
* ``cli`` (Ginzburg, Verhaeghe & d'Humières 2008, Commun. Comput. Phys. 3, 427, "central linear
  interpolation"): (1, κ, −κ), κ = (1 − 2q)/(1 + 2q), one formula for all q.

Where the node behind is solid too (a one-voxel gap along the link) ``cli`` falls back to halfway bounce-back;
``bfl`` uses its local branch for q ≥ ½ and halfway bounce-back for q < ½. Both are exact for a linear profile.
With TRT, ``cli`` (with halfway fallback) keeps κ̂ τ-independent like halfway bounce-back (sphere array: 1e-5
for τ = 0.6 … 2; tests/validation/test_lbm_spheres.py); ``bfl`` does not (−7 % from τ = 0.6 to 2 at 10 voxels
per diameter), and neither does BFL's local branch inside ``cli`` (0.24 % on a porous sample), hence the
fallback. ``cli`` is the default.

Sources of q, in lattice coordinates (voxel i spans [i, i + 1), its node sits at i + ½):

* :class:`SphereWalls`: exact ray–sphere intersection with the (periodic) spheres, e.g. of ``packing.h5``;
* :class:`GreyWalls`: from the grey volume's matrix fraction s = g/216 of the two voxels of the link, the level
  s = θ located by linear interpolation, θ the segmentation's boundary (pore if g ≤ g_th: θ = (g_th + ½)/216),
  so that q ∈ (0, 1) is consistent with the binary volume. A first-order estimate of the surface position.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.lbm._kernels import _TILE, _ray_sphere_fractions
from porepipe.lbm._lattice import C
from porepipe.lbm._settings import Walls

#: q is kept at least this far from 0 (a wall through the node itself).
Q_MIN = 1e-6


@dataclasses.dataclass(frozen=True)
class SphereWalls:
    """Spheres in lattice units of the sample's voxel grid (caller's axis order).

    Attributes
    ----------
    centres : (S, 3) float ndarray
        Centres in voxels, the sample's corner at 0 (voxel i spans [i, i + 1)).
    radii : (S,) float ndarray
        Radii in voxels.
    box : (3,) float
        Period of each axis in voxels (the sample's shape for a periodic packing).
    periodic : (3,) bool
        Which axes carry periodic images.
    """

    centres: np.ndarray
    radii: np.ndarray
    box: tuple[float, float, float]
    periodic: tuple[bool, bool, bool] = (True, True, True)

    @classmethod
    def from_packing(cls, centres_um, radii_um, voxel_um: float, shape, periodic=(True, True, True)):
        """Spheres given in µm with the sample's corner at the origin (``packing.h5``) on a grid of ``voxel_um``."""
        centres = np.asarray(centres_um, dtype=np.float64) / voxel_um
        radii = np.asarray(radii_um, dtype=np.float64) / voxel_um
        if centres.ndim != 2 or centres.shape[1] != 3 or radii.shape != (centres.shape[0],):
            raise PorepipeError(
                f"spheres: centres must be (S, 3) and radii (S,), got {centres.shape}, {radii.shape}"
            )
        box = tuple(float(s) for s in shape)
        return cls(np.mod(centres, box), radii, box, tuple(bool(p) for p in periodic))

    def permuted(self, order) -> SphereWalls:
        """The same spheres with the axes reordered (``order[k]`` = caller's axis that becomes axis k)."""
        order = list(order)
        return SphereWalls(
            np.ascontiguousarray(self.centres[:, order]),
            self.radii,
            tuple(self.box[k] for k in order),
            tuple(self.periodic[k] for k in order),
        )

    def fractions(self, nodes: np.ndarray, pops: np.ndarray) -> np.ndarray:
        """Q of links from node coordinates (K, 3) (integer voxel indices) along −c_p; −1 where no sphere."""
        points = nodes.astype(np.float64) + 0.5
        dirs = -C[pops].astype(np.float64)
        box = np.array(self.box, dtype=np.float64)
        reach = float(self.radii.max(initial=0.0)) + np.sqrt(2.0)
        cell_n = np.maximum(1, np.floor(box / reach)).astype(np.int64)
        idx = np.minimum((self.centres / box * cell_n).astype(np.int64), cell_n - 1)
        flat = (idx[:, 0] * cell_n[1] + idx[:, 1]) * cell_n[2] + idx[:, 2]
        order = np.argsort(flat, kind="stable")
        start = np.searchsorted(flat[order], np.arange(int(np.prod(cell_n)) + 1)).astype(np.int64)
        out = np.empty(points.shape[0])
        _ray_sphere_fractions(
            points,
            dirs,
            self.centres,
            self.radii,
            box,
            np.array(self.periodic),
            cell_n,
            start,
            order.astype(np.int64),
            out,
        )
        return out


@dataclasses.dataclass(frozen=True)
class GreyWalls:
    """Wall position from a grey volume of matrix fractions (caller's axis order).

    Attributes
    ----------
    solid : (X, Y, Z) float ndarray
        Matrix fraction of every voxel, s = g/216 for the pipeline's grey volumes.
    level : float
        Fraction at which the surface lies; must separate the binary volume's pore (s ≤ level) from matrix.
    """

    solid: np.ndarray
    level: float = 0.5

    @classmethod
    def from_grey(cls, grey, threshold: int, levels: int = 216) -> GreyWalls:
        """Grey values 0..``levels`` segmented as pore if g ≤ ``threshold``."""
        return cls(np.asarray(grey, dtype=np.float64) / levels, (threshold + 0.5) / levels)

    def permuted(self, order) -> GreyWalls:
        return GreyWalls(np.ascontiguousarray(np.transpose(self.solid, list(order))), self.level)

    def fractions(self, nodes: np.ndarray, pops: np.ndarray) -> np.ndarray:
        shape = np.array(self.solid.shape)
        up = np.mod(nodes - C[pops], shape)
        s_x = self.solid[tuple(nodes.T)]
        s_y = self.solid[tuple(up.T)]
        with np.errstate(invalid="ignore", divide="ignore"):
            q = (self.level - s_x) / (s_y - s_x)
        return np.where((s_y > self.level) & (s_x <= self.level) & np.isfinite(q), q, -1.0)


@dataclasses.dataclass
class Links:
    """Interpolated boundary links of one lattice in the step kernel's layout (links with b = c = 0 — halfway
    bounce-back — are left out).

    Attributes
    ----------
    tile_start : (T + 1,) int64 ndarray
        Links of tile t (nodes t·_TILE … (t + 1)·_TILE − 1) are ``tile_start[t]:tile_start[t + 1]``.
    slot : (K,) uint16 ndarray
        p · _TILE + (node − t·_TILE): population and node of the link in the tile scratch.
    b, c : (K,) float32 ndarrays
        Weights of f*_ō(x + c_p) − h and f*_p(x) − h, h = f*_ō(x) the halfway value (a = 1 − b − c).
    n_boundary : int
        All boundary links of the lattice, interpolated or not.
    """

    tile_start: np.ndarray
    slot: np.ndarray
    b: np.ndarray
    c: np.ndarray
    n_boundary: int = 0

    @classmethod
    def none(cls) -> Links:
        return cls(
            np.zeros(1, dtype=np.int64),
            np.zeros(0, dtype=np.uint16),
            np.zeros(0, dtype=np.float32),
            np.zeros(0, dtype=np.float32),
        )

    @property
    def size(self) -> int:
        return int(self.slot.size)

    def nodes_and_populations(self) -> tuple[np.ndarray, np.ndarray]:
        """(K,) node and (K,) population of every stored link (diagnostics, tests)."""
        tiles = np.repeat(np.arange(self.tile_start.size - 1), np.diff(self.tile_start))
        slot = self.slot.astype(np.int64)
        return tiles * _TILE + slot % _TILE, slot // _TILE


def coefficients(q: np.ndarray, has_behind: np.ndarray, scheme: Walls) -> np.ndarray:
    """(K, 2) weights (b, c) for wall distances ``q``: f_p = h + b (f*_ō(x + c_p) − h) + c (f*_p(x) − h)."""
    q = np.clip(np.asarray(q, dtype=np.float64), Q_MIN, 1.0)
    coef = np.zeros((q.size, 2))  # halfway bounce-back
    if scheme is Walls.bfl:
        far = q >= 0.5
        coef[far, 1] = 1.0 - 0.5 / q[far]  # local branch (needs no neighbour)
        near = ~far & has_behind
        coef[near, 0] = 1.0 - 2.0 * q[near]
    elif scheme is Walls.cli:
        k = (1.0 - 2.0 * q[has_behind]) / (1.0 + 2.0 * q[has_behind])
        coef[has_behind] = np.column_stack([k, -k])
    else:
        raise PorepipeError(f"walls={scheme.value!r} has no interpolation coefficients")
    return coef


def link_geometry(pore: np.ndarray, periodic, node: np.ndarray, pop: np.ndarray):
    """(K, 3) voxel indices of the links' nodes and (K,) bool: the upstream voxel lies outside a non-periodic face."""
    coords = np.argwhere(pore)[node]
    up = coords - C[pop]
    shape = np.array(pore.shape)
    outside = np.zeros(node.size, dtype=bool)
    for k in range(3):
        if not periodic[k]:
            outside |= (up[:, k] < 0) | (up[:, k] >= shape[k])
    return coords, outside


def link_distances(pore, periodic, node, pop, geometry) -> np.ndarray:
    """(K,) wall distance q of raw wall links; ½ across a non-periodic lattice face (lateral walls, exactly
    halfway) and where the geometry does not cut the link within (0, 1] (binary and geometry disagree there).
    """
    coords, outside = link_geometry(pore, periodic, node, pop)
    q = np.full(node.size, 0.5)
    inner = ~outside
    if np.any(inner):
        got = geometry.fractions(coords[inner], pop[inner])
        q[inner] = np.where(got > 0, got, 0.5)
    return q


def build_links(pore, periodic, node, pop, behind, geometry, scheme: Walls) -> Links:
    """Interpolated links of a lattice from its raw wall links (node, pop, behind = −1 if solid; by node)."""
    q = link_distances(pore, periodic, node, pop, geometry)
    coef = coefficients(q, behind >= 0, scheme).astype(np.float32)
    used = (coef[:, 0] != 0) | (coef[:, 1] != 0)
    node, pop, coef = node[used], pop[used], coef[used]
    n_nodes = int(np.count_nonzero(pore))
    n_tiles = (n_nodes + _TILE - 1) // _TILE
    tile_start = np.searchsorted(node, np.arange(n_tiles + 1) * _TILE).astype(np.int64)
    slot = (pop * _TILE + node % _TILE).astype(np.uint16)
    return Links(
        tile_start, slot, np.ascontiguousarray(coef[:, 0]), np.ascontiguousarray(coef[:, 1]), int(used.size)
    )


def geometry_from_files(
    shape,
    voxel_um: float,
    origin_um=(0.0, 0.0, 0.0),
    *,
    packing=None,
    grey=None,
    threshold: int | None = None,
    periodic=(True, True, True),
):
    """The wall geometry of a binary volume from ``packing.h5`` (exact spheres) or ``grey_a{a}.h5`` (grey values).

    Parameters
    ----------
    shape : 3 ints
        The binary volume's shape; the grey volume must match it, the packing's spheres are placed on its grid.
    voxel_um, origin_um : float, 3 floats
        Voxel edge and the sample corner (µm) of the binary volume.
    threshold : int
        Segmentation threshold g_th of the binary volume (pore if g ≤ g_th); needed with ``grey``.
    """
    from porepipe._shared.store import read_volume
    from porepipe.voxelize import read_packing_h5

    if packing is not None and grey is not None:
        raise PorepipeError("give either a packing file or a grey volume for the wall geometry, not both")
    if packing is not None:
        centres, radii = read_packing_h5(packing)
        return SphereWalls.from_packing(
            np.asarray(centres) - np.asarray(origin_um, dtype=float), radii, voxel_um, shape, periodic
        )
    if grey is not None:
        if threshold is None:
            raise PorepipeError(
                f"grey wall geometry from {grey} needs the binary volume's `threshold` attribute"
            )
        values, _ = read_volume(grey, "grey")
        if values.shape != tuple(shape):
            raise PorepipeError(
                f"grey volume {grey} has shape {values.shape}, the binary volume {tuple(shape)}"
            )
        return GreyWalls.from_grey(values, int(threshold))
    return None
