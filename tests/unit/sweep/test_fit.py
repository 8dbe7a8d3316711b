"""Extrapolation fits q(a) = q∞ + c·a^p: calibration of the error bars, exact recovery, and the verdicts."""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.sweep import Status, fit_inverse_length, fit_power, two_point_limit

A = np.array([8.0, 4.0, 2.0, 1.0, 0.5])


@pytest.mark.parametrize(
    "p_true, exponent, known_sigma",
    [
        (1.5, None, False),  # exponent fitted, noise estimated from residuals
        (1.0, 1.0, False),  # linear in a (thesis 7.2.1)
        (2.0, 2.0, False),  # quadratic
        (1.0, None, True),  # exponent fitted, noise known
    ],
)
def test_error_bars_cover_the_true_limit_in_90_percent_of_trials(p_true, exponent, known_sigma):
    # calibration: the stated interval is a 95 % one, so >= 90 % of 200 seeded trials must contain q∞
    # (binomial sd of the hit rate at 200 trials is 1.5 %, so 90 % is 3 sd below 95 %)
    rng = np.random.default_rng(2024)
    sigma, hits, supported = 0.002, 0, 0
    for _ in range(200):
        q = 1.0 + 0.05 * A**p_true + rng.normal(0.0, sigma, A.size)
        lim = fit_power(A, q, exponent=exponent, sigma=sigma if known_sigma else None)
        if lim.supported:
            supported += 1
            hits += abs(lim.q_inf - 1.0) <= lim.err
    assert supported >= 190, (
        supported
    )  # the signal (0.05·a^p) is far above the noise: almost every fit is usable
    assert hits / supported >= 0.90, hits / supported


def test_noise_free_power_law_is_recovered_exactly():
    q = 2.0 + 0.5 * A**1.7
    lim = fit_power(A, q)
    # variable projection + bounded search to xatol 1e-10: q∞ and p to ~1e-7 relative
    assert lim.q_inf == pytest.approx(2.0, abs=1e-7)
    assert lim.p == pytest.approx(1.7, rel=1e-6)
    assert lim.status is Status.ok and lim.err < 1e-6


def test_fixed_exponent_is_linear_least_squares():
    rng = np.random.default_rng(3)
    q = 0.3 - 0.01 * A + rng.normal(0, 1e-4, A.size)
    lim = fit_power(A, q, exponent=1.0)
    coef = np.polyfit(A, q, 1)  # independent truth: numpy's least-squares line
    assert lim.q_inf == pytest.approx(coef[1], rel=1e-12)
    assert lim.c == pytest.approx(coef[0], rel=1e-10)


def test_two_points_give_the_two_point_line_without_an_error_bar():
    lim = fit_power([1.0, 0.5], [608.0, 559.0], exponent=1.0)
    assert lim.q_inf == pytest.approx(two_point_limit(608.0, 559.0), rel=1e-12)
    assert lim.status is Status.too_few_points and np.isnan(lim.err)
    assert "no error estimate" in lim.text()


def test_too_few_points_for_a_free_exponent():
    lim = fit_power([4.0, 2.0], [1.0, 0.9])
    assert lim.status is Status.too_few_points and np.isnan(lim.q_inf)
    assert lim.text().startswith("no limit: 2 point(s) for 3 parameters")


def test_non_monotonic_data_give_no_limit():
    lim = fit_power(A, [1.0, 1.2, 1.05, 1.15, 1.1], exponent=1.0)
    assert lim.status is Status.non_monotonic and not lim.supported


def test_scatter_without_trend_is_a_poor_fit():
    # known noise much larger than any trend: a monotonic draw still fails the chi² test or R²
    q = np.array([1.0, 1.001, 1.0011, 1.0012, 1.0013]) + np.array([0.0, 0.0, 0.0, 0.0, 0.02])
    lim = fit_power(A, q, exponent=2.0)
    assert lim.status is Status.poor_fit, lim


def test_inverse_length_form_is_linear_in_a_for_a_fixed_sample():
    length_lu = 300.0 / A  # a fixed physical sample: L_S ∝ 1/a
    kappa = 500.0 + 30.0 * A + np.array([0.3, -0.2, 0.1, -0.1, 0.05])
    by_length = fit_inverse_length(length_lu, kappa)
    by_a = fit_power(A, kappa, exponent=1.0)
    assert by_length.q_inf == pytest.approx(by_a.q_inf, rel=1e-12)
    assert by_length.err == pytest.approx(by_a.err, rel=1e-9)


@pytest.mark.parametrize(
    "a, q",
    [
        ([1.0, 1.0, 0.5], [1, 2, 3]),
        ([1.0, -0.5, 0.25], [1, 2, 3]),
        ([1.0, 0.5], [1.0, np.nan]),
        ([1.0, 0.5, 0.25], [1.0, 2.0]),
    ],
)
def test_bad_input_is_rejected(a, q):
    with pytest.raises(PorepipeError):
        fit_power(a, q)
