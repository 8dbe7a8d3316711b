"""Sub-voxel walls: the wall distance q of every boundary link and the interpolated bounce-back coefficients.

A boundary link is population p of fluid node x whose upstream voxel x − c_p is solid. The wall cuts the link at
x − q c_p, q ∈ (0, 1] (halfway bounce-back puts it at q = ½ whatever the geometry). The pulled value is

    f_p(x, t + 1) = a f*_ō(x) + b f*_ō(x + c_p) + c f*_p(x),  a = 1 − b − c   (ō = opposite of p, f* = post-collision)

(weights summing to 1: a uniform state is reflected unchanged) with, for q and the node behind x + c_p fluid,

* ``bfl`` (Bouzidi, Firdaouss & Lallemand 2001, Phys. Fluids 13, 3452, linear): q < ½: (2q, 1 − 2q, 0);
  q ≥ ½: (1/(2q), 0, 1 − 1/(2q)) — convex weights, so no link amplifies a population;
* ``cli`` (Ginzburg, Verhaeghe & d'Humières 2008, Commun. Comput. Phys. 3, 427, "central linear
  interpolation"): (1, κ, −κ), κ = (1 − 2q)/(1 + 2q), one formula for all q;
* ``mr1`` (the same paper's multi-reflection MR1, Eq. 4.1 with Table 3's coefficients and the post-collision
  correction): f_p = h + κ₀ (f*_ō(x + c_p) − f*_p(x)) + κ₋₁ (f*_ō(x + 2c_p) − f*_p(x + c_p)) − α g n⁻_ō(x),
  κ₀ = (1 − 2q − 2q²)/(1 + q)², κ₋₁ = q²/(1 + q)², α = 4/(1 + q)², g = 1 − ω⁻/2 and n⁻_ō(x) the antisymmetric
  non-equilibrium part of the node's pre-collision populations one step earlier (equilibrium of j = Σ c f). Worked
  through for a straight wall with the exact TRT solution of Poiseuille flow (n⁺ = −τ⁺ ∂e⁻, n⁻ = τ⁻(Λ⁺ ∂²e⁻ + F)):
  the residual vanishes for every q and Λ when the measured velocity (j + F/2)/ρ is zero at the wall, so the
  slit's κ̂ is the nodal sum of the parabola itself (tests/hard/test_lbm_hard.py). Needs two fluid
  nodes behind the wall; with one it is ``cli``, with none halfway.

Where the node behind is solid too (a one-voxel gap along the link) ``cli`` falls back to halfway bounce-back;
``bfl`` uses its local branch for q ≥ ½ and halfway bounce-back for q < ½. Both are exact for a linear profile.
``cli`` and ``mr1`` keep halfway bounce-back at nodes with :data:`CROWDED_LINKS` wall links or more (stability).
With TRT, ``cli`` (with halfway fallback) keeps κ̂ τ-independent like halfway bounce-back (sphere array: 1e-5
for τ = 0.6 … 2; tests/validation/test_lbm_spheres.py); ``bfl`` does not (−7 % from τ = 0.6 to 2 at 10 voxels
per diameter), and neither does BFL's local branch inside ``cli`` (0.24 % on a porous sample), hence the
fallback. ``cli`` is the default.

Sources of q, in lattice coordinates (voxel i spans [i, i + 1), its node sits at i + ½):

* :class:`SphereWalls`: exact ray–sphere intersection with the (periodic) spheres, e.g. of ``packing.h5``;
* :class:`GrainWalls`: exact ray–polyhedron (slab clipping against every face plane) and ray–ball intersection with
  the decorated grains of ``grains.h5`` (type planes rotated and scaled per grain, periodic copies);
* :class:`GreyWalls`: from the grey volume's matrix fraction s = g/216 of the two voxels of the link, the level
  s = θ located by linear interpolation, θ the segmentation's boundary (pore if g ≤ g_th: θ = (g_th + ½)/216),
  so that q ∈ (0, 1) is consistent with the binary volume. A first-order estimate of the surface position.

Set-ups: the periodic one's domain is the sample; the mirror set-up's links are folded into the sample
(:class:`MirroredWalls`: a link across a mirror plane is split there and reflected), the chamber set-up's are shifted
past the inlet chamber (:class:`ShiftedWalls`: a chamber node's link into the sample is cut at the sample's face).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.lbm._kernels import _TILE, _ray_grain_fractions, _ray_sphere_fractions
from porepipe.lbm._lattice import OPPOSITE, C
from porepipe.lbm._settings import Walls

#: q is kept at least this far from 0 (a wall through or next to the node itself): links with q → 0 (κ → 1 in CLI,
#: the weight of f*_ō(x + c_p) − f*_p(x) largest) kept the driven flow on the decorated model at 8 µm drifting (κ̂
#: +0.27 % from 20 000 to 150 000 steps, still moving); with q ≥ 0.1 it settles like halfway walls (3e-5 from 30 000
#: to 60 000 steps). Such a wall sits at most 0.1 voxel off; halfway bounce-back there instead moved κ̂ 4.5× further.
Q_MIN = 0.1
#: A node with this many wall links or more (of 18) keeps halfway bounce-back on all of them with ``cli`` and ``mr1``:
#: in crevices one or two voxels wide, links coupled through the node's few fluid neighbours grew a local mode (CLI
#: ×1.01 and MR1 ×1.2 per 2000 steps, force-free, on the decorated fontainebleau-like model at 8 µm, where 31 % of the
#: boundary nodes have ≥ 10 links); with this guard both decay there. Sphere arrays at c = 0.45 have none at 32 voxels
#: per diameter (13 nodes at 16); the touching array has 41-81.
CROWDED_LINKS = 10


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
        """Q of links from node coordinates (K, 3) (integer voxel indices) along −c_p; −1 where no sphere, 0 where
        the node lies in one.
        """
        return self.segment_hits(nodes.astype(np.float64) + 0.5, -C[pops].astype(np.float64))

    def segment_hits(self, points: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """First t ∈ (0, 1] of each segment points + t · dirs (lattice units, |dirs| <= √2) in a sphere; −1 if none."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        dirs = np.ascontiguousarray(dirs, dtype=np.float64)
        box = np.array(self.box, dtype=np.float64)
        reach = float(self.radii.max(initial=0.0)) + np.sqrt(2.0)
        cell_n = np.maximum(1, np.floor(box / reach)).astype(np.int64)
        idx = np.minimum((self.centres / box * cell_n).astype(np.int64), cell_n - 1)
        flat = (idx[:, 0] * cell_n[1] + idx[:, 1]) * cell_n[2] + idx[:, 2]
        order = np.argsort(flat, kind="stable")
        start = np.searchsorted(flat[order], np.arange(int(np.prod(cell_n)) + 1)).astype(np.int64)
        out = np.empty(points.shape[0])
        if points.shape[0] == 0:
            return out
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
class GrainWalls:
    """Decorated grains (balls and convex polyhedra of ``grains.h5``) in lattice units of the sample's voxel grid.

    Every periodic copy of a grain that comes within one voxel of the sample is listed, so a link is tested against
    the copies that can reach it only (a cell list), by exact ray–plane / ray–sphere intersection.

    Attributes
    ----------
    centres : (M, 3) float ndarray
        Centres of the grain copies in voxels, the sample's corner at 0.
    half : (M, 3) float ndarray
        Half-edges (voxels) of a box about each copy's centre that holds the copy.
    grain : (M,) int64 ndarray
        Grain of each copy (row of ``kind``, ``radius``, ``plane_ptr``).
    kind : (N,) int64 ndarray
        0 ball, 1 convex polyhedron.
    radius : (N,) float ndarray
        Ball radius (voxels); for a polyhedron its circumradius.
    plane_ptr : (N + 1,) int64 ndarray
        Planes of grain g are rows ``plane_ptr[g]:plane_ptr[g + 1]`` of ``planes``.
    planes : (P, 4) float ndarray
        Outward unit normal and offset (voxels) of every face plane, n·(y − centre) <= offset.
    """

    centres: np.ndarray
    half: np.ndarray
    grain: np.ndarray
    kind: np.ndarray
    radius: np.ndarray
    plane_ptr: np.ndarray
    planes: np.ndarray

    @classmethod
    def from_decoration(cls, deco, shape, voxel_um: float, origin_um=(0.0, 0.0, 0.0), periodic=(True,) * 3):
        """The grains of a :class:`porepipe.decorate.Decoration` (µm, box corner at ``origin_um``) on a grid of
        ``shape`` voxels of ``voxel_um``; copies across the faces of ``periodic`` axes included.
        """
        from porepipe.decorate import grain_images, world_grains

        world = world_grains(deco)
        box_um = np.asarray(shape, dtype=np.float64) * voxel_um
        centres_um = np.asarray(deco.centres_um, dtype=np.float64) - np.asarray(origin_um, dtype=np.float64)
        # one voxel of margin: a node's link reaches one voxel beyond the sample
        rows, ids = grain_images(centres_um, world.half_um + voxel_um, box_um, any(periodic))
        shift = rows[:, :3] - centres_um[ids]
        own = np.all(np.isclose(shift[:, [not p for p in periodic]], 0.0), axis=1)
        rows, ids = rows[own], ids[own]
        planes = world.planes.copy()
        planes[:, 3] /= voxel_um
        return cls(
            np.ascontiguousarray(rows[:, :3] / voxel_um),
            np.ascontiguousarray(rows[:, 3:] / voxel_um),
            ids.astype(np.int64),
            world.kind.astype(np.int64),
            world.radius / voxel_um,
            world.plane_ptr.astype(np.int64),
            np.ascontiguousarray(planes),
        )

    def permuted(self, order) -> GrainWalls:
        """The same grains with the axes reordered (``order[k]`` = caller's axis that becomes axis k)."""
        order = list(order)
        planes = self.planes.copy()
        planes[:, :3] = self.planes[:, order]
        return dataclasses.replace(
            self,
            centres=np.ascontiguousarray(self.centres[:, order]),
            half=np.ascontiguousarray(self.half[:, order]),
            planes=planes,
        )

    def fractions(self, nodes: np.ndarray, pops: np.ndarray) -> np.ndarray:
        """Q of links from node coordinates (K, 3) (integer voxel indices) along −c_p; −1 where no grain, 0 where
        the node lies in one.
        """
        return self.segment_hits(nodes.astype(np.float64) + 0.5, -C[pops].astype(np.float64))

    def segment_hits(self, points: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """First t ∈ (0, 1] of each segment points + t · dirs (|dirs| per axis <= 1) in a grain; −1 if none."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        dirs = np.ascontiguousarray(dirs, dtype=np.float64)
        out = np.full(points.shape[0], -1.0)
        if points.shape[0] == 0 or self.centres.shape[0] == 0:
            return out
        reach_lo = (
            self.centres - self.half - 1.0
        )  # a segment starting in the box grown by 1 can reach the grain
        reach_hi = self.centres + self.half + 1.0
        lo = points.min(axis=0) - 1.0
        edge = max(2.0, float(np.median(2.0 * self.half.max(axis=1))) + 2.0)
        cell_n = np.maximum(1, np.ceil((points.max(axis=0) + 1.0 - lo) / edge)).astype(np.int64)
        first = np.clip(np.floor((reach_lo - lo) / edge), 0, cell_n - 1).astype(np.int64)
        last = np.clip(np.floor((reach_hi - lo) / edge), 0, cell_n - 1).astype(np.int64)
        inside = np.all((reach_hi >= lo) & (reach_lo <= lo + cell_n * edge), axis=1)
        cells, items = [], []
        for m in np.flatnonzero(inside):
            ranges = [np.arange(first[m, a], last[m, a] + 1) for a in range(3)]
            flat = ((ranges[0][:, None, None] * cell_n[1] + ranges[1][None, :, None]) * cell_n[2]) + ranges[2]
            cells.append(flat.ravel())
            items.append(np.full(flat.size, m, dtype=np.int64))
        cells = np.concatenate(cells) if cells else np.zeros(0, dtype=np.int64)
        items = np.concatenate(items) if items else np.zeros(0, dtype=np.int64)
        order = np.argsort(cells, kind="stable")
        start = np.searchsorted(cells[order], np.arange(int(np.prod(cell_n)) + 1)).astype(np.int64)
        _ray_grain_fractions(
            points,
            dirs,
            self.centres,
            self.grain,
            self.kind,
            self.radius,
            self.plane_ptr,
            self.planes,
            lo,
            edge,
            cell_n,
            start,
            items[order],
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
        """Q of links from node coordinates (K, 3) (integer voxel indices) along −c_p; −1 where no level crossing."""
        return self.pair_fractions(nodes, np.mod(nodes - C[pops], np.array(self.solid.shape)))

    def pair_fractions(self, nodes: np.ndarray, up: np.ndarray) -> np.ndarray:
        """Q between the voxels ``nodes`` (K, 3) (pore) and ``up`` (K, 3) (matrix); −1 where no level crossing."""
        s_x = self.solid[tuple(nodes.T)]
        s_y = self.solid[tuple(up.T)]
        with np.errstate(invalid="ignore", divide="ignore"):
            q = (self.level - s_x) / (s_y - s_x)
        return np.where((s_y > self.level) & (s_x <= self.level) & np.isfinite(q), q, -1.0)


@dataclasses.dataclass(frozen=True)
class ShiftedWalls:
    """A sample geometry seen from a domain whose layer ``offset`` along axis 0 is the sample's layer 0 (the chamber
    set-up: inlet chamber, ``length`` sample layers, outlet chamber; the chambers are open fluid).

    A link from a chamber node into the sample enters the solid no earlier than the sample's face: an exact geometry
    is cut there (the link is split at the face), a grey one puts the wall halfway (the face itself).
    """

    inner: object
    offset: int
    length: int

    def fractions(self, nodes: np.ndarray, pops: np.ndarray) -> np.ndarray:
        local = nodes - np.array([self.offset, 0, 0])
        outside = (local[:, 0] < 0) | (local[:, 0] >= self.length)
        out = np.full(nodes.shape[0], 0.5)
        if np.any(~outside):
            out[~outside] = self.inner.fractions(local[~outside], pops[~outside])
        if np.any(outside) and hasattr(self.inner, "segment_hits"):
            start = local[outside].astype(np.float64) + 0.5
            step = -C[pops[outside]].astype(np.float64)
            face = np.where(start[:, 0] < 0, 0.0, float(self.length))
            t_face = (face - start[:, 0]) / step[
                :, 0
            ]  # a chamber link into the sample crosses its face: c_0 ≠ 0
            rest = self.inner.segment_hits(start + t_face[:, None] * step, (1.0 - t_face)[:, None] * step)
            out[outside] = np.where(rest >= 0, t_face + (1.0 - t_face) * rest, -1.0)  # 0: solid at the face
        return out


def _fold(x0: np.ndarray, length: int) -> tuple[np.ndarray, np.ndarray]:
    """Axis-0 coordinate of the sample + mirror domain (period 2L) folded into the sample [0, L], and the sign of
    the direction there (−1 in a mirror half).
    """
    y = np.mod(x0, 2 * length)
    mirrored = y > length
    return np.where(mirrored, 2 * length - y, y), np.where(mirrored, -1.0, 1.0)


@dataclasses.dataclass(frozen=True)
class MirroredWalls:
    """A sample geometry seen from the mirror set-up's domain (sample, then its mirror image along axis 0, periodic
    over 2L): a link is folded into the sample, and a link that crosses a mirror plane (axis-0 coordinate 0 or L) is
    split there, its second part reflected. Exact geometries (``segment_hits``) give the exact q of the reflected
    wall; grey walls read the two folded voxels of the link.
    """

    inner: object
    length: int

    def fractions(self, nodes: np.ndarray, pops: np.ndarray) -> np.ndarray:
        if not hasattr(self.inner, "segment_hits"):
            up = nodes - C[pops]
            return self.inner.pair_fractions(self._fold_voxels(nodes), self._fold_voxels(up))
        start = nodes.astype(np.float64) + 0.5
        step = -C[pops].astype(np.float64)
        end0 = start[:, 0] + step[:, 0]
        crossing = np.floor(start[:, 0] / self.length) != np.floor(end0 / self.length)
        plane = np.maximum(np.floor(start[:, 0] / self.length), np.floor(end0 / self.length)) * self.length
        t_cross = np.where(crossing, (plane - start[:, 0]) / np.where(step[:, 0] == 0, 1.0, step[:, 0]), 1.0)
        first = self._hits(start, step * t_cross[:, None], start[:, 0])
        out = np.where(
            first > 0, t_cross * first, first
        )  # −1: no hit before the plane; 0: the node is inside
        more = crossing & (out < 0)
        if np.any(more):
            at = start[more] + t_cross[more, None] * step[more]
            rest = (1.0 - t_cross[more])[:, None] * step[more]
            second = self._hits(at, rest, end0[more])
            # second = 0: the solid starts at the mirror plane itself
            out[more] = np.where(second >= 0, t_cross[more] + (1.0 - t_cross[more]) * second, -1.0)
        return out

    def _hits(self, points: np.ndarray, dirs: np.ndarray, side: np.ndarray) -> np.ndarray:
        """Hits of segments that stay on one side of the mirror planes; ``side``: an axis-0 coordinate on it."""
        folded = points.copy()
        folded[:, 0], _ = _fold(points[:, 0], self.length)
        _, sign = _fold(side, self.length)
        reflected = dirs.copy()
        reflected[:, 0] *= sign
        return self.inner.segment_hits(folded, reflected)

    def _fold_voxels(self, index: np.ndarray) -> np.ndarray:
        """Voxel indices of the domain folded into the sample (periodic across the flow)."""
        out = np.mod(index, np.array(self.inner.solid.shape))
        i = np.mod(index[:, 0], 2 * self.length)
        out[:, 0] = np.where(i >= self.length, 2 * self.length - 1 - i, i)
        return out


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
    mr : tuple (far, far_own, d, e)
        Multi-reflection only (else four empty arrays): (K,) int64 flat indices of f*_ō(x + 2c_p) and
        f*_p(x + c_p) in the population array, (K,) float32 weight d of their difference and e of the
        correction g n⁻_ō(x) (g = 1 − ω⁻/2, n⁻ of the previous step's pre-collision populations).
    state : (K,) float64 ndarray
        n⁻_ō(x) of every multi-reflection link, carried from step to step (zero at rest; part of a checkpoint).
    """

    tile_start: np.ndarray
    slot: np.ndarray
    b: np.ndarray
    c: np.ndarray
    n_boundary: int = 0
    mr: tuple = dataclasses.field(default_factory=lambda: _no_mr())
    state: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))

    @classmethod
    def none(cls) -> Links:
        return cls(
            np.zeros(1, dtype=np.int64),
            np.zeros(0, dtype=np.uint16),
            np.zeros(0, dtype=np.float32),
            np.zeros(0, dtype=np.float32),
        )

    @property
    def multi_reflection(self) -> bool:
        return bool(self.mr[0].size)

    @property
    def size(self) -> int:
        return int(self.slot.size)

    def nodes_and_populations(self) -> tuple[np.ndarray, np.ndarray]:
        """(K,) node and (K,) population of every stored link (diagnostics, tests)."""
        tiles = np.repeat(np.arange(self.tile_start.size - 1), np.diff(self.tile_start))
        slot = self.slot.astype(np.int64)
        return tiles * _TILE + slot % _TILE, slot // _TILE


def _no_mr() -> tuple:
    empty = np.zeros(0, dtype=np.int64)
    return empty, empty, np.zeros(0, dtype=np.float32), np.zeros(0, dtype=np.float32)


def coefficients(q: np.ndarray, has_behind: np.ndarray, scheme: Walls, has_far=None) -> np.ndarray:
    """(K, 4) weights (b, c, d, e) for wall distances ``q``: f_p = h + b (f*_ō(x + c_p) − h) + c (f*_p(x) − h)
    + d (f*_ō(x + 2c_p) − f*_p(x + c_p)) + e g n⁻_ō(x), h = f*_ō(x); d = e = 0 but for ``mr1`` links with two
    fluid nodes behind (``has_far``; ``mr1`` falls back to ``cli`` with one, to halfway with none).
    """
    q = np.clip(np.asarray(q, dtype=np.float64), Q_MIN, 1.0)
    coef = np.zeros((q.size, 4))  # halfway bounce-back
    if scheme is Walls.bfl:
        far = q >= 0.5
        coef[far, 1] = 1.0 - 0.5 / q[far]  # local branch (needs no neighbour)
        near = ~far & has_behind
        coef[near, 0] = 1.0 - 2.0 * q[near]
    elif scheme in (Walls.cli, Walls.mr1):
        k = (1.0 - 2.0 * q[has_behind]) / (1.0 + 2.0 * q[has_behind])
        coef[has_behind, 0], coef[has_behind, 1] = k, -k
        if scheme is Walls.mr1:
            two = has_behind & np.asarray(has_far, dtype=bool)
            common = (1.0 + q[two]) ** 2
            kappa0 = (1.0 - 2.0 * q[two] - 2.0 * q[two] ** 2) / common
            coef[two] = np.column_stack([kappa0, -kappa0, q[two] ** 2 / common, -4.0 / common])
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
    halfway) and where binary and geometry disagree: the geometry does not cut the link within (0, 1], or the node
    itself lies in the geometry's solid (a pore voxel of a segmented image whose centre a grain covers: interpolating
    such links with q → 0 made κ̂ drift without converging on a decorated model, 13 % of its links).
    """
    coords, outside = link_geometry(pore, periodic, node, pop)
    q = np.full(node.size, 0.5)
    inner = ~outside
    if np.any(inner):
        got = geometry.fractions(coords[inner], pop[inner])
        q[inner] = np.where(got > 0, got, 0.5)
    return q


def build_links(pore, periodic, node, pop, behind, far, geometry, scheme: Walls) -> Links:
    """Interpolated links of a lattice from its raw wall links (node, pop, behind and far = −1 if solid; by node)."""
    q = link_distances(pore, periodic, node, pop, geometry)
    usable = behind >= 0
    if scheme is not Walls.bfl:  # BFL's convex weights need no guard
        usable &= np.bincount(node, minlength=int(node.max(initial=0)) + 1)[node] < CROWDED_LINKS
    coef = coefficients(q, usable, scheme, far >= 0).astype(np.float32)
    used = np.any(coef != 0, axis=1)
    node, pop, coef, behind, far = node[used], pop[used], coef[used], behind[used], far[used]
    n_nodes = int(np.count_nonzero(pore))
    n_tiles = (n_nodes + _TILE - 1) // _TILE
    tile_start = np.searchsorted(node, np.arange(n_tiles + 1) * _TILE).astype(np.int64)
    slot = (pop * _TILE + node % _TILE).astype(np.uint16)
    mr, state = _no_mr(), np.zeros(0)
    if scheme is Walls.mr1:
        # f*_p(x + c_p): population p of the node behind (behind = ō N + m); links without two nodes behind
        # (d = 0) read the link's own node
        own_behind = np.where(
            behind >= 0, behind - OPPOSITE[pop] * n_nodes + pop * n_nodes, pop * n_nodes + node
        )
        two = far >= 0
        mr = (
            np.where(two, far, own_behind).astype(np.int64),
            own_behind.astype(np.int64),
            np.ascontiguousarray(coef[:, 2]),
            np.ascontiguousarray(coef[:, 3]),
        )
        state = np.zeros(node.size)
    return Links(
        tile_start,
        slot,
        np.ascontiguousarray(coef[:, 0]),
        np.ascontiguousarray(coef[:, 1]),
        int(used.size),
        mr,
        state,
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
    grains=None,
    pore=None,
):
    """The wall geometry of a binary volume from ``packing.h5`` (exact spheres), ``grains.h5`` (exact decorated
    grains) or ``grey_a{a}.h5`` (grey values).

    Parameters
    ----------
    shape : 3 ints
        The binary volume's shape; the grey volume must match it, the packing's spheres are placed on its grid.
    voxel_um, origin_um : float, 3 floats
        Voxel edge and the sample corner (µm) of the binary volume.
    threshold : int
        Segmentation threshold g_th of the binary volume (pore if g ≤ g_th); needed with ``grey``.
    pore : (X, Y, Z) ndarray, optional
        The binary volume (1 = pore); with ``grey``, the grey volume segmented at ``threshold`` must equal it.
    """
    from porepipe._shared.store import read_volume
    from porepipe.voxelize import read_packing_h5

    given = [name for name, v in (("packing", packing), ("grains", grains), ("grey", grey)) if v is not None]
    if len(given) > 1:
        raise PorepipeError(f"give one wall geometry (packing, grains or grey), got {' and '.join(given)}")
    if grains is not None:
        from porepipe.decorate import read_grains

        deco, _ = read_grains(grains)
        return GrainWalls.from_decoration(deco, shape, voxel_um, origin_um, periodic)
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
        if pore is not None:
            _check_grey_segments_to(values, int(threshold), pore, grey)
        return GreyWalls.from_grey(values, int(threshold))
    return None


def _check_grey_segments_to(values: np.ndarray, threshold: int, pore: np.ndarray, grey) -> None:
    """Refuse a grey volume that is not the binary volume's: its walls would lie off the binary's pore voxels."""
    differ = int(np.count_nonzero((values <= threshold) != pore.astype(bool)))
    if differ:
        raise PorepipeError(
            f"grey volume {grey} segmented at the binary volume's threshold {threshold} differs from it in {differ} "
            f"of {values.size} voxels; give the grey volume the binary volume was segmented from"
        )
