"""Slow, obviously-right references for the packing kernels (all-pairs NumPy, no cell lists)."""

from __future__ import annotations

import numpy as np


def min_image(d: np.ndarray, box: np.ndarray, periodic: np.ndarray) -> np.ndarray:
    per = np.asarray(periodic, bool)
    d = d.copy()
    d[..., per] -= box[per] * np.round(d[..., per] / box[per])
    return d


def pair_distances(x: np.ndarray, box, periodic) -> np.ndarray:
    """(N, N) minimum-image distances."""
    d = min_image(x[:, None, :] - x[None, :, :], np.asarray(box, float), periodic)
    return np.sqrt((d * d).sum(-1))


def max_overlaps(x, r, box, periodic, types=None, pair_on=None) -> np.ndarray:
    """max_j sigma_ij over touching/overlapping partners (sigma >= 0), -inf if none; O(N^2)."""
    dist = pair_distances(x, box, periodic)
    rsum = r[:, None] + r[None, :]
    sig = (rsum - dist) / (rsum - np.abs(r[:, None] - r[None, :]))
    np.fill_diagonal(sig, -np.inf)
    if pair_on is not None:
        sig[pair_on[types[:, None], types[None, :]] == 0] = -np.inf
    sig[sig < 0] = -np.inf
    return sig.max(axis=1)


def neighbour_pairs(x, r, box, periodic, cutoff, skin) -> set[tuple[int, int]]:
    """Unordered pairs with |x_i - x_j| <= cutoff (r_i + r_j) + skin."""
    dist = pair_distances(x, box, periodic)
    lim = cutoff * (r[:, None] + r[None, :]) + skin
    i, j = np.nonzero(np.triu(dist <= lim, 1))
    return set(zip(i.tolist(), j.tolist()))
