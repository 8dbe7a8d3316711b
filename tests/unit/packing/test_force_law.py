"""The pair law of §5.2 (as re-derived in porepipe.packing._api): potential, force, continuity, limits."""

import math

import numpy as np
import pytest

from porepipe.packing._kernels import LJ_M, LJ_N, _pair_dxeq, _pair_force, _pair_potential

KS = [1.0, 20.0, 400.0, 1200.0]
DXEQ = [0.17, 1.9, 85.0]


@pytest.mark.parametrize("k", KS)
@pytest.mark.parametrize("dxeq", DXEQ)
def test_force_is_minus_potential_gradient(k, dxeq):
    # central differences with h = 1e-6 dx_eq: truncation O(h^2 V''') and round-off O(eps V / h) are both
    # below 1e-6 of the force scale k / dx_eq, so rtol 1e-5 of that scale is safe
    h = 1e-6 * dxeq
    scale = (math.sqrt(k) * (1 + k / 4) + k) / dxeq
    for dx in np.linspace(0.02, 2.5, 97) * dxeq:
        if abs(dx - dxeq) < 2 * h:
            continue
        numeric = -(_pair_potential(dx + h, dxeq, k) - _pair_potential(dx - h, dxeq, k)) / (2 * h)
        assert _pair_force(dx, dxeq, k) == pytest.approx(numeric, abs=1e-5 * scale)


@pytest.mark.parametrize("k", KS)
def test_continuous_at_equilibrium_with_zero_force(k):
    dxeq = 3.0
    eps = 1e-9 * dxeq
    # V(dx_eq) = V_min = -k/4 from both sides (5.2.2); relative 1e-12 is a few ulps of k
    assert _pair_potential(dxeq, dxeq, k) == pytest.approx(-k / 4, rel=1e-12)
    assert _pair_potential(dxeq * (1 + 1e-12), dxeq, k) == pytest.approx(-k / 4, rel=1e-9)
    assert _pair_force(dxeq, dxeq, k) == 0.0
    # the force changes sign at dx_eq: repulsive inside, attractive outside, and tends to 0 from both sides
    assert _pair_force(dxeq - eps, dxeq, k) > 0 and _pair_force(dxeq + eps, dxeq, k) < 0
    assert (
        abs(_pair_force(dxeq - eps, dxeq, k)) < 1e-6 * k and abs(_pair_force(dxeq + eps, dxeq, k)) < 1e-6 * k
    )


@pytest.mark.parametrize("k", KS)
def test_finite_force_and_potential_at_contact_zero(k):
    dxeq = 2.0
    # closed forms f^H(0) = sqrt(k)(1 - V_min)/dx_eq, V^H(0) = sqrt(k)(1 + k/4)/2 - k/4 (digest §2.2)
    assert _pair_force(0.0, dxeq, k) == pytest.approx(math.sqrt(k) * (1 + k / 4) / dxeq, rel=1e-14)
    assert _pair_potential(0.0, dxeq, k) == pytest.approx(math.sqrt(k) * (1 + k / 4) / 2 - k / 4, rel=1e-14)


@pytest.mark.parametrize("k", KS)
def test_lj_branch_matches_printed_generalised_form(k):
    # f^LJ = k [m b^m / dx^(m+1) - n b^n / dx^(n+1)], b = (n/m)^(1/(m-n)) dx_eq (5.2.3), evaluated literally
    dxeq = 5.0
    b = (LJ_N / LJ_M) ** (1 / (LJ_M - LJ_N)) * dxeq
    for dx in np.linspace(1.001, 3.0, 40) * dxeq:
        literal = k * (LJ_M * b**LJ_M / dx ** (LJ_M + 1) - LJ_N * b**LJ_N / dx ** (LJ_N + 1))
        assert _pair_force(dx, dxeq, k) == pytest.approx(literal, rel=1e-12, abs=1e-15 * k)
        v_literal = k * ((b / dx) ** LJ_M - (b / dx) ** LJ_N)
        assert _pair_potential(dx, dxeq, k) == pytest.approx(v_literal, rel=1e-12, abs=1e-15 * k)


def test_peak_attraction_position_and_value():
    # analytic: d f / d dx = 0 at dx = (17/9)^(1/8) dx_eq, |f| = 0.9204 k / dx_eq (digest §2.2, 4 digits)
    k, dxeq = 10.0, 1.0
    grid = np.linspace(1.0, 1.5, 200001)
    f = np.array([_pair_force(d, dxeq, k) for d in grid])
    assert grid[f.argmin()] == pytest.approx((17 / 9) ** (1 / 8), abs=1e-5)
    assert -f.min() == pytest.approx(0.9204 * k / dxeq, rel=1e-4)


def test_equilibrium_distance_of_the_overlap_window():
    # dx_eq is the midpoint of [dx_min, dx_max]: overlap sigma_max / 2 relative to 2 min(r_i, r_j) (§5.1)
    for ri, rj, s in [(1.0, 1.0, 0.3), (100.0, 1.0, 0.25), (3.0, 7.0, 0.5)]:
        dxeq = _pair_dxeq(ri, rj, s)
        sigma = (ri + rj - dxeq) / (2 * min(ri, rj))
        assert sigma == pytest.approx(s / 2, rel=1e-12)


@pytest.mark.parametrize("k", [1.0, 20.0, 400.0, 1200.0])
def test_kernel_fast_path_equals_reference_force_over_distance(k):
    """The step kernel's f/dx (precomputed sqrt(k)(1 + k/4), one reciprocal) equals the reference f(dx)/dx to
    round-off (1e-13 relative: a few ulps of the different operation order) on both branches and across dx_eq."""
    from porepipe.packing._kernels import _pair_force_over_dist

    dxeq = 2.3
    hcoef = np.sqrt(k) * (1.0 + 0.25 * k)
    for dx in np.concatenate([np.linspace(1e-3, 1.3 * dxeq, 701), [dxeq, np.nextafter(dxeq, 9.0)]]):
        ref = _pair_force(dx, dxeq, k) / dx
        fast = _pair_force_over_dist(dx, dxeq, k, hcoef)
        assert fast == pytest.approx(ref, rel=1e-13, abs=1e-13 * abs(hcoef / dxeq**2))
