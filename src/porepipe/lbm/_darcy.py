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
    """Precomputed per-node layer index and sample membership of one lattice.

    Slice averages run over whole slices (C(ℓ) ∩ P); only the sample average ⟨v⟩_S uses the lateral window.
    """

    layer: np.ndarray  # (N,) int64 layer of each node
    sample_nodes: np.ndarray  # (N,) bool: node in S
    n_layers: int

    @classmethod
    def of(cls, lat: Lattice) -> Sampler:
        counts = np.diff(lat.layer_start)
        layer = np.repeat(np.arange(lat.shape[0], dtype=np.int64), counts)
        win = lat.node_window()
        s0, s1 = lat.sample_layers
        return cls(layer, win & (layer >= s0) & (layer < s1), lat.shape[0])

    def layer_sums(self, values: np.ndarray) -> np.ndarray:
        """Σ over the pore nodes of every layer, C(ℓ) ∩ P (thesis Eq. 6.1.24)."""
        return np.bincount(self.layer, weights=values, minlength=self.n_layers)

    def layer_means(self, values: np.ndarray) -> np.ndarray:
        """Mean over the pore nodes of every layer, ⟨·⟩_{C(ℓ)∩P} (NaN where a layer has none)."""
        count = np.bincount(self.layer, minlength=self.n_layers)
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.layer_sums(values) / count


def _slope(y: np.ndarray) -> float:
    if y.size < 2 or not np.all(np.isfinite(y)):
        return float("nan")
    x = np.arange(y.size, dtype=np.float64)
    return float(np.polyfit(x, y, 1)[0])


def estimates(
    lat: Lattice,
    sampler: Sampler,
    fields: np.ndarray,
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
    fields : (4, N) ndarray
        δρ and the velocity (u_0 along the flow) per node.
    sample_voxels, sample_area : int
        |S| (solid included) and the voxels of one cross-section of S.
    """
    d, u = fields[0], fields[1]
    s0, s1 = lat.sample_layers
    n_s = s1 - s0
    rho = 1.0 + d
    u_mean = float(np.sum(u[sampler.sample_nodes])) / sample_voxels
    q_layer = sampler.layer_sums(rho * u)[s0:s1]
    rho_bar_s = float(np.mean(rho[sampler.sample_nodes])) if np.any(sampler.sample_nodes) else 1.0
    u_flux = float(np.mean(q_layer)) / (rho_bar_s * sample_area)
    velocities = {Velocity.mean.value: u_mean, Velocity.flux.value: u_flux}
    out = {}
    if lat.body_force_everywhere:
        for vname, v in velocities.items():
            out[f"body_force/{vname}"] = nu * v / body_force
        return out
    rho_layer = 1.0 + sampler.layer_means(d)
    p_layer = CS2 * rho_layer
    rho_bar = 0.5 * (rho_layer[s0] + rho_layer[s1 - 1])
    w = min(trim_layers, max(0, (n_s - 2) // 2))
    grads = {
        Gradient.ends.value: (p_layer[s1 - 1] - p_layer[s0]) / (n_s - 1) if n_s > 1 else float("nan"),
        Gradient.fit.value: _slope(p_layer[s0:s1]),
        Gradient.fit_trimmed.value: _slope(p_layer[s0 + w : s1 - w]),
        Gradient.outside.value: (p_layer[s1 % lat.shape[0]] - p_layer[s0 - 1]) / (n_s + 1),
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
