"""Permeability from a converged flow field by Darcy's law (thesis §6.1.5, Eqs. 6.1.35-6.1.39, 6.2.3).

All quantities in lattice units (Δx = Δt = ρ° = 1): p̂ = ρ̂/3, ν̂ = (τ̂ − ½)/3, κ̂ = κ/Δx².
"""

from __future__ import annotations

import dataclasses

import numpy as np

from porepipe.lbm._domain import Lattice
from porepipe.lbm._lattice import CS2
from porepipe.lbm._settings import Gradient, Velocity


@dataclasses.dataclass
class Sampler:
    """Per-node layer index and sample membership of the nodes one process owns, and the domain's layer layout.

    Slice averages run over whole slices (C(ℓ) ∩ P); only the sample average ⟨v⟩_S uses the lateral window. Layers
    are numbered over the whole domain, so the per-layer sums of several processes (each owning whole layers) add up
    exactly to those of one process.
    """

    layer: np.ndarray  # (N,) int64 layer of each node
    sample_nodes: np.ndarray  # (N,) bool: node in S
    n_layers: int
    sample_layers: tuple[int, int]  # half-open layer range of S
    everywhere: bool  # body force on every layer (periodic set-up)

    @classmethod
    def of(cls, lat: Lattice) -> Sampler:
        counts = np.diff(lat.layer_start)
        layer = np.repeat(np.arange(lat.shape[0], dtype=np.int64), counts)
        win = lat.node_window()
        s0, s1 = lat.sample_layers
        return cls(
            layer, win & (layer >= s0) & (layer < s1), lat.shape[0], (s0, s1), lat.body_force_everywhere
        )

    def layer_sums(self, values: np.ndarray) -> np.ndarray:
        """Σ over the pore nodes of every layer, C(ℓ) ∩ P (thesis Eq. 6.1.24)."""
        return np.bincount(self.layer, weights=values, minlength=self.n_layers)

    def tables(self, fields: np.ndarray) -> np.ndarray:
        """(6, n_layers) per-layer sums of the (4, N) fields: Σ ρu, Σ δρ, node count, and over the sample's nodes
        Σ u, Σ ρ, node count (:data:`TABLE_ROWS`). Every κ̂ estimate and sample mean follows from them.
        """
        d, u = fields[0], fields[1]
        rho = 1.0 + d
        inside = self.sample_nodes
        rows = (
            rho * u,
            d,
            np.ones_like(d),
            np.where(inside, u, 0.0),
            np.where(inside, rho, 0.0),
            inside * 1.0,
        )
        return np.stack([self.layer_sums(r) for r in rows])


#: rows of :meth:`Sampler.tables`
TABLE_ROWS = ("flux", "density", "nodes", "sample_velocity", "sample_rho", "sample_nodes")


def sample_mean_rho(tables: np.ndarray) -> float:
    """Mean ρ over the sample's pore nodes (1 where the sample has none)."""
    n = float(np.sum(tables[5]))
    return float(np.sum(tables[4])) / n if n else 1.0


def _slope(y: np.ndarray) -> float:
    if y.size < 2 or not np.all(np.isfinite(y)):
        return float("nan")
    x = np.arange(y.size, dtype=np.float64)
    return float(np.polyfit(x, y, 1)[0])


def estimates(
    sampler: Sampler,
    tables: np.ndarray,
    *,
    nu: float,
    body_force: float,
    sample_voxels: int,
    sample_area: int,
    trim_layers: int,
) -> dict[str, float]:
    """Every applicable κ̂ estimate of the current fields, keyed ``"<gradient>/<velocity>"``.

    Parameters
    ----------
    sampler : Sampler
        The domain's layer layout.
    tables : (6, n_layers) ndarray
        :meth:`Sampler.tables` of the fields (summed over the processes).
    sample_voxels, sample_area : int
        |S| (solid included) and the voxels of one cross-section of S.
    """
    flux, density, nodes = tables[0], tables[1], tables[2]
    s0, s1 = sampler.sample_layers
    n_s = s1 - s0
    u_mean = float(np.sum(tables[3])) / sample_voxels
    u_flux = float(np.mean(flux[s0:s1])) / (sample_mean_rho(tables) * sample_area)
    velocities = {Velocity.mean.value: u_mean, Velocity.flux.value: u_flux}
    out = {}
    if sampler.everywhere:
        for vname, v in velocities.items():
            out[f"body_force/{vname}"] = nu * v / body_force
        return out
    with np.errstate(invalid="ignore", divide="ignore"):
        rho_layer = 1.0 + density / nodes  # NaN where a layer has no node
    p_layer = CS2 * rho_layer
    rho_bar = 0.5 * (rho_layer[s0] + rho_layer[s1 - 1])
    w = min(trim_layers, max(0, (n_s - 2) // 2))
    grads = {
        Gradient.ends.value: (p_layer[s1 - 1] - p_layer[s0]) / (n_s - 1) if n_s > 1 else float("nan"),
        Gradient.fit.value: _slope(p_layer[s0:s1]),
        Gradient.fit_trimmed.value: _slope(p_layer[s0 + w : s1 - w]),
        Gradient.outside.value: (p_layer[s1 % sampler.n_layers] - p_layer[s0 - 1]) / (n_s + 1),
    }
    for gname, g in grads.items():
        for vname, v in velocities.items():
            with np.errstate(invalid="ignore", divide="ignore"):
                out[f"{gname}/{vname}"] = float(-nu * rho_bar * v / g) if g != 0 else float("nan")
    return out


def estimate_key(body_force_everywhere: bool, gradient: Gradient, velocity: Velocity) -> str:
    """Key of the estimate the settings select."""
    g = "body_force" if body_force_everywhere else gradient.value
    return f"{g}/{velocity.value}"
