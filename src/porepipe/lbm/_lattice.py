"""D3Q19 lattice constants and the d'Humières (2002) moment basis.

Velocity order: rest, the six axis directions, then the twelve edge diagonals, arranged so that
velocity ``i`` and its opposite ``i ^ 1`` ... are neighbours in the list (``OPPOSITE[i]``).
"""

from __future__ import annotations

import numpy as np

#: D3Q19 velocities (19, 3); pairs (2k-1, 2k) are opposite for k = 1..9.
C = np.array(
    [
        (0, 0, 0),
        (1, 0, 0),
        (-1, 0, 0),
        (0, 1, 0),
        (0, -1, 0),
        (0, 0, 1),
        (0, 0, -1),
        (1, 1, 0),
        (-1, -1, 0),
        (1, -1, 0),
        (-1, 1, 0),
        (1, 0, 1),
        (-1, 0, -1),
        (1, 0, -1),
        (-1, 0, 1),
        (0, 1, 1),
        (0, -1, -1),
        (0, 1, -1),
        (0, -1, 1),
    ],
    dtype=np.int64,
)
Q = 19
#: lattice weights: 1/3 rest, 1/18 axis, 1/36 diagonal (Qian et al. 1992; not printed in the thesis).
W = np.array([1 / 3] + [1 / 18] * 6 + [1 / 36] * 12)
OPPOSITE = np.array([0] + [i + 1 if i % 2 == 1 else i - 1 for i in range(1, Q)], dtype=np.int64)
#: speed of sound squared, lattice units.
CS2 = 1.0 / 3.0


def dhumieres_matrix() -> np.ndarray:
    """Moment matrix M (19, 19) of d'Humières et al. (2002), rows in their order.

    Rows: ρ, e, ε, j_x, q_x, j_y, q_y, j_z, q_z, 3p_xx, 3π_xx, p_ww, π_ww, p_xy, p_yz, p_xz, m_x, m_y, m_z.
    The rows are mutually orthogonal (unweighted), so M⁻¹ = Mᵀ diag(1/|M_k|²).
    """
    cx, cy, cz = (C[:, k].astype(np.float64) for k in range(3))
    c2 = cx * cx + cy * cy + cz * cz
    rows = [
        np.ones(Q),
        19 * c2 - 30,
        (21 * c2 * c2 - 53 * c2 + 24) / 2,
        cx,
        (5 * c2 - 9) * cx,
        cy,
        (5 * c2 - 9) * cy,
        cz,
        (5 * c2 - 9) * cz,
        3 * cx * cx - c2,
        (3 * c2 - 5) * (3 * cx * cx - c2),
        cy * cy - cz * cz,
        (3 * c2 - 5) * (cy * cy - cz * cz),
        cx * cy,
        cy * cz,
        cx * cz,
        (cy * cy - cz * cz) * cx,
        (cz * cz - cx * cx) * cy,
        (cx * cx - cy * cy) * cz,
    ]
    return np.array(rows)


def mrt_rates(tau: float, tau_bulk: float, magic: float | None = None) -> np.ndarray:
    """Diagonal of Š (thesis Eq. 6.1.14): stresses relax with 1/τ, energy with 1/τ_bulk, the rest fixed.

    With ``magic`` = Λ the odd moments q and m relax with 1/τ⁻, τ⁻ = ½ + Λ/(τ − ½), instead of the thesis's
    fixed 1.2 and 1.98 (the MRT analogue of TRT's τ-independent wall position).
    """
    s_nu, s_e = 1.0 / tau, 1.0 / tau_bulk
    s_q, s_m = (1.2, 1.98) if magic is None else (1.0 / trt_minus_tau(tau, magic),) * 2
    return np.array(
        [0.0, s_e, 1.4, 0.0, s_q, 0.0, s_q, 0.0, s_q, s_nu, 1.4, s_nu, 1.4, s_nu, s_nu, s_nu, s_m, s_m, s_m]
    )


def mrt_operator(tau: float, tau_bulk: float, magic: float | None = None) -> np.ndarray:
    """Collision matrix A = M⁻¹ Š M acting on f − f^eq (dense reference, tests only)."""
    m = dhumieres_matrix()
    return np.linalg.solve(m, np.diag(mrt_rates(tau, tau_bulk, magic)) @ m)


def trt_minus_tau(tau: float, magic: float) -> float:
    """τ⁻ of the antisymmetric modes from τ⁺ = τ and the magic parameter Λ = (τ⁺ − ½)(τ⁻ − ½)."""
    return 0.5 + magic / (tau - 0.5)


def viscosity(tau: float) -> float:
    """Kinematic viscosity in lattice units, ν̂ = (τ̂ − ½)/3 (thesis Eq. 6.1.15)."""
    return CS2 * (tau - 0.5)
