"""Slow, obviously-right dense D3Q19 reference for the sparse kernels (full populations, not zero-centred)."""

import numpy as np

from porepipe.lbm._lattice import OPPOSITE, C, Q, W, dhumieres_matrix


def collision_matrix(kind: str, tau: float, magic: float = 3 / 16, tau_bulk: float = 1.0) -> np.ndarray:
    """19 x 19 matrix A of f_post = f − A (f − f_eq) + φ, built without any shortcut of the kernels."""
    if kind == "bgk":
        return np.eye(Q) / tau
    if kind == "trt":
        plus = np.zeros((Q, Q))
        minus = np.zeros((Q, Q))
        for i in range(Q):
            plus[i, i] += 0.5
            plus[i, OPPOSITE[i]] += 0.5
            minus[i, i] += 0.5
            minus[i, OPPOSITE[i]] -= 0.5
        tau_minus = 0.5 + magic / (tau - 0.5)
        return plus / tau + minus / tau_minus
    m = dhumieres_matrix()
    s = np.array(
        [
            0,
            1 / tau_bulk,
            1.4,
            0,
            1.2,
            0,
            1.2,
            0,
            1.2,
            1 / tau,
            1.4,
            1 / tau,
            1.4,
            1 / tau,
            1 / tau,
            1 / tau,
            1.98,
            1.98,
            1.98,
        ]
    )
    return np.linalg.inv(m) @ np.diag(s) @ m


def equilibrium(rho, u):
    """f_eq (19, ...) of density rho (...) and velocity u (3, ...)."""
    cu = np.tensordot(C.astype(float), u, axes=(1, 0))
    uu = np.sum(u * u, axis=0)
    return W.reshape((Q,) + (1,) * rho.ndim) * rho * (1 + 3 * cu + 4.5 * cu**2 - 1.5 * uu)


def step(f, pore, periodic, a_matrix, force, force_mask):
    """One pull step on dense (19, L0, L1, L2) populations that hold post-collision values of the last step.

    Returns (new post-collision populations, rho, velocity u = (j + ρ b / 2)/ρ of the gathered populations).
    """
    shape = pore.shape
    g = np.zeros_like(f)
    idx = np.indices(shape)
    for q in range(Q):
        src = [idx[k] - C[q, k] for k in range(3)]
        inside = np.ones(shape, dtype=bool)
        for k in range(3):
            if periodic[k]:
                src[k] %= shape[k]
            else:
                inside &= (src[k] >= 0) & (src[k] < shape[k])
                src[k] = np.clip(src[k], 0, shape[k] - 1)
        upstream_fluid = inside & pore[src[0], src[1], src[2]]
        g[q] = np.where(upstream_fluid, f[q][src[0], src[1], src[2]], f[OPPOSITE[q]])
    rho = g.sum(axis=0)
    j = np.tensordot(C.T.astype(float), g, axes=(1, 0))
    feq = equilibrium(rho, j / rho)
    b = np.asarray(force, dtype=float).reshape(3, 1, 1, 1) * force_mask
    phi = 3 * W.reshape(Q, 1, 1, 1) * rho * np.tensordot(C.astype(float), b, axes=(1, 0))
    post = g - np.tensordot(a_matrix, g - feq, axes=(1, 0)) + phi
    post = np.where(pore, post, 0.0)
    return post, rho, j / rho + b / 2
