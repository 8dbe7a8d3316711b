"""Flow velocities in µm/s and their mean and variance over the pore voxels (Zauner 2020, §6.2 units; Table 8.5).

Truth: plane Poiseuille flow with TRT Λ = 3/16, whose node values are the exact parabola v̂(y) = b̂ y (h − y) / (2ν̂)
with walls halfway (y = k + ½, ν̂ = (τ̂ − ½)/3; tests/validation/test_lbm_calibration.py shows κ̂ to 1e-7), and the
thesis's unit rule Δt = Δx / (√3 c_s) (Eq. 6.1.7 with c_s = 1 m/s).
"""

import numpy as np
import pytest

from porepipe.lbm import Settings, permeability
from porepipe.lbm._velocity import time_step_s, velocity_um_s


def test_time_step_and_velocity_of_the_thesis_units():
    assert time_step_s(1.0, 1.0) == pytest.approx(1e-6 / np.sqrt(3), rel=1e-15)  # "Δt ≈ 10⁻⁶ s" at Δx = 1 µm
    # one voxel per step at Δx = 3.7 µm is Δx/Δt = √3 · 1 m/s, whatever the voxel
    assert velocity_um_s(1.0, 1.0) == pytest.approx(3.7 / time_step_s(3.7, 1.0), rel=1e-14)


@pytest.mark.parametrize("sound_speed", [1.0, 2.5])
def test_slit_mean_and_variance_are_the_parabolas(sound_speed):
    h, tau, b = 8, 0.8, 1e-6
    pore = np.zeros((3, 2, h + 2), dtype=bool)
    pore[:, :, 1:-1] = True
    settings = Settings(
        collision="trt",
        tau=tau,
        body_force=b,
        sound_speed_m_s=sound_speed,
        tolerance_kappa=1e-9,
        tolerance_velocity=1e-8,
    )
    res = permeability(pore, "x", settings, voxel_um=3.7, progress=False)
    y = np.arange(h) + 0.5
    v = b * y * (h - y) / (2 * (tau - 0.5) / 3) * np.sqrt(3) * sound_speed * 1e6  # µm/s at the fluid nodes
    assert res.mean_velocity_um_s == pytest.approx(v.mean(), rel=1e-6)
    assert res.velocity_variance_um2_s2 == pytest.approx(v.var(), rel=1e-5)
    ds = res.to_dataset()
    assert (
        ds.mean_velocity_um_s.attrs["units"] == "µm/s"
        and float(ds.mean_velocity_um_s) == res.mean_velocity_um_s
    )
    assert res.attrs()["time_step_s"] == pytest.approx(time_step_s(3.7, sound_speed))


def test_pore_voxels_the_lattice_drops_count_at_rest():
    """A dead-end pocket (pruned: it carries no flow) lowers the mean by its share of the pore voxels."""
    h = 6
    pore = np.zeros((4, 4, h + 4), dtype=bool)
    pore[:, :, 1 : h + 1] = True
    pore[1, 1, h + 2] = True  # isolated pore voxel
    settings = Settings(collision="trt", tau=0.8, tolerance_kappa=1e-9, tolerance_velocity=1e-8)
    res = permeability(pore, "x", settings, voxel_um=1.0, progress=False)
    open_only = permeability(
        pore & (np.arange(h + 4) <= h)[None, None, :], "x", settings, voxel_um=1.0, progress=False
    )
    n, n_open = pore.sum(), pore.sum() - 1
    assert res.mean_velocity_um_s == pytest.approx(open_only.mean_velocity_um_s * n_open / n, rel=1e-9)
