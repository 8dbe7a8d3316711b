"""Silo and heap theory (porepipe.granular._theory) against direct numerical integration of the ODEs.

Truth: scipy ``solve_ivp`` (DOP853, rtol 1e-12, atol 1e-14) of the defining ODE, written out here independently of
the closed forms. Tolerance 1e-8 relative (the issue's bar); the integrator's own error is below 1e-10 at these
settings, so a failure means a wrong formula, not a loose integrator.
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from porepipe._shared.errors import PorepipeError
from porepipe.granular import _theory as T

RTOL = 1e-8
RHO_G = 0.78 * 5000 * 9.81


def _ode_sigma_zz(r, dr, k, mu_j, z_end, z_eval):
    """Eq. 3.10: d sigma/dz = rho g - mu_j sigma (r'² + k)/(r (1 + r'²)^{3/2}), sigma(0) = 0."""

    def rhs(z, y):
        d2 = dr(z) ** 2
        return [RHO_G - mu_j * y[0] * (d2 + k) / (r(z) * (1 + d2) ** 1.5)]

    sol = solve_ivp(rhs, (0.0, z_end), [0.0], method="DOP853", rtol=1e-12, atol=1e-14, t_eval=z_eval)
    return sol.y[0]


def test_janssen_matches_ode_and_saturates():
    r, k, mu_j = 0.2, 0.64, 0.33
    z = np.linspace(0.05, 3.0, 12)
    num = _ode_sigma_zz(lambda z: r, lambda z: 0.0, k, mu_j, 3.0, z)
    szz, sxx = T.janssen(z, r, k, mu_j, RHO_G)
    np.testing.assert_allclose(szz, num, rtol=RTOL)
    np.testing.assert_allclose(sxx, k * num, rtol=RTOL)
    # saturation value rho g r/mu_j (Eq. 3.4) far below the Janssen length r/(k mu_j) ~ 0.95 m
    assert T.janssen(60.0, r, k, mu_j, RHO_G)[1] == pytest.approx(RHO_G * r / mu_j, rel=1e-12)


@pytest.mark.parametrize(
    "shape",
    [
        (lambda z: 0.1 + 0.05 * np.sin(3 * z), lambda z: 0.15 * np.cos(3 * z)),  # wavy wall
        (lambda z: 0.1 - 0.03 * z, lambda z: -0.03),  # gentle hopper
    ],
)
def test_general_silo_matches_ode(shape):
    r, dr = shape
    k, mu_j = 0.7, 0.4
    z = np.array([0.1, 0.4, 0.9, 1.5])
    np.testing.assert_allclose(
        T.silo_sigma_zz(z, r, dr, k, mu_j, RHO_G), _ode_sigma_zz(r, dr, k, mu_j, 1.5, z), rtol=RTOL
    )


def test_stepped_silo_matches_piecewise_ode():
    r1, r2, h0, k, mu_j = 0.04, 0.02, 0.25, 0.64, 0.33
    z = np.linspace(0.02, 0.6, 15)
    # Eq. 3.15 is the Janssen ODE with r jumping at h0 (sigma continuous)
    sol1 = solve_ivp(
        lambda z, y: [RHO_G - mu_j * k * y[0] / r1],
        (0, h0),
        [0.0],
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
        dense_output=True,
    )
    s_h0 = sol1.y[0, -1]
    sol2 = solve_ivp(
        lambda z, y: [RHO_G - mu_j * k * y[0] / r2],
        (h0, 0.6),
        [s_h0],
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
        dense_output=True,
    )
    num = np.where(z <= h0, sol1.sol(np.minimum(z, h0))[0], sol2.sol(np.maximum(z, h0))[0])
    np.testing.assert_allclose(T.stepped_silo(z, r1, r2, h0, k, mu_j, RHO_G), k * num, rtol=RTOL)
    with pytest.raises(PorepipeError, match="narrowing"):
        T.stepped_silo(z, r2, r1, h0, k, mu_j, RHO_G)


@pytest.mark.parametrize("mu_j,k", [(0.30, 0.77), (0.37, 0.76)])
def test_hopper_corrected_formula_matches_ode(mu_j, k):
    a, b = -0.1087, 0.065  # the thesis's simulated hopper (§3.4)
    z = np.linspace(0.01, 0.55, 10)
    num = _ode_sigma_zz(lambda z: a * z + b, lambda z: a, k, mu_j, 0.55, z)
    np.testing.assert_allclose(T.hopper_sigma_zz(z, a, b, k, mu_j, RHO_G), num, rtol=RTOL)


def test_parabolic_xi_and_r_p():
    a, b, k = 100.0, 0.46, 0.86

    def r(u):
        return math.sqrt((b - u) / a)

    def dr(u):
        return -0.5 / (a * r(u))

    for zz in (0.05, 0.2, 0.4):
        # Eq. 3.20 against the defining integral Eq. 3.12 (additive constant removed, Eq. 3.13)
        direct = quad(
            lambda u: (dr(u) ** 2 + k) / (r(u) * (1 + dr(u) ** 2) ** 1.5), 0, zz, epsabs=0, epsrel=1e-13
        )[0]
        assert T.parabolic_xi(zz, a, b, k) - T.parabolic_xi(0.0, a, b, k) == pytest.approx(direct, rel=RTOL)
        assert T.silo_xi(zz, r, dr, k)[0] == pytest.approx(direct, rel=RTOL)
    # r_P is k/xi'(0) (Eq. 3.22 without the extra k)
    xi_prime0 = (dr(0) ** 2 + k) / (r(0) * (1 + dr(0) ** 2) ** 1.5)
    assert T.parabolic_r_p(a, b, k) == pytest.approx(k / xi_prime0, rel=1e-12)


def test_parabolic_sigma_matches_ode():
    a, b, k, mu_j = 100.0, 0.46, 0.86, 0.30
    z = np.array([0.05, 0.2, 0.35, 0.44])
    num = _ode_sigma_zz(
        lambda u: math.sqrt((b - u) / a), lambda u: -0.5 / (a * math.sqrt((b - u) / a)), k, mu_j, 0.44, z
    )
    np.testing.assert_allclose(T.parabolic_sigma_zz(z, a, b, k, mu_j, RHO_G), num, rtol=RTOL)


def test_fit_janssen_recovers_parameters():
    z = np.linspace(0.0, 0.3, 40)
    p = T.janssen(z, 0.02, 0.55, 0.3, RHO_G)[1]
    fit = T.fit_janssen(z, p, 0.02, RHO_G)
    assert fit["k"] == pytest.approx(0.55, rel=1e-6)
    assert fit["mu_j"] == pytest.approx(0.3, rel=1e-6)
    fixed = T.fit_janssen(z, p, 0.02, RHO_G, k=0.55)
    assert fixed["mu_j"] == pytest.approx(0.3, rel=1e-6)
    assert not fit["at_bound"] and not fixed["at_bound"]


def test_fit_janssen_flags_a_non_janssen_profile_and_refuses_what_it_cannot_fit():
    """A pressure that falls with depth pins the fit on a bound (flagged: its errors mean nothing); a pressure that
    is nowhere positive gave scipy's 'initial guess is outside of provided bounds', now one line; a NaN k is
    refused by the model itself."""
    z = np.linspace(0.01, 0.3, 12)
    assert T.fit_janssen(z, 3.0 - 5.0 * z, 0.02, RHO_G)["at_bound"]
    with pytest.raises(PorepipeError, match="nowhere positive"):
        T.fit_janssen(z, np.zeros_like(z), 0.02, RHO_G)
    with pytest.raises(PorepipeError, match="k must be a positive finite number"):
        T.fit_janssen(z, T.janssen(z, 0.02, 0.55, 0.3, RHO_G)[1], 0.02, RHO_G, k=float("nan"))


def test_bounds_and_ife_closure_are_mohr_coulomb():
    mu = 0.4
    bnd = T.lateral_pressure_bounds(mu)
    phi = bnd["phi_rad"]
    assert bnd["rankine_active"] < bnd["jaky"] < 1 < bnd["rankine_passive"]
    # IFE at U = 0 is Rankine's passive/active state
    assert T.closure_ife(0.0, phi, +1) == pytest.approx(bnd["rankine_passive"], rel=1e-12)
    assert T.closure_ife(0.0, phi, -1) == pytest.approx(bnd["rankine_active"], rel=1e-12)
    # for any U the Mohr circle of (C, 1, U) touches the failure line: (s1 - s2)/(s1 + s2) = sin phi
    for u in np.linspace(-0.9, 0.9, 7) * math.tan(phi):
        for br in (+1, -1):
            c = float(T.closure_ife(u, phi, br))
            radius = math.sqrt(0.25 * (c - 1) ** 2 + u * u)
            assert radius / (0.5 * (c + 1)) == pytest.approx(math.sin(phi), rel=1e-12)


def _wedge_ode(phi, eta, mu, s_from, s_to, y0, s_eval):
    """RSF equilibrium (Eqs. 1.9-1.10 with sigma = g z s(S)): t s_xx' + s_xz - S s_xz' = 0,
    t s_xz' + s_zz - S s_zz' = 1, closure s_xx = eta s_zz + mu s_xz; state (s_zz, s_xz)."""
    t = math.tan(phi)

    def rhs(S, y):
        szz, sxz = y
        m = np.array([[t * eta, t * mu - S], [-S, t]])
        return np.linalg.solve(m, [-sxz, 1 - szz])

    sol = solve_ivp(rhs, (s_from, s_to), y0, method="DOP853", rtol=1e-12, atol=1e-14, t_eval=s_eval)
    return sol.y


@pytest.mark.parametrize("model,kw", [("BCC", {}), ("FPA", {}), ("OSL", {"K": 0.6, "tau": 0.3})])
def test_wedge_linear_closures_match_ode(model, kw):
    phi = math.radians(28.0)
    eta, mu = T.closure_linear(model, phi, **kw)
    sc = T.wedge_stress(0.0, phi, eta, mu)["S_c"]
    # outer region: integrate inwards from the stress-free surface S = 1 (IFS) to just outside S_c
    s_out = np.linspace(1.0, sc + 0.02, 9)
    zz, xz = _wedge_ode(phi, eta, mu, 1.0, s_out[-1], [0.0, 0.0], s_out)
    w = T.wedge_stress(s_out, phi, eta, mu)
    np.testing.assert_allclose(zz[1:], w["zz"][1:], rtol=RTOL)
    np.testing.assert_allclose(xz[1:], w["xz"][1:], rtol=RTOL)
    # inner region: from the symmetric axis (s_xz(0) = 0) with the closed form's s_zz(0), out to S_c
    s_in = np.linspace(0.0, sc - 0.02, 9)
    zz, xz = _wedge_ode(phi, eta, mu, 0.0, s_in[-1], [T.wedge_stress(0.0, phi, eta, mu)["zz"], 0.0], s_in)
    w = T.wedge_stress(s_in, phi, eta, mu)
    np.testing.assert_allclose(zz, w["zz"], rtol=RTOL)
    np.testing.assert_allclose(xz[1:], w["xz"][1:], rtol=RTOL)
    # global vertical balance: the floor at depth z carries the wedge above it, int_0^1 s_zz dS = 1/2
    total = quad(
        lambda S: float(T.wedge_stress(S, phi, eta, mu)["zz"]), 0, 1, points=[sc], epsabs=0, epsrel=1e-13
    )[0]
    assert total == pytest.approx(0.5, rel=1e-10)
    # closure and continuity at S_c
    w = T.wedge_stress(np.array([sc - 1e-12, sc + 1e-12]), phi, eta, mu)
    np.testing.assert_allclose(w["zz"][0], w["zz"][1], rtol=1e-9)
    np.testing.assert_allclose(w["xx"], eta * w["zz"] + mu * w["xz"], rtol=1e-12)


def test_fpa_gives_a_dip_bcc_does_not():
    phi = math.radians(28.0)
    s = np.array([0.0, 0.2])
    fpa = T.wedge_stress(s, phi, *T.closure_linear("FPA", phi))["zz"]
    bcc = T.wedge_stress(s, phi, *T.closure_linear("BCC", phi))["zz"]
    assert fpa[0] < fpa[1]  # minimum on the axis (the dip)
    assert bcc[0] == pytest.approx(bcc[1], rel=1e-12)  # plateau
    # the outer-region principal axis makes the IFS angle (pi/2 - phi)/2 with the vertical (Eq. 1.17) for BCC
    w = T.wedge_stress(0.95, phi, *T.closure_linear("BCC", phi))
    assert float(T.principal_angle(w["xx"], w["zz"], w["xz"])) == pytest.approx(
        0.5 * (0.5 * math.pi - phi), rel=1e-9
    )
