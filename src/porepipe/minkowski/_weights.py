"""Weight tables that turn a 2x2x2 configuration histogram into V, S, ∫H and χ.

Conventions
-----------
Cell code bit ``b = dx + 2*dy + 4*dz`` is voxel (i+dx, j+dy, k+dz) of the cell (see ``_kernels``). Every table is
an integer array over the 256 codes with a stated denominator, so that the sums over a histogram are exact int64
arithmetic and the identities between the two phases hold bit for bit:

- volume: number of foreground vertices, denominator 8 (each voxel is a vertex of 8 cells);
- transitions (13 line directions): foreground/background pairs along the direction, denominator 4;
- section Euler numbers (13 plane families): local Euler contribution of the cell's planar sections, denominator 24;
- Euler number: local Euler contribution of the cell, denominator 8.

Adjacency
---------
The 6-adjacent phase is reconstructed as the cubical complex K6 (a vertex, edge, face or cube of the lattice belongs
to it when all its voxels are foreground); its Euler number is counted with fractional weights (a k-cell shared by
m cells of the 2x2x2 tiling counts 1/m in each).
The Euler number of a planar section is that of the section's own lattice complex (its lattice points, the polygon
edges with both ends foreground, the polygons with all corners foreground): 4-adjacency on the square and
rectangular section lattices, 6-adjacency on the triangular ones (space-diagonal normals). The 26-adjacent phase
gets the complementary (dual) tables, ``w26(c) = w6(~c)`` in 3-D and ``e26(c) = -e6(~c)`` in the sections (8-
adjacency on squares and rectangles; the triangular complex is self-dual), which is the digital form of Alexander
duality on the torus: χ26(X) = χ6(Xᶜ) in 3-D and χ8(X ∩ E) = -χ4(Xᶜ ∩ E) in a plane E. This is why the Euler
number of a discretised set is consistent only for a complementary pair of adjacencies (Ohser, Nagel & Schladitz
2003, Image Anal. Stereol. 22:11-19; Ohser & Mücklich 2000, Statistical Analysis of Microstructures in Materials
Science, §4.2). For a body surrounded by background in a non-periodic window both tables give its exact Euler
number.

Surface area and integral of mean curvature follow from the Crofton formulae over the 13 lattice directions
(Schladitz, Ohser & Nagel 2006, DGCI, LNCS 4245:247-258):
``S_V = 2 Σ_i γ_i P_L(i)`` (boundary points per unit length of lines in direction i) and
``M_V = 2π Σ_j γ'_j χ_A(j)`` (Euler number per unit area of sections with normal j); γ, γ' are the solid-angle
fractions of the spherical Voronoi cells of the ±directions / ±normals, computed for the actual voxel edge lengths.
The surface estimator counts plain transitions and so does not depend on the adjacency.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np
from scipy.spatial import SphericalVoronoi

from porepipe._shared.units import from_voxel_units

N_CODES = 256
VOLUME_DENOMINATOR = 8
TRANSITION_DENOMINATOR = 4
SECTION_DENOMINATOR = 24
EULER_DENOMINATOR = 8

#: vertex offsets (dx, dy, dz) of bit b
VERTICES = np.array([(b & 1, (b >> 1) & 1, (b >> 2) & 1) for b in range(8)], dtype=np.int64)
#: foreground flag of vertex b in code c, shape (256, 8)
_FG = ((np.arange(N_CODES)[:, None] >> np.arange(8)[None, :]) & 1).astype(np.int64)


def complement(codes: np.ndarray) -> np.ndarray:
    """Code of the complementary configuration (all 8 bits flipped)."""
    return 255 - codes


# -- line directions and plane families (index space) ----------------------------------------------------------------
#: the 13 lattice directions of the 2x2x2 cell: 3 axes, 6 face diagonals, 4 space diagonals
DIRECTIONS = np.array(
    [
        (1, 0, 0),
        (0, 1, 0),
        (0, 0, 1),
        (1, 1, 0),
        (1, -1, 0),
        (1, 0, 1),
        (1, 0, -1),
        (0, 1, 1),
        (0, 1, -1),
        (1, 1, 1),
        (1, 1, -1),
        (1, -1, 1),
        (-1, 1, 1),
    ],
    dtype=np.int64,
)


def _segments(direction: np.ndarray) -> tuple[list[tuple[int, int]], int]:
    """Vertex pairs (u, v) of the cell with v - u = ±direction, and how many cells share each such segment."""
    pairs = [
        (u, v) for u in range(8) for v in range(8) if np.array_equal(VERTICES[v] - VERTICES[u], direction)
    ]
    share = 2 ** int(np.sum(direction == 0))
    return pairs, share


@functools.cache
def transition_table() -> np.ndarray:
    """(13, 256) int64: per direction, foreground/background transitions in a cell × 4 (denominator 4)."""
    table = np.zeros((len(DIRECTIONS), N_CODES), dtype=np.int64)
    for i, d in enumerate(DIRECTIONS):
        pairs, share = _segments(d)
        for u, v in pairs:
            table[i] += (_FG[:, u] != _FG[:, v]) * (TRANSITION_DENOMINATOR // share)
    return table


def _in_complex(vertex_set: list[int]) -> np.ndarray:
    """(256,) 0/1: the cell of K6 spanned by ``vertex_set`` is present (all its vertices foreground)."""
    return np.all(_FG[:, vertex_set] == 1, axis=1).astype(np.int64)


def _section_polygons(normal: np.ndarray) -> tuple[list[list[int]], int]:
    """Planar sections of the cell by lattice planes of ``normal`` that this cell owns, and their sharing factor.

    For an axis normal the sections are the two faces of the cube, each shared with the neighbour (factor 2); for
    diagonal normals they are the cube's sections by the planes strictly between its extreme vertices (a rectangle
    or two triangles), owned by this cell alone (factor 1). Polygon vertices are returned in boundary order.
    """
    level = VERTICES @ normal
    if np.count_nonzero(normal) == 1:
        planes, share = [level.min(), level.max()], 2
    else:
        planes, share = list(range(level.min() + 1, level.max())), 1
    polygons = []
    for m in planes:
        members = [b for b in range(8) if level[b] == m]
        centre = VERTICES[members].mean(axis=0)
        # order by angle in the plane: project onto two in-plane axes
        e1 = VERTICES[members[0]] - centre
        e2 = np.cross(normal, e1)
        angle = [np.arctan2((VERTICES[b] - centre) @ e2, (VERTICES[b] - centre) @ e1) for b in members]
        polygons.append([members[t] for t in np.argsort(angle)])
    return polygons, share


@functools.cache
def _section_euler6() -> np.ndarray:
    """(13, 256) int64: Euler contribution × 24 of the cell's planar sections (4-/6-adjacency) per plane family."""
    table = np.zeros((len(DIRECTIONS), N_CODES), dtype=np.int64)
    for j, normal in enumerate(DIRECTIONS):
        polygons, share = _section_polygons(normal)
        for poly in polygons:
            around_vertex = 4 if len(poly) == 4 else 6  # polygons meeting at a vertex of the section lattice
            for b in poly:
                table[j] += _FG[:, b] * (SECTION_DENOMINATOR // (share * around_vertex))
            for u, v in zip(poly, poly[1:] + poly[:1]):
                table[j] -= _in_complex([u, v]) * (SECTION_DENOMINATOR // (share * 2))
            table[j] += _in_complex(poly) * (SECTION_DENOMINATOR // share)
    return table


@functools.cache
def _euler6() -> np.ndarray:
    """(256,) int64: Euler contribution × 8 of the cell to the cubical complex K6."""
    table = _FG.sum(axis=1).copy()  # vertices, shared by 8 cells
    for u, v in itertools.combinations(range(8), 2):
        diff = np.abs(VERTICES[u] - VERTICES[v]).sum()
        if diff == 1:  # 12 edges, shared by 4 cells
            table -= 2 * _FG[:, u] * _FG[:, v]
    for axis in range(3):
        for side in (0, 1):  # 6 faces, shared by 2 cells
            face = [b for b in range(8) if VERTICES[b][axis] == side]
            table += 4 * _in_complex(face)
    table -= 8 * _in_complex(list(range(8)))  # the cube itself
    return table


def euler_table(adjacency: int) -> np.ndarray:
    """(256,) int64 Euler weights × 8 for a foreground of ``adjacency`` 6 or 26."""
    if adjacency == 6:
        return _euler6()
    return _euler6()[complement(np.arange(N_CODES))]


def section_euler_table(adjacency: int) -> np.ndarray:
    """(13, 256) int64 section Euler weights × 24 for a foreground of ``adjacency`` 6 or 26."""
    if adjacency == 6:
        return _section_euler6()
    return -_section_euler6()[:, complement(np.arange(N_CODES))]


def volume_table() -> np.ndarray:
    """(256,) int64: foreground vertices of each code (denominator 8)."""
    return _FG.sum(axis=1)


# -- geometry: direction weights for the actual voxel size ---------------------------------------------------------
def _voronoi_weights(vectors: np.ndarray) -> np.ndarray:
    """Solid-angle fraction of the spherical Voronoi cells of ±vectors, summed per ± pair."""
    unit = vectors / np.linalg.norm(vectors, axis=1)[:, None]
    points = np.concatenate([unit, -unit])
    sv = SphericalVoronoi(points, radius=1.0, center=np.zeros(3))
    area = sv.calculate_areas()
    n = len(vectors)
    return (area[:n] + area[n:]) / (4.0 * np.pi)


def _plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two index-space lattice vectors spanning a primitive cell of the lattice plane with this normal."""
    nz = np.flatnonzero(normal)
    if len(nz) == 1:
        a, b = [ax for ax in range(3) if ax != nz[0]]
        return np.eye(3, dtype=np.int64)[a], np.eye(3, dtype=np.int64)[b]
    if len(nz) == 2:
        zero = next(ax for ax in range(3) if normal[ax] == 0)
        p = np.eye(3, dtype=np.int64)[zero]
        q = np.zeros(3, dtype=np.int64)
        q[nz[0]], q[nz[1]] = normal[nz[1]], -normal[nz[0]]
        return p, q
    p = np.array([normal[1], -normal[0], 0])
    q = np.array([0, normal[2], -normal[1]])
    return p, q


@dataclass(frozen=True)
class Geometry:
    """Direction weights and lengths of the 13 lattice directions for one voxel size (µm).

    Lengths are stored in units of ``unit_um`` (the longest voxel edge), so that the weights and every length stay
    O(1) for any voxel size; :func:`to_um` turns a quantity of length dimension k into µm^k afterwards (Crofton
    weights are scale-free: V ~ a³, S ~ a², M ~ a, χ ~ 1).

    Attributes
    ----------
    voxel_um : (3,) float
        Voxel edge lengths along x, y, z.
    unit_um : float
        Length unit of the fields below: the longest voxel edge.
    cell_volume : float
        Volume of one lattice cell (unit_um³).
    line_length : (13,) float
        Length of the lattice step in each line direction (unit_um).
    line_weight : (13,) float
        Crofton weight γ_i of each line direction (sums to 1).
    plane_spacing : (13,) float
        Distance between neighbouring lattice planes of each family (unit_um).
    plane_weight : (13,) float
        Crofton weight γ'_j of each plane family (sums to 1).
    """

    voxel_um: tuple[float, float, float]
    unit_um: float
    cell_volume: float
    line_length: np.ndarray
    line_weight: np.ndarray
    plane_spacing: np.ndarray
    plane_weight: np.ndarray

    @property
    def cell_volume_um3(self) -> float:
        """Volume of one lattice cell in µm³ (inf beyond the float64 range)."""
        return float(to_um(self.cell_volume, self, 3))

    @property
    def line_length_um(self) -> np.ndarray:
        """(13,) lattice step of each line direction in µm."""
        return to_um(self.line_length, self, 1)

    @property
    def plane_spacing_um(self) -> np.ndarray:
        """(13,) distance between neighbouring lattice planes of each family in µm."""
        return to_um(self.plane_spacing, self, 1)


def to_um(value, geom: Geometry, power: int) -> np.ndarray:
    """``value`` in units of ``geom.unit_um``^power, in µm^power (inf or 0 beyond the float64 range)."""
    return from_voxel_units(value, geom.unit_um, power)


@functools.lru_cache(maxsize=64)
def geometry(voxel_um: tuple[float, float, float]) -> Geometry:
    """Crofton weights and lattice lengths for voxel edge lengths ``voxel_um`` (x, y, z) in µm.

    Everything is computed for the voxel edges divided by the longest one (the weights are scale-free), so any
    positive finite voxel size gives the same weights as its shape at unit size.
    """
    voxel = np.asarray(voxel_um, dtype=np.float64)
    unit = float(voxel.max())
    scale = voxel / unit
    lines = DIRECTIONS * scale
    normals, spacing = [], []
    cell_volume = float(np.prod(scale))
    for normal in DIRECTIONS:
        p, q = _plane_basis(normal)
        n_phys = np.cross(p * scale, q * scale)
        normals.append(n_phys)
        spacing.append(cell_volume / np.linalg.norm(n_phys))
    return Geometry(
        voxel_um=tuple(float(s) for s in voxel),
        unit_um=unit,
        cell_volume=cell_volume,
        line_length=np.linalg.norm(lines, axis=1),
        line_weight=_voronoi_weights(lines),
        plane_spacing=np.asarray(spacing),
        plane_weight=_voronoi_weights(np.asarray(normals)),
    )
