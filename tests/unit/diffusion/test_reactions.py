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
        r = D.reactive_pore(pore, 2, w, particles=16000, seed=2, z_bins=8)
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
        r = D.reactive_pore(pore, 2, w, particles=64000, seed=3, z_bins=8)
        etas.append(r["eta"])
        if w == 0.002:
            phi = 8.0 * math.sqrt(w * r["k0_max"] / 1.5)
            assert r["eta"] == pytest.approx(float(eta_slab_mouth(phi, 8.0, 1.5, 1.0)), abs=3 * r["eta_err"])
            assert r["eta"] > 0.95
    assert etas[0] > etas[1] > etas[2]
    r0 = D.reactive_pore(pore, 2, 0.0, particles=1000, seed=3, z_bins=8)
    assert r0["products"] == 0 and r0["reactions"] == 0 and "eta" not in r0


def test_reverse_reaction_lowers_the_product_rate_and_follow_up_the_selectivity():
    """Thesis Tables 4.3/4.4 trends: a reverse reaction P → A lowers r_eff; a follow-up P → S lowers the P rate
    (selectivity < 1) and produces S. Same seed: the runs share their random streams up to the first change."""
    pore = square_capillary(4, 20).pore
    base = D.reactive_pore(pore, 2, 0.05, particles=8000, seed=4, z_bins=8)
    rev = D.reactive_pore(pore, 2, 0.05, w_reverse=0.05, particles=8000, seed=4, z_bins=8)
    fol = D.reactive_pore(pore, 2, 0.05, w_follow=0.05, particles=8000, seed=4, z_bins=8)
    assert rev["r_eff"] < base["r_eff"] - 3 * math.hypot(rev["r_eff_err"], base["r_eff_err"])
    assert fol["r_eff"] / base["r_eff"] < 0.95
    assert fol["byproducts"] > 0
    with pytest.raises(PorepipeError, match="probability"):
        D.reactive_pore(pore, 2, 1.5)


def test_reactive_hit_map_and_reactant_profile(channel):
    """Along a uniform channel wall hits come at the same rate ν everywhere, so the reactive hits per axial bin are
    w·ν·(time spent there as A) — exact; checked per bin within 4 Poisson σ. The reactant profile c_A/c₀ falls
    from the mouth, and Φ fitted to it by (4.11) agrees with Φ from η by bisection within 5 % (the thesis's two
    methods; here both come from one run of 16000 histories)."""
    pore, _, _ = channel
    w = 0.01
    r = D.reactive_pore(pore, 2, w, particles=16000, seed=5, z_bins=16)
    expected = w * r["k0_max"] * r["z_time_reactant"]
    assert np.all(np.abs(r["z_react"] - expected) <= 4 * np.sqrt(expected) + 1)
    prof = r["reactant_profile"]
    assert np.all(np.diff(prof) < 0.02) and prof[0] > 3 * prof[-1]
    assert r["phi_profile"] == pytest.approx(r["phi"], rel=0.05)


def test_active_sites_only_in_the_front_half_react_only_there():
    """Active-site distribution: sites = 1 in the front half of a 4 x 4 x 16 channel, 0 behind — no reactive hit
    in the back half (exact), and the same run without sites reacts in both halves."""
    pore = square_capillary(4, 16).pore
    sites = np.zeros(pore.shape)
    sites[:, :, :8] = 1.0
    r = D.reactive_pore(pore, 2, 0.05, particles=4000, seed=6, z_bins=8, sites=sites)
    assert r["z_react"][4:].sum() == 0 and r["z_react"][:4].sum() > 100
    full = D.reactive_pore(pore, 2, 0.05, particles=4000, seed=6, z_bins=8)
    assert full["z_react"][4:].sum() > 0
    with pytest.raises(PorepipeError, match="sites"):
        D.reactive_pore(pore, 2, 0.05, sites=-sites)


def test_poisoning_deactivates_the_mouth_first_and_lowers_the_rate():
    """Quasi-static poisoning (each reaction multiplies its voxel's activity by e^-0.05): over 4 rounds the product
    rate falls round by round beyond 3 σ, and the sites near the mouth (first quarter) lose more activity than those
    at the back wall (the reactant reaches the back less often)."""
    pore = square_capillary(4, 16).pore
    r = D.reactive_pore(pore, 2, 0.05, particles=4000, seed=7, z_bins=8, poisoning=0.05, rounds=4)
    rates = r["r_eff_rounds"]
    round_err = 2 * r["r_eff_err"]  # one round holds 1/4 of the histories
    assert rates[-1] < rates[0] - 3 * math.sqrt(2) * round_err
    sites = r["sites"]
    wall_layer = sites[0]  # voxels along one lateral wall (all touch it)
    assert wall_layer[:, :4].mean() < wall_layer[:, -4:].mean() < 1.0


def test_adsorption_residence_slows_the_rate_by_the_renewal_factor():
    """Adsorption (probability p = 0.3 per wall hit, mean residence τ = 8 jiffies, fixed and exponential): the path
    sequence is unchanged, only time is added, so by renewal-reward r_eff falls by exactly 1/(1 + p·ν·τ) with
    ν = 1/a the free wall-hit rate (kinetic theory), the adsorbed time fraction is p·ν·τ/(1 + p·ν·τ), and η (per hit)
    stays. Tolerances 4 σ of the batch errors (ν's kinetic value is exact; the measured one is within 1 %)."""
    pore = square_capillary(4, 16).pore
    base = D.reactive_pore(pore, 2, 0.05, particles=8000, seed=8, z_bins=8)
    factor = 1 + 0.3 * 0.25 * 8.0
    for law in ("fixed", "exponential"):
        ads = D.reactive_pore(
            pore, 2, 0.05, particles=8000, seed=9, z_bins=8, adsorption=0.3, residence=8.0, residence_law=law
        )
        assert ads["r_eff"] == pytest.approx(
            base["r_eff"] / factor, abs=4 * math.hypot(ads["r_eff_err"], base["r_eff_err"] / factor)
        )
        assert ads["adsorbed_fraction"] == pytest.approx((factor - 1) / factor, rel=0.02)
        assert ads["eta"] == pytest.approx(base["eta"], abs=4 * math.hypot(ads["eta_err"], base["eta_err"]))
    with pytest.raises(PorepipeError, match="residence_law"):
        D.reactive_pore(pore, 2, 0.05, adsorption=0.3, residence=1.0, residence_law="gamma")
