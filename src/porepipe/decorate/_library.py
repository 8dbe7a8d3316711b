"""Grain types: convex polyhedra given by half-spaces n·x <= d (unit n), their exact measures, and generators.

Every type is stored centred at its centroid, so "grain centre = sphere centre" (§4.7.1 step 3) puts the grain's
centre of mass on the sphere centre. The sphere is a type too (kind ``SPHERE``, unit radius, no planes).
"""

from __future__ import annotations

import dataclasses
import enum
from pathlib import Path

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

from porepipe._shared.errors import PorepipeError

#: a plane counts as a face only if it carries a polygon of area above this fraction of the squared size
_FACE_AREA_RTOL = 1e-10
#: inscribed radius below this fraction of the circumscribed radius = empty / flat polyhedron
_FLAT_RTOL = 1e-7
#: quartz: angle between the normal of a rhombohedral cap face and the c axis (the r face is 51.8° from the basal plane)
QUARTZ_CAP_ANGLE_DEG = 51.8


class Kind(enum.IntEnum):
    """Body of a grain type: the sphere itself, or a convex polyhedron (a set of planes)."""

    SPHERE = 0
    POLYHEDRON = 1


@dataclasses.dataclass(frozen=True)
class GrainType:
    """One grain type at unit scale, centred at its centroid.

    Attributes
    ----------
    name : str
    kind : Kind
    normals : (m, 3) ndarray
        Outward unit normals of the facet planes (m = 0 for a sphere).
    offsets : (m,) ndarray
        Plane offsets d: the grain is {x : normals @ x <= offsets}.
    volume, area, mean_curvature : float
        Exact V, S and integral of mean curvature M = ½ Σ_edges L_e ψ_e (ψ_e the exterior dihedral angle).
    inradius : float
        Radius of the largest ball inside the grain (Chebyshev radius, anywhere in the grain).
    centre_inradius : float
        Radius of the largest ball centred at the centroid = min(offsets) (the ``inscribed`` scaling rule).
    circumradius : float
        Largest distance of a vertex from the centroid (the ``circumscribed`` scaling rule).
    vertices : (v, 3) ndarray
    """

    name: str
    kind: Kind
    normals: np.ndarray
    offsets: np.ndarray
    volume: float
    area: float
    mean_curvature: float
    inradius: float
    centre_inradius: float
    circumradius: float
    vertices: np.ndarray

    @property
    def n_faces(self) -> int:
        return len(self.offsets)


def sphere_type(name: str = "sphere") -> GrainType:
    """The unit ball as a grain type."""
    return GrainType(
        name,
        Kind.SPHERE,
        np.zeros((0, 3)),
        np.zeros(0),
        4.0 / 3.0 * np.pi,
        4.0 * np.pi,
        4.0 * np.pi,
        1.0,
        1.0,
        1.0,
        np.zeros((0, 3)),
    )


def _normalise(name, normals, offsets, unit: bool = False) -> tuple[np.ndarray, np.ndarray]:
    normals = np.asarray(normals, dtype=np.float64)
    offsets = np.asarray(offsets, dtype=np.float64)
    if normals.ndim != 2 or normals.shape[1] != 3 or offsets.shape != (normals.shape[0],):
        raise PorepipeError(
            f"grain type {name!r}: need normals (m, 3) and offsets (m,), got {normals.shape} and "
            f"{offsets.shape}"
        )
    if not (np.isfinite(normals).all() and np.isfinite(offsets).all()):
        raise PorepipeError(f"grain type {name!r}: plane set has NaN or Inf")
    length = np.linalg.norm(normals, axis=1)
    if len(length) < 4:
        raise PorepipeError(
            f"grain type {name!r}: {len(length)} planes cannot bound a polyhedron (need >= 4)"
        )
    if (length == 0).any():
        raise PorepipeError(f"grain type {name!r}: plane {int(np.argmin(length))} has a zero normal")
    if unit:
        if not np.allclose(length, 1.0, rtol=0, atol=1e-12):
            raise PorepipeError(
                f"grain type {name!r}: normals read as unit vectors have lengths up to "
                f"{float(np.abs(length - 1).max()):.3g} away from 1"
            )
        return normals, offsets
    return normals / length[:, None], offsets / length


def check_bounded(name: str, normals: np.ndarray) -> None:
    """{n·x <= d} is bounded iff the origin lies strictly inside the convex hull of the unit normals."""
    try:
        hull = ConvexHull(normals)
        inside = hull.equations[:, 3].max() < -1e-9
    except QhullError:
        inside = False  # coplanar normals: a prism or slab, open along their common perpendicular
    if not inside:
        raise PorepipeError(
            f"grain type {name!r}: the planes do not bound a polyhedron (unbounded); add planes whose "
            "normals surround the origin"
        )


def chebyshev_ball(name: str, normals: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and radius of the largest ball in {n·x <= d} (linear programme); PorepipeError if unbounded or empty."""
    a_ub = np.column_stack([normals, np.ones(len(offsets))])
    res = linprog(
        c=[0, 0, 0, -1.0], A_ub=a_ub, b_ub=offsets, bounds=[(None, None)] * 3 + [(None, None)], method="highs"
    )
    if res.status == 3:
        raise PorepipeError(
            f"grain type {name!r}: the planes do not bound a polyhedron (unbounded); add planes whose "
            "normals surround the origin"
        )
    if res.status != 0:
        raise PorepipeError(
            f"grain type {name!r}: the planes leave no interior (empty polyhedron): {res.message}"
        )
    centre, radius = res.x[:3], float(res.x[3])
    scale = max(1.0, float(np.abs(offsets).max()))
    if radius <= _FLAT_RTOL * scale:
        raise PorepipeError(
            f"grain type {name!r}: the planes leave no interior (empty or flat polyhedron, "
            f"inscribed radius {radius:.3g})"
        )
    return centre, radius


def _vertices(name, normals, offsets, interior) -> np.ndarray:
    try:
        hs = HalfspaceIntersection(np.column_stack([normals, -offsets]), interior)
    except QhullError as err:
        raise PorepipeError(f"grain type {name!r}: vertex enumeration failed ({err})") from err
    verts = hs.intersections
    if not np.isfinite(verts).all():
        raise PorepipeError(f"grain type {name!r}: the planes do not bound a polyhedron (unbounded)")
    return verts


def _centroid(hull: ConvexHull) -> np.ndarray:
    """Centroid of a convex hull from its triangulated boundary (cones to an interior point)."""
    pts = hull.points
    inner = pts[hull.vertices].mean(axis=0)
    tri = pts[hull.simplices]
    vol = (
        np.abs(np.einsum("ij,ij->i", np.cross(tri[:, 0] - inner, tri[:, 1] - inner), tri[:, 2] - inner)) / 6.0
    )
    cent = (tri.sum(axis=1) + inner) / 4.0
    return (vol[:, None] * cent).sum(axis=0) / vol.sum()


def mean_curvature_integral(hull: ConvexHull) -> float:
    """M = ½ Σ_edges L_e ψ_e of a convex polytope from its triangulated hull; coplanar triangle pairs give ψ = 0."""
    total = 0.0
    normals = hull.equations[:, :3]
    for s, simplex in enumerate(hull.simplices):
        for corner, nb in enumerate(hull.neighbors[s]):
            if nb <= s:
                continue
            edge = np.delete(simplex, corner)
            length = np.linalg.norm(hull.points[edge[0]] - hull.points[edge[1]])
            # atan2 stays accurate for the near-zero angles of coplanar triangle pairs (arccos would give ~1e-8)
            angle = np.arctan2(np.linalg.norm(np.cross(normals[s], normals[nb])), normals[s] @ normals[nb])
            total += length * angle
    return 0.5 * total


def _faces(normals, offsets, verts, size) -> np.ndarray:
    """Mask of planes that carry a face of positive area (the others are redundant)."""
    keep = np.zeros(len(offsets), dtype=bool)
    tol = 1e-9 * size
    for p in range(len(offsets)):
        on = verts[np.abs(verts @ normals[p] - offsets[p]) <= tol]
        if len(on) < 3:
            continue
        centred = on - on.mean(axis=0)
        # area proxy: the second singular value of the face's vertex cloud in its plane
        sv = np.linalg.svd(centred, compute_uv=False)
        keep[p] = sv[1] > np.sqrt(_FACE_AREA_RTOL) * size
    # identical planes given twice: keep the first
    for p in np.flatnonzero(keep):
        same = keep & (np.abs(normals @ normals[p] - 1.0) < 1e-12) & (np.abs(offsets - offsets[p]) <= tol)
        same[: p + 1] = False
        keep &= ~same
    return keep


def polyhedron(name: str, normals, offsets, centre: bool = True, *, unit: bool = False) -> GrainType:
    """A convex polyhedron {x : n·x <= d} with its exact measures.

    Parameters
    ----------
    name : str
        Type name, used in every error message.
    normals : (m, 3) array_like
        Plane normals (any length; normalised together with ``offsets``).
    offsets : (m,) array_like
    centre : bool
        Translate the polyhedron so its centroid is the origin.
    unit : bool
        The normals are unit vectors already (a plane set read back from a file): used as given, so a type is rebuilt
        bit for bit (dividing by a norm that rounds to 1 ± 1 ulp would move a normal by an ulp).

    Raises
    ------
    PorepipeError
        The planes do not bound a polyhedron (unbounded), leave no interior (empty or flat), or contain NaN/Inf.
    """
    normals, offsets = _normalise(name, normals, offsets, unit)
    check_bounded(name, normals)
    interior, _ = chebyshev_ball(name, normals, offsets)
    verts = _vertices(name, normals, offsets, interior)
    if centre:
        hull = ConvexHull(verts)
        shift = _centroid(hull)
        offsets = offsets - normals @ shift
        verts = verts - shift
    size = float(np.abs(verts).max())
    keep = _faces(normals, offsets, verts, size)
    normals, offsets = normals[keep], offsets[keep]
    hull = ConvexHull(verts)
    verts = hull.points[hull.vertices]
    _, inradius = chebyshev_ball(name, normals, offsets)
    return GrainType(
        name,
        Kind.POLYHEDRON,
        np.ascontiguousarray(normals),
        np.ascontiguousarray(offsets),
        float(hull.volume),
        float(hull.area),
        mean_curvature_integral(hull),
        inradius,
        float(offsets.min()),
        float(np.linalg.norm(verts, axis=1).max()),
        np.ascontiguousarray(verts),
    )


def _tilt(normals: np.ndarray, angle: np.ndarray, rng) -> np.ndarray:
    """Rotate each unit normal by ``angle`` towards a random perpendicular direction."""
    rand = rng.normal(size=normals.shape)
    perp = rand - (rand * normals).sum(axis=1)[:, None] * normals
    perp /= np.linalg.norm(perp, axis=1)[:, None]
    return np.cos(angle)[:, None] * normals + np.sin(angle)[:, None] * perp


def quartz_type(name: str, rng, elongation: float = 0.0, perturbation: float = 0.1) -> GrainType:
    """Quartz-like crystal: hexagonal prism (6 planes) with two hexagonal pyramidal caps (2 × 6 planes) = 18 planes.

    The prism has inradius 1 and half-length ``1 + elongation`` (in units of the prism inradius) to where the caps
    start; cap faces are tilted by 51.8° from the c axis (rhombohedral r faces of quartz). Normals are tilted by up
    to ``perturbation`` radians and offsets scaled by 1 ± ``perturbation``/2, uniformly.
    """
    theta = np.arange(6) * np.pi / 3.0
    alpha = np.deg2rad(QUARTZ_CAP_ANGLE_DEG)
    half = 1.0 + elongation
    prism = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(6)])
    caps = [
        np.column_stack(
            [np.cos(theta) * np.sin(alpha), np.sin(theta) * np.sin(alpha), np.full(6, sign * np.cos(alpha))]
        )
        for sign in (1.0, -1.0)
    ]
    normals = np.vstack([prism, *caps])
    # each cap face sits above its prism face, through the prism face's top (bottom) edge at height ±half
    offsets = np.concatenate([np.ones(6), np.full(12, np.sin(alpha) + np.cos(alpha) * half)])
    normals = _tilt(normals, rng.uniform(0.0, perturbation, 18), rng)
    offsets = offsets * (1.0 + rng.uniform(-perturbation / 2, perturbation / 2, 18))
    return polyhedron(name, normals, offsets)


def _stretch(normals, offsets, elongation):
    """Planes of the body stretched by 1/(1 - e) along z (an affine map keeps every facet)."""
    inv = np.array([1.0, 1.0, 1.0 - elongation])
    n = normals * inv
    length = np.linalg.norm(n, axis=1)
    return n / length[:, None], offsets / length


def random_type(
    name: str, rng, facets: int, elongation: float = 0.0, perturbation: float = 0.1, attempts: int = 50
) -> GrainType:
    """Random convex polyhedron with exactly ``facets`` faces and elongation e = 1 − (short/long axis).

    Normals: a Fibonacci sphere of ``facets`` points, randomly rotated and each tilted by up to ``perturbation``
    radians; all offsets 1, so every plane touches the unit sphere and is a facet. The body is then stretched by
    1/(1 − e) along z (affine maps keep facets).
    """
    from porepipe.decorate._rotation import uniform_rotations

    if not (facets >= 4 and 0 <= elongation < 1 and 0 <= perturbation < np.inf):
        raise PorepipeError(
            f"grain type {name!r}: needs facets >= 4, 0 <= elongation < 1 and a finite perturbation >= 0, got "
            f"{facets}, {elongation}, {perturbation}"
        )
    k = np.arange(facets) + 0.5
    polar = np.arccos(1.0 - 2.0 * k / facets)
    azim = np.pi * (1.0 + 5.0**0.5) * k
    base = np.column_stack([np.cos(azim) * np.sin(polar), np.sin(azim) * np.sin(polar), np.cos(polar)])
    for _ in range(attempts):
        normals = base @ uniform_rotations(rng, 1)[0].T
        normals = _tilt(normals, rng.uniform(0.0, perturbation, facets), rng)
        n, d = _stretch(normals, np.ones(facets), elongation)
        try:
            grain = polyhedron(name, n, d)
        except PorepipeError:
            continue
        if grain.n_faces == facets:
            return grain
    raise PorepipeError(
        f"grain type {name!r}: no polyhedron with {facets} facets found in {attempts} attempts "
        f"(perturbation {perturbation} too large?)"
    )


def read_plane_file(path) -> list[GrainType]:
    """Types from a text file: one plane per line, ``type_name nx ny nz d`` (n need not be unit); ``#`` comments."""
    path = Path(path)
    if not path.is_file():
        raise PorepipeError(f"plane file {path} does not exist")
    planes: dict[str, list[list[float]]] = {}
    for lineno, line in enumerate(path.read_text().splitlines(), start=1):
        text = line.split("#", 1)[0].split()
        if not text:
            continue
        if len(text) != 5:
            raise PorepipeError(f"{path}:{lineno}: expected 'type nx ny nz d', got {line!r}")
        try:
            planes.setdefault(text[0], []).append([float(v) for v in text[1:]])
        except ValueError as err:
            raise PorepipeError(f"{path}:{lineno}: not a number in {line!r}") from err
    if not planes:
        raise PorepipeError(f"plane file {path} holds no planes")
    return [polyhedron(name, np.array(rows)[:, :3], np.array(rows)[:, 3]) for name, rows in planes.items()]
