"""Grain orientations: uniform on SO(3), von Mises–Fisher about a preferred axis, rotation matrices."""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """(n, 4) unit quaternions (w, x, y, z) -> (n, 3, 3) rotation matrices."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=1)[:, None]
    w, x, y, z = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=1,
    )


def uniform_rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3, 3) rotations uniform (Haar) on SO(3): normalised 4-D Gaussian quaternions."""
    return quaternion_to_matrix(rng.normal(size=(n, 4)))


def _axis_rotation(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations by ``angle`` about unit ``axis`` (n, 3) (Rodrigues)."""
    half = 0.5 * angle
    return quaternion_to_matrix(np.column_stack([np.cos(half), np.sin(half)[:, None] * axis]))


def align_z(directions: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations taking e_z to each unit vector of ``directions`` (n, 3) by the shortest arc."""
    d = np.asarray(directions, dtype=np.float64)
    cross = np.column_stack([-d[:, 1], d[:, 0], np.zeros(len(d))])  # e_z × d
    sin = np.linalg.norm(cross, axis=1)
    angle = np.arctan2(sin, d[:, 2])
    axis = np.where(
        sin[:, None] > 1e-300, cross / np.maximum(sin, 1e-300)[:, None], np.array([1.0, 0.0, 0.0])
    )
    return _axis_rotation(axis, angle)


def von_mises_fisher(rng: np.random.Generator, n: int, axis, kappa: float) -> np.ndarray:
    """(n, 3) unit vectors from the von Mises–Fisher distribution on S² about ``axis``; κ = 0 is uniform.

    Notes
    -----
    Inverse CDF of w = cos(angle to the axis): w = 1 + log(u + (1 − u) e^{−2κ}) / κ; E[w] = coth κ − 1/κ.
    """
    a = np.asarray(axis, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or not np.linalg.norm(a) > 0:
        raise PorepipeError(f"von Mises-Fisher axis {axis} must be a finite non-zero 3-vector")
    if not kappa >= 0:
        raise PorepipeError(f"von Mises-Fisher concentration kappa must be >= 0 (0: uniform), got {kappa}")
    u = rng.uniform(size=n)
    if kappa < 1e-8:
        w = 2.0 * u - 1.0
    else:
        w = 1.0 + np.log(u + (1.0 - u) * np.exp(-2.0 * kappa)) / kappa
    w = np.clip(w, -1.0, 1.0)
    phi = rng.uniform(0.0, 2.0 * np.pi, size=n)
    s = np.sqrt(1.0 - w * w)
    local = np.column_stack([s * np.cos(phi), s * np.sin(phi), w])
    a = a / np.linalg.norm(a)
    return local @ align_z(a[None, :])[0].T


def anisotropic_rotations(rng: np.random.Generator, n: int, axis, kappa: float) -> np.ndarray:
    """(n, 3, 3) rotations whose image of the grain z axis is von Mises–Fisher about ``axis``, spin uniform."""
    spin = _axis_rotation(np.tile([0.0, 0.0, 1.0], (n, 1)), rng.uniform(0.0, 2.0 * np.pi, size=n))
    return align_z(von_mises_fisher(rng, n, axis, kappa)) @ spin
