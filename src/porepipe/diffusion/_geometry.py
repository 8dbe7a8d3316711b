"""Pore volumes for the Knudsen engine: synthetic capillaries (thesis §3.6, §4.2.3), the accessible cluster (§2.3),
porosities and the voxel wall area.

A pore volume is a uint8 array (1 = pore, 0 = solid), axes (x, y, z) = array axes (0, 1, 2), with per-axis voxel
edges ``voxel`` (any length unit; anisotropic voxels allowed). The outside of the box is solid across every axis that
is neither the transport axis nor periodic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from porepipe._shared.clusters import spanning_clusters
from porepipe._shared.errors import PorepipeError
from porepipe.diffusion import _kernels as K


@dataclass(frozen=True)
class PoreVolume:
    """A binary pore volume with its voxel edges and periodic flags.

    Attributes
    ----------
    pore : (n0, n1, n2) uint8 ndarray
        1 = pore, 0 = solid.
    voxel : (3,) float ndarray
        Voxel edge per axis (the generators use voxels as unit unless told otherwise).
    periodic : (3,) bool ndarray
        Axes that wrap.
    """

    pore: np.ndarray
    voxel: np.ndarray
    periodic: np.ndarray


def _volume(pore: np.ndarray, voxel=(1.0, 1.0, 1.0), periodic=(False, False, False)) -> PoreVolume:
    return PoreVolume(
        np.ascontiguousarray(pore, dtype=np.uint8),
        np.asarray(voxel, dtype=float).reshape(3),
        np.asarray(periodic, dtype=bool).reshape(3),
    )


def _positive_int(name: str, value) -> int:
    if int(value) != value or value < 1:
        raise PorepipeError(f"{name} must be a positive whole number of voxels, got {value!r}")
    return int(value)


def square_capillary(a: int, length: int) -> PoreVolume:
    """Square channel a x a x length voxels along z, walls = the box's lateral faces (thesis §3.6.3: 30 x 30 x 300)."""
    a, length = _positive_int("a", a), _positive_int("length", length)
    return _volume(np.ones((a, a, length), dtype=np.uint8))


def slit(width: int, length: int, depth: int = 4) -> PoreVolume:
    """Slit of ``width`` voxels between two plates normal to x, periodic across y (``depth`` voxels), along z."""
    width, length, depth = (
        _positive_int(k, v) for k, v in (("width", width), ("length", length), ("depth", depth))
    )
    return _volume(np.ones((width, depth, length), dtype=np.uint8), periodic=(False, True, False))


def _disk(radius: float, voxel: np.ndarray) -> np.ndarray:
    """(n0, n1) bool: voxel centres within ``radius`` of the centre of the smallest enclosing square."""
    n = [int(np.ceil(2.0 * radius / voxel[d] - 1e-9)) for d in (0, 1)]
    c = [(np.arange(n[d]) + 0.5) * voxel[d] - 0.5 * n[d] * voxel[d] for d in (0, 1)]
    return c[0][:, None] ** 2 + c[1][None, :] ** 2 <= radius * radius


def cylinder(radius: float, length: float, voxel=(1.0, 1.0, 1.0)) -> PoreVolume:
    """Voxelised circular tube along z: pore where the voxel centre lies within ``radius`` of the axis.

    Parameters
    ----------
    radius, length : float
        In the unit of ``voxel`` (the axial voxel count is ``round(length / voxel[2])``).
    voxel : (3,) float
        Voxel edges.
    """
    voxel = np.asarray(voxel, dtype=float)
    if not radius > 0 or not length > 0:
        raise PorepipeError(f"cylinder needs radius > 0 and length > 0, got {radius!r}, {length!r}")
    nz = max(1, round(length / voxel[2]))
    disk = _disk(radius, voxel)
    return _volume(np.repeat(disk[:, :, None], nz, axis=2).astype(np.uint8), voxel)


def constricted_capillary(radius: int, length: int, throat_radius: int, throat_length: int) -> PoreVolume:
    """§4.2.3 A: a tube with two pronounced constrictions, centred at 1/3 and 2/3 of the length."""
    vol = cylinder(radius, length)
    throat = _disk(throat_radius, vol.voxel)
    pad = (vol.pore.shape[0] - throat.shape[0]) // 2
    ring = np.zeros(vol.pore.shape[:2], dtype=bool)
    ring[pad : pad + throat.shape[0], pad : pad + throat.shape[1]] = throat
    pore = vol.pore.copy()
    for centre in (length / 3.0, 2.0 * length / 3.0):
        lo = max(0, round(centre - throat_length / 2.0))
        pore[:, :, lo : lo + int(throat_length)] &= ring[:, :, None].astype(np.uint8)
    return _volume(pore, vol.voxel)


def pocketed_capillary(
    a: int, length: int, pocket_depth: int, pocket_width: int, n_pockets: int = 3
) -> PoreVolume:
    """§4.2.3 B: a square a x a channel in a solid shell with few, deep pockets cut into the lateral walls.

    Pockets alternate between the four walls, evenly spaced along z.
    """
    s = pocket_depth
    pore = np.zeros((a + 2 * s, a + 2 * s, length), dtype=np.uint8)
    pore[s : s + a, s : s + a, :] = 1
    for k in range(n_pockets):
        z0 = round((k + 0.5) * length / n_pockets - pocket_width / 2.0)
        zs = slice(max(0, z0), min(length, z0 + pocket_width))
        mid = slice(s + a // 2 - pocket_width // 2, s + a // 2 - pocket_width // 2 + pocket_width)
        wall = k % 4
        if wall == 0:
            pore[:s, mid, zs] = 1
        elif wall == 1:
            pore[s + a :, mid, zs] = 1
        elif wall == 2:
            pore[mid, :s, zs] = 1
        else:
            pore[mid, s + a :, zs] = 1
    return _volume(pore)


def rough_capillary(a: int, length: int, roughness: float, seed: int = 0) -> PoreVolume:
    """§4.2.3 C: a square channel whose wall layer is uniformly roughened: each voxel of the one-voxel layer along
    the walls is solid with probability ``roughness`` (many edges and small traps).
    """
    if not 0.0 <= roughness < 1.0:
        raise PorepipeError(f"roughness must be in [0, 1), got {roughness!r}")
    rng = np.random.default_rng(seed)
    pore = np.ones((a, a, length), dtype=np.uint8)
    layer = np.zeros((a, a), dtype=bool)
    layer[0, :] = layer[-1, :] = layer[:, 0] = layer[:, -1] = True
    bumps = (rng.random((a, a, length)) < roughness) & layer[:, :, None]
    pore[bumps] = 0
    return _volume(pore)


def closed_box(shape) -> PoreVolume:
    """An all-pore box closed on every side (the outside is solid)."""
    return _volume(np.ones(tuple(int(s) for s in shape), dtype=np.uint8))


# ---------------------------------------------------------------------------------------------------------------------
def accessible_pore(
    pore: np.ndarray, axis: int | None, periodic=(False, False, False), in_place: bool = False
) -> np.ndarray:
    """The pore space a particle can use (§2.3): the largest face-connected (6-connected) cluster.

    Found by the shared in-place flood fill (:func:`porepipe._shared.clusters.spanning_clusters`): one byte per
    voxel for the work copy (none with ``in_place``), no label array.

    Parameters
    ----------
    pore : (n0, n1, n2) uint8 or bool ndarray
        1 = pore.
    axis : int or None
        Transport axis: keep the largest cluster that touches both its first and its last layer. None: keep the
        largest cluster (clusters joined across periodic faces count as one).
    periodic : (3,) bool
        Axes that wrap (the transport axis never wraps).
    in_place : bool
        Overwrite ``pore`` (writeable C-contiguous uint8) with the result instead of taking a 1-byte work copy.

    Returns
    -------
    (n0, n1, n2) uint8 ndarray

    Raises
    ------
    PorepipeError
        All-solid volume, or no face-connected path from the inlet to the outlet layer.
    """
    pore = np.asarray(pore)
    if pore.ndim != 3 or min(pore.shape) < 1:
        raise PorepipeError(f"a pore volume must be 3-D with positive sizes, got shape {pore.shape}")
    if not pore.any():
        raise PorepipeError(f"the pore volume of shape {pore.shape} is all solid (no voxel is 1 = pore)")
    per = [bool(p) and d != axis for d, p in enumerate(periodic)]
    keep, spanning = spanning_clusters(pore, axis, connectivity=6, periodic=per, in_place=in_place)
    if axis is not None and spanning == 0:
        name = "xyz"[axis]
        raise PorepipeError(
            f"no face-connected pore path joins the inlet face {name} = 0 to the outlet face "
            f"{name} = {pore.shape[axis] - 1} (shape {pore.shape}); nothing can be transmitted"
        )
    return keep


def wall_area(pore: np.ndarray, voxel, periodic=(False, False, False), open_axis: int | None = None) -> float:
    """Area of the pore-solid voxel faces, with the outside solid except across periodic axes and ``open_axis``.

    Counted by a numba pass over the volume (no full-size temporaries).

    Returns
    -------
    float
        In the square of the ``voxel`` unit.
    """
    pore = np.ascontiguousarray(pore)
    if pore.dtype == np.bool_:
        pore = pore.view(np.uint8)
    voxel = np.broadcast_to(np.asarray(voxel, dtype=float), (3,))
    per = np.array([bool(p) for p in np.broadcast_to(periodic, (3,))])
    faces = K._wall_faces(pore, per, -1 if open_axis is None else int(open_axis))
    return float(sum(faces[d] * np.prod(np.delete(voxel, d)) for d in range(3)))
