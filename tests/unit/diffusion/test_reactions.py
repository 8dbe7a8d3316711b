"""Wall reactions (Mahler 2001 §4.1-4.2): the η(Φ) algebra, and the Knudsen reactive pore against Thiele.

Truths: η = tanh Φ/Φ and its bisection inverse (the thesis's Φ = 1.2386 ↔ η = 0.68227, Fig. 4.8), the slab
reaction-diffusion solution with the D the Knudsen engine measures in the same channel, and the w → 0 limit.
"""

import math

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.diffusion import Settings, equilibrium, square_capillary
from porepipe.diffusion import _edmd as D
from porepipe.diffusion._reactions import (
    diffusion_under_reaction,
    eta_of_phi,
    eta_slab_mouth,
    fit_alpha_r,
    phi_of_eta,
    profile_phi,
)


def test_bisection_matches_the_thesis_pair_and_inverts_tanh():
    """Thesis Fig. 4.8: Φ = 1.2386 gives η = 0.68227 (5 digits printed: tolerance 5e-5 on η, 2e-4 on Φ)."""
    assert float(eta_of_phi(1.2386)) == pytest.approx(0.68227, abs=5e-5)
    assert phi_of_eta(0.68227) == pytest.approx(1.2386, abs=2e-4)
    for phi in (1e-3, 0.5, 3.0, 40.0):
        assert phi_of_eta(float(eta_of_phi(phi))) == pytest.approx(phi, rel=1e-9)
    assert phi_of_eta(1.0) == 0.0
    assert phi_of_eta(1e-3) == pytest.approx(1e3, rel=1e-6)  # η → 1/Φ for large Φ
    for bad in (0.0, 1.5, -0.1, math.nan):
        with pytest.raises(PorepipeError, match="effectiveness"):
            phi_of_eta(bad)


def test_profile_fit_and_alpha_r_recover_known_parameters():
    """(4.11) fitted to an exact cosh profile returns its Φ (to 1e-6); (4.13) fitted to exact 1/D_R(η) returns α_R;
    (4.12) D_R = L²k/Φ²."""
    z = np.linspace(0, 1, 25)
    assert profile_phi(z, np.cosh(2.3 * (1 - z)) / np.cosh(2.3)) == pytest.approx(2.3, abs=1e-6)
    eta = np.array([0.9, 0.6, 0.4, 0.2])
    d_r = 1.0 / (0.5 * (1 + 3.7 * (1 - eta) / eta))
    alpha, a, _ = fit_alpha_r(eta, d_r)
    assert alpha == pytest.approx(3.7, rel=1e-10)
    assert a == pytest.approx(0.5, rel=1e-10)
    assert diffusion_under_reaction(2.0, 10.0, 0.3) == pytest.approx(100 * 0.3 / 4)


@pytest.fixture(scope="module")
def channel():
    """Square channel 4 x 4 x 80 voxels and its intrinsic axial Knudsen D from the engine's msd (periodic axis)."""
    pore = square_capillary(4, 80).pore
    s = Settings(setup="msd", batches=16, batch_particles=200, msd_time_jiffies=2000.0, max_rounds=1)
    eq = equilibrium(pore, s, periodic=(False, False, True), seed=1)
    return pore, eq.values["D_zz"], eq.values["D_zz_err"]


def test_first_order_reaction_in_a_long_channel_follows_thiele(channel):
    """One-face feed, specular back wall, Lambert walls, w = 0.002 and 0.01 (Φ ≈ 1.5 and 3.3): η = products/(w·hits)
    against the slab solution with Φ = L√(w·ν/D), ν the measured wall-hit rate and D the engine's msd value.

    Truth: Thiele's tanh Φ/Φ with the Knudsen mouth condition (``eta_slab_mouth``: Marshak, extrapolation 2D/v̄);
    tolerance 3 σ (η's batch error and D's error propagated through Φ) + 4 % model error (continuum description of
    free-molecular flow at decay lengths of 6-14 channel widths; measured deviations 2-4 %). The bare tanh Φ/Φ lies
    further off (mouth correction 5-12 %), so the check also shows which description holds.
    """
    pore, d, d_err = channel
    length = 80.0
    for w in (0.002, 0.01):
        r = D.reactive_pore(pore, 2, w, particles=16000, seed=2)
        assert r["truncated"] == 0
        phi = length * math.sqrt(w * r["k0_max"] / d)
        truth = float(eta_slab_mouth(phi, length, d, 1.0))
        slope = abs(float(eta_slab_mouth(phi * 1.001, length, d, 1.0)) - truth) / (0.001 * phi)
        sigma = math.hypot(r["eta_err"], slope * phi * 0.5 * d_err / d)
        assert abs(r["eta"] - truth) <= 3 * sigma + 0.04 * truth
        assert abs(r["eta"] - truth) < abs(r["eta"] - float(eta_of_phi(phi)))
        assert r["k0_max"] == pytest.approx(0.25, rel=0.03)  # ν = v̄S/(4V) = 1/a (kinetic theory)


def test_eta_tends_to_one_as_w_vanishes_and_falls_with_w():
    """Short channel (4 x 4 x 8): η(w = 0.002) within 3 σ of the (≈0.99) slab value and above 0.95; η falls
    monotonically with w (thesis Table 4.2's trend); w = 0 reacts never (no η) and costs nothing extra."""
    pore = square_capillary(4, 8).pore
    etas = []
    for w in (0.002, 0.05, 0.5):
        r = D.reactive_pore(pore, 2, w, particles=64000, seed=3)
        etas.append(r["eta"])
        if w == 0.002:
            phi = 8.0 * math.sqrt(w * r["k0_max"] / 1.5)
            assert r["eta"] == pytest.approx(float(eta_slab_mouth(phi, 8.0, 1.5, 1.0)), abs=3 * r["eta_err"])
            assert r["eta"] > 0.95
    assert etas[0] > etas[1] > etas[2]
    r0 = D.reactive_pore(pore, 2, 0.0, particles=1000, seed=3)
    assert r0["products"] == 0 and r0["reactions"] == 0 and "eta" not in r0


def test_reverse_reaction_lowers_the_product_rate_and_follow_up_the_selectivity():
    """Thesis Tables 4.3/4.4 trends: a reverse reaction P → A lowers r_eff; a follow-up P → S lowers the P rate
    (selectivity < 1) and produces S. Same seed: the runs share their random streams up to the first change."""
    pore = square_capillary(4, 20).pore
    base = D.reactive_pore(pore, 2, 0.05, particles=8000, seed=4)
    rev = D.reactive_pore(pore, 2, 0.05, w_reverse=0.05, particles=8000, seed=4)
    fol = D.reactive_pore(pore, 2, 0.05, w_follow=0.05, particles=8000, seed=4)
    assert rev["r_eff"] < base["r_eff"] - 3 * math.hypot(rev["r_eff_err"], base["r_eff_err"])
    assert fol["r_eff"] / base["r_eff"] < 0.95
    assert fol["byproducts"] > 0
    with pytest.raises(PorepipeError, match="probability"):
        D.reactive_pore(pore, 2, 1.5)
