"""Flow velocities in physical units (Zauner 2020, §6.1.1 and §6.2) and their mean and variance (Table 8.5).

The thesis's pseudo-fluid has c_s = 1 m/s (§6.2), so the time step follows from Eq. 6.1.7, c_s = Δx / (√3 Δt):
Δt = Δx / (√3 c_s), and a lattice velocity v̂ (voxels per step) is v = v̂ Δx / Δt = √3 c_s v̂ — independent of the
voxel size. With b̂ = 10⁻⁶ the velocities are those of the thesis's forcing, not of a chosen pressure drop: compare
them between runs with the same b̂ and c_s only.
"""

from __future__ import annotations

import numpy as np

SQRT3 = 3.0**0.5


def time_step_s(voxel_um: float, sound_speed_m_s: float) -> float:
    """Δt = Δx / (√3 c_s) in seconds (Eq. 6.1.7)."""
    return voxel_um * 1e-6 / (SQRT3 * sound_speed_m_s)


def velocity_um_s(v_lu, sound_speed_m_s: float):
    """Lattice velocity (voxels per step) in µm/s: v̂ Δx / Δt = √3 c_s v̂."""
    return np.asarray(v_lu) * SQRT3 * sound_speed_m_s * 1e6


def flow_velocity_stats(
    flow_lu: np.ndarray, layer: np.ndarray, sample_layers, n_pore: int, sound_speed_m_s: float
):
    """Mean and variance (µm/s, µm²/s²) of the flow component over the sample's ``n_pore`` pore voxels.

    ``flow_lu`` is the flow component at the lattice's pore nodes and ``layer`` their index along the flow; nodes in
    ``sample_layers`` [s0, s1) count. Pore voxels the lattice dropped (clusters that carry no flow) count with v = 0.
    """
    s0, s1 = sample_layers
    v = velocity_um_s(flow_lu[(layer >= s0) & (layer < s1)], sound_speed_m_s)
    if n_pore == 0:
        return float("nan"), float("nan")
    mean = float(v.sum() / n_pore)
    return mean, float(max(np.dot(v, v) / n_pore - mean * mean, 0.0))
