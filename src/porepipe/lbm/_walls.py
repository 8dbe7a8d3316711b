"""Sub-voxel walls: the wall distance q of every boundary link and the interpolated bounce-back coefficients.

A boundary link is population p of fluid node x whose upstream voxel x − c_p is solid. The wall cuts the link at
x − q c_p, q ∈ (0, 1] (halfway bounce-back puts it at q = ½ whatever the geometry). The pulled value is

    f_p(x, t + 1) = a f*_ō(x) + b f*_ō(x + c_p) + c f*_p(x)        (ō = opposite of p, f* = post-collision)

with, for q and the node behind x + c_p fluid,

* ``bfl`` (Bouzidi, Firdaouss & Lallemand 2001, Phys. Fluids 13, 3452, linear): q < ½: (2q, 1 − 2q, 0);
  q ≥ ½: (1/(2q), 0, 1 − 1/(2q)) — convex weights, so no link amplifies a population;
* ``cli`` (Ginzburg, Verhaeghe & d'Humières 2008, Commun. Comput. Phys. 3, 427, "central linear
  interpolation"): (1, κ, −κ), κ = (1 − 2q)/(1 + 2q), one formula for all q.

Where the node behind is solid too (a one-voxel gap along the link) both fall back to the local BFL branch for
q ≥ ½ and to halfway bounce-back for q < ½ (no neighbour to interpolate with). Both are exact for a linear
profile at any q; with TRT their steady solution depends on τ only through Λ (measured, tests/validation).

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
from porepipe.lbm._kernels import _ray_sphere_fractions
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
        """q of links from node coordinates (K, 3) (integer voxel indices) along −c_p; −1 where no sphere."""
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
    """Interpolated boundary links of one lattice, sorted by node (inputs of the step kernel)."""

    node: np.ndarray  # (K,) int64
    pop: np.ndarray  # (K,) int64
    behind: np.ndarray  # (K,) int64 flat index of f*_ō(x + c_p) (any valid index where its weight is 0)
    coef: np.ndarray  # (K, 3) float64 (a, b, c)
    q: np.ndarray  # (K,) float64 wall distance used

    @classmethod
    def none(cls) -> Links:
        e = np.zeros(0, dtype=np.int64)
        return cls(e, e, e, np.zeros((0, 3)), np.zeros(0))

    @property
    def size(self) -> int:
        return int(self.node.size)


def coefficients(q: np.ndarray, has_behind: np.ndarray, scheme: Walls) -> np.ndarray:
    """(K, 3) weights (a, b, c) of :data:`f*_ō(x)`, f*_ō(x + c_p), f*_p(x) for wall distances ``q``."""
    q = np.clip(np.asarray(q, dtype=np.float64), Q_MIN, 1.0)
    coef = np.zeros((q.size, 3))
    coef[:, 0] = 1.0  # halfway bounce-back
    far = q >= 0.5
    coef[far, 0] = 0.5 / q[far]  # local branch (needs no neighbour)
    coef[far, 2] = 1.0 - 0.5 / q[far]
    if scheme is Walls.bfl:
        near = ~far & has_behind
        coef[near, 0] = 2.0 * q[near]
        coef[near, 1] = 1.0 - 2.0 * q[near]
    elif scheme is Walls.cli:
        k = (1.0 - 2.0 * q[has_behind]) / (1.0 + 2.0 * q[has_behind])
        coef[has_behind] = np.column_stack([np.ones_like(k), k, -k])
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


def build_links(pore, periodic, node, pop, behind, geometry, scheme: Walls) -> Links:
    """Interpolated links of a lattice from its raw wall links (node, pop, behind = −1 if solid) and a geometry.

    Links across a non-periodic lattice face (lateral walls, exactly halfway) and links the geometry does not cut
    within (0, 1] (binary and geometry disagree there) keep q = ½.
    """
    coords, outside = link_geometry(pore, periodic, node, pop)
    q = np.full(node.size, 0.5)
    inner = ~outside
    if np.any(inner):
        got = geometry.fractions(coords[inner], pop[inner])
        q[inner] = np.where(got > 0, got, 0.5)
    has_behind = behind >= 0
    coef = coefficients(q, has_behind, scheme)
    n_nodes = int(np.count_nonzero(pore))
    safe_behind = np.where(has_behind, behind, pop * n_nodes + node)
    return Links(node.astype(np.int64), pop.astype(np.int64), safe_behind.astype(np.int64), coef, q)


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
