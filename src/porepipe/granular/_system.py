"""From a ``granular:`` scene section to the bodies of a simulation: particles, blocks, drop sources, walls."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from porepipe._shared import rng as _rng
from porepipe._shared.errors import PorepipeError
from porepipe.granular._settings import Block, DropMode, Lattice, Settings, Shape, ShapeKind, Wall
from porepipe.granular._shapes import (
    Dist,
    corner_numbers,
    draw,
    ellipse_polygon,
    polygon_properties,
    rectangle,
)
from porepipe.granular._silo_shape import silo_wall_slabs

STAGE = "granular"


@dataclasses.dataclass
class Bodies:
    """Mobile particles of a scene (walls separately), before they become kernel arrays.

    Attributes
    ----------
    vertices : list of (n_i, 2) ndarray
        Corners relative to the centroid, CCW, m.
    position : (N, 3) ndarray
        Centroid x, y (m) and angle phi (rad, CCW).
    velocity : (N, 3) ndarray
        m/s and rad/s.
    insert_s : (N,) ndarray
        Insertion time (0 = present from the start).
    drop : (N,) int ndarray
        Index of the drop source that inserts the particle (-1 = none).
    """

    vertices: list
    position: np.ndarray
    velocity: np.ndarray
    insert_s: np.ndarray
    drop: np.ndarray


def generate_shapes(shape: Shape, count: int, gen: np.random.Generator) -> tuple[list, np.ndarray]:
    """``count`` particle outlines (centred at 0, before orientation) and their orientations phi (rad)."""
    a = draw(shape.size_dist, shape.size_m[0], shape.size_spread, gen, count)
    b = draw(shape.size_dist, shape.size_m[1], shape.size_spread, gen, count)
    n = corner_numbers(shape.corners_dist, shape.corners, shape.corners_spread, gen, count)
    if shape.orientation_dist is Dist.equal:
        phi = gen.uniform(0.0, 2.0 * np.pi, count)
    else:
        phi = draw(shape.orientation_dist, shape.orientation_rad, 0.5 * np.pi, gen, count, relative=False)
    out = []
    for k in range(count):
        if shape.kind is ShapeKind.rectangle:
            out.append(
                rectangle(
                    a[k],
                    b[k],
                    cut=shape.cut,
                    round_radius_m=shape.round_radius_m,
                    round_corners=shape.round_corners,
                )
            )
        else:
            out.append(ellipse_polygon(int(n[k]), a[k], b[k], shape.angle_mode, gen))
    return out, phi


def lattice_sites(block: Block, gen: np.random.Generator) -> np.ndarray:
    """Sites of a GENERATE_BLOCK lattice (RECT or FCC) with its jitter, (M, 2) in m."""
    (x0, y0), (x1, y1), (dx, dy) = block.lower_m, block.upper_m, block.grid_m
    xs = np.arange(x0 + 0.5 * dx, x1 - 0.5 * dx + 1e-12 * dx, dx)
    ys = np.arange(y0 + 0.5 * dy, y1 - 0.5 * dy + 1e-12 * dy, dy)
    gx, gy = np.meshgrid(xs, ys)
    sites = np.column_stack([gx.ravel(), gy.ravel()])
    if block.lattice is Lattice.fcc:
        off = sites + [0.5 * dx, 0.5 * dy]
        off = off[(off[:, 0] <= x1 - 0.5 * dx + 1e-12 * dx) & (off[:, 1] <= y1 - 0.5 * dy + 1e-12 * dy)]
        sites = np.vstack([sites, off])
        sites = sites[np.lexsort((sites[:, 0], sites[:, 1]))]
    if block.jitter is not Dist.const and block.jitter_fraction > 0:
        for axis, step in ((0, dx), (1, dy)):
            sites[:, axis] += draw(
                block.jitter, 0.0, 0.5 * step * block.jitter_fraction, gen, len(sites), relative=False
            )
    if block.max_count is not None:
        sites = sites[: block.max_count]
    return sites


def collect_bodies(settings: Settings, seed: int) -> Bodies:
    """All mobile particles of the scene in a fixed order: explicit particles, blocks, drop sources."""
    verts, pos, vel, ins, drop = [], [], [], [], []

    def add(v, p, phi, u, w, t, d):
        verts.append(v)
        pos.append((p[0], p[1], phi))
        vel.append((u[0], u[1], w))
        ins.append(t)
        drop.append(d)

    for k, part in enumerate(settings.particles):
        if part.vertices_m is not None:
            v = np.asarray(part.vertices_m, dtype=np.float64)
            phi = 0.0
        else:
            (v,), (phi,) = generate_shapes(part.shape, 1, _rng.stream(seed, STAGE, 0, k))
        add(v, part.position_m, part.angle_rad + phi, part.velocity_m_s, part.angular_velocity_rad_s, 0.0, -1)
    for k, block in enumerate(settings.blocks):
        gen = _rng.stream(seed, STAGE, 1, k)
        sites = lattice_sites(block, gen)
        shapes, phis = generate_shapes(block.shape, len(sites), gen)
        for s, v, phi in zip(sites, shapes, phis, strict=True):
            add(v, s, phi, (0.0, 0.0), 0.0, 0.0, -1)
    for k, src in enumerate(settings.drop_sources):
        gen = _rng.stream(seed, STAGE, 2, k)
        times = np.arange(src.from_s, src.to_s + 1e-12 * src.every_s, src.every_s)
        shapes, phis = generate_shapes(src.shape, len(times), gen)
        width = np.full(len(times), src.width_m)
        if src.shrink and src.to_s > src.from_s:  # line source of layered heaps: width -> 0 at to_s
            width *= 1.0 - (times - src.from_s) / (src.to_s - src.from_s)
        xs = src.x_m + width * (gen.uniform(0.0, 1.0, len(times)) - 0.5)
        ys = src.y_m + src.rise_m_s * (times - src.from_s)
        for t, v, phi, x, y in zip(times, shapes, phis, xs, ys, strict=True):
            add(v, (x, y), phi, src.velocity_m_s, 0.0, float(t), k)
    n = len(verts)
    return Bodies(
        verts,
        np.asarray(pos, dtype=np.float64).reshape(n, 3),
        np.asarray(vel, dtype=np.float64).reshape(n, 3),
        np.asarray(ins, dtype=np.float64),
        np.asarray(drop, dtype=np.int64),
    )


def wall_polygons(settings: Settings) -> list[tuple[str, np.ndarray, Wall | None]]:
    """World-frame corners of every wall (explicit walls, the slabs of ``box``, then those of ``silo``)."""
    out = []
    for w in settings.walls:
        v = np.asarray(w.vertices_m, dtype=np.float64)
        c, s = math.cos(w.angle_rad), math.sin(w.angle_rad)
        v = v @ np.array([[c, s], [-s, c]]) + np.asarray(w.offset_m)
        out.append((w.name, v, w))
    if settings.box is not None:
        (x0, y0), (x1, y1), d = settings.box.lower_m, settings.box.upper_m, settings.box.thickness_m
        if not (x1 > x0 and y1 > y0):
            raise PorepipeError(
                f"granular.box: upper_m {settings.box.upper_m} must exceed lower_m "
                f"{settings.box.lower_m} in x and y"
            )
        slabs = [
            ("box floor", (x0 - d, y0 - d, x1 + d, y0)),
            ("box left", (x0 - d, y0, x0, y1 + d)),
            ("box right", (x1, y0, x1 + d, y1 + d)),
        ]
        if settings.box.closed_top:
            slabs.append(("box top", (x0, y1, x1, y1 + d)))
        for name, (a0, b0, a1, b1) in slabs:
            out.append((name, np.array([(a0, b0), (a1, b0), (a1, b1), (a0, b1)]), None))
    if settings.silo is not None:
        out += [(name, v, None) for name, v in silo_wall_slabs(settings.silo)]
    return out


def particle_properties(vertices: list, density: float):
    """Mass properties of every particle; raises naming the first bad one. Returns list of dicts."""
    return [polygon_properties(v, density, name=f"granular particle {k}") for k, v in enumerate(vertices)]


def drop_modes(settings: Settings) -> list[DropMode]:
    return [src.mode for src in settings.drop_sources]
