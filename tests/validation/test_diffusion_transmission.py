"""Free-molecular transmission against published values.

References: an independent continuous-duct Monte Carlo (tests/unit/diffusion/naive_diffusion.py), Clausing's W of a cylinder (Lambert walls and inlet; Clausing 1932, as tabulated in the digest §5.4:
0.6720, 0.5142, 0.3566, 0.1909 for L/R = 1, 2, 4, 10; at other L/R from his integral equation, solved in
naive_diffusion.clausing_w, which reproduces this table), a continuous-tube Monte Carlo (no voxels) and the digest's
square-channel table (a = 30, L = 300; its own Monte Carlo, quoted to 3 digits, so ±0.0005 rounding). Every tolerance is 3 σ of the batch-means error of W
(combined with the reference's rounding), plus, for the staircase cylinders, the measured voxelisation error.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "unit" / "diffusion"))
from naive_diffusion import clausing_w, cylinder_w_naive, rect_channel_w_naive

from porepipe.diffusion import InletLaw, Settings, WallLaw, cylinder, square_capillary, transport

CLAUSING = {1: 0.6720, 2: 0.5142, 4: 0.3566, 10: 0.1909}


def _w(pore, settings, seed, voxel=1.0):
    r = transport(pore, 2, settings, voxel_um=voxel, seed=seed)
    assert r.values["truncated"] == 0
    return r.values["W"], r.values["W_err"], r


@pytest.mark.parametrize(
    "wall,inlet,ref",
    [
        (WallLaw.lambert, InletLaw.lambert, 0.119),
        (WallLaw.isotropic, InletLaw.lambert, 0.143),
    ],
)
def test_square_channel_30x300(wall, inlet, ref):
    s = Settings(wall_law=wall, inlet_law=inlet, batches=32, batch_particles=1500, max_rounds=1)
    w, err, r = _w(square_capillary(30, 300).pore, s, seed=1)
    assert abs(w - ref) <= 3 * math.hypot(err, 0.0005)
    # an independent implementation: continuous duct, analytic ray-plane hits, vectorised numpy (no voxels, no DDA)
    w_ref, e_ref = rect_channel_w_naive(30, 30, 300, wall.value, inlet.value, n=40000, seed=3)
    assert abs(w - w_ref) <= 3 * math.hypot(err, e_ref)
    # the binomial error of 48 000 independent particles agrees with the batch-means error (to its own ±25 %)
    assert err == pytest.approx(math.sqrt(w * (1 - w) / 48000), rel=0.4)
    # D = v̄ L W / 4 in voxel²/jiffie, and in SI from N2 at 298.15 K with 1 µm voxels
    assert r.values["D"] == pytest.approx(300 * w / 4, rel=1e-12)
    assert r.values["D_m2_s"] == pytest.approx(r.values["D"] * 1e-6 * r.values["mean_speed_m_s"], rel=1e-12)


def test_specular_straight_channel_transmits_everything():
    s = Settings(wall_law=WallLaw.specular, batches=8, batch_particles=500, max_rounds=1)
    w, _, r = _w(square_capillary(7, 200).pore, s, seed=2)
    assert w == 1.0 and r.values["wall_hits"] > 0


def test_cylinders_converge_to_clausing():
    """Staircase cylinders R = 8 and 16 voxels: |W16 - W_Clausing| <= 3 σ + |W16 - W8| (measured voxelisation
    error, the first-order Richardson bound), and the pooled residuals at R = 16 are consistent with the noise."""
    s = Settings(batches=32, batch_particles=2500, max_rounds=1)
    z2 = []
    for lr, ref in CLAUSING.items():
        w8, _, _ = _w(cylinder(8, 8 * lr).pore, s, seed=10 + lr)
        w16, e16, _ = _w(cylinder(16, 16 * lr).pore, s, seed=20 + lr)
        assert abs(w16 - ref) <= 3 * math.hypot(e16, 5e-5) + abs(w16 - w8), (lr, w8, w16, ref)
        assert abs(w8 - ref) / ref < 0.03  # already within 3 % at 8 voxels per radius
        z2.append(((w16 - ref) / e16) ** 2)
    assert sum(z2) < 18.5  # chi^2 with 4 degrees of freedom, p = 0.001


def test_clausing_integral_equation_and_continuous_tube():
    """The integral-equation W reproduces the 4-digit table; a continuous tube (exact geometry, no voxels) meets it
    within 3 σ of its binomial error at L/R = 0.125 and 1 (so the gap of the staircase tubes below is theirs)."""
    for lr, ref in CLAUSING.items():
        assert clausing_w(lr) == pytest.approx(ref, abs=5e-5)  # the table's last-digit rounding
    for lr, seed in ((0.125, 31), (1.0, 32)):
        w, err = cylinder_w_naive(1.0, lr, n=2_000_000, seed=seed)
        assert abs(w - clausing_w(lr)) <= 3 * err, (lr, w, err)


def test_short_staircase_tube_converges_at_first_order():
    """L/R = 0.125 (length R/8 voxels) at R = 32, 64, 128 voxels: the staircase wall lowers W by about 0.065/R
    (docs/results.md). R (W_R - W_Clausing) is the same at every R within the noise (first order: chi^2 with 2
    degrees of freedom, p = 0.001), and below 0 by more than 5 σ; W_32 and W_128 differ by more than 5 σ (not an
    R-independent offset); the first-order Richardson value 2 W_128 - W_64 meets Clausing's W within 3 σ (nothing that
    refinement leaves behind). Every σ is the batch-means error of W (12.8 million particles per R: ~7e-5)."""
    ref = clausing_w(0.125)
    s = Settings(batches=32, batch_particles=400_000, max_rounds=1)
    radii = np.array([32, 64, 128])
    runs = [_w(cylinder(r, r / 8).pore, s, seed=40 + k) for k, r in enumerate(radii)]
    w, err = np.array([r[0] for r in runs]), np.array([r[1] for r in runs])
    scaled, scaled_err = radii * (w - ref), radii * err
    weights = scaled_err**-2
    c = np.sum(weights * scaled) / np.sum(weights)
    assert np.sum(((scaled - c) / scaled_err) ** 2) < 13.8, (w, scaled)
    assert c < -5 / np.sqrt(np.sum(weights)), (w, c)
    assert abs(w[2] - w[0]) > 5 * math.hypot(err[2], err[0]), w
    assert abs(2 * w[2] - w[1] - ref) <= 3 * math.hypot(2 * err[2], err[1]), (w, ref)


def test_anisotropic_voxels_give_the_same_tube():
    """A z-invariant tube with 3x longer voxels along z is the same body: W agrees within 3 σ."""
    s = Settings(batches=32, batch_particles=1000, max_rounds=1)
    w1, e1, _ = _w(cylinder(6, 24).pore, s, seed=5)
    tube = cylinder(6, 24, voxel=(1.0, 1.0, 3.0))
    assert tube.pore.shape[2] == 8
    w3, e3, r = _w(tube.pore, s, seed=6, voxel=tube.voxel)
    assert abs(w1 - w3) <= 3 * math.hypot(e1, e3)
    assert r.values["length"] == pytest.approx(24.0)
    np.testing.assert_allclose(r.values["W"], w3)
