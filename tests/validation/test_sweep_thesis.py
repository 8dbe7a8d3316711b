"""The thesis's extrapolation rules, reproduced from its own numbers (spec digest §3.5 and §4.2)."""

import numpy as np
import pytest

from porepipe.estimate import regress_porosity_limit, two_point_line
from porepipe.sweep import fit_inverse_length, two_point_limit

# Table 6.4 (Zauner 2020, §6.2): tau, kappa_l.r., kappa_h.r., kappa_extrap in mD; l.r. L_S = 300, h.r. L_S = 600
TABLE_6_4 = [
    (0.688, 608, 559, 510),
    (0.857, 773, 634, 495),
    (0.688, 505, 489, 473),
    (0.857, 558, 518, 478),
    (1.000, 601, 541, 481),
]


@pytest.mark.parametrize("tau, lr, hr, extrap", TABLE_6_4)
def test_table_6_4_linear_in_inverse_sample_length(tau, lr, hr, extrap):
    # the printed values are integers in mD and 2*hr - lr is an integer: exact agreement
    assert two_point_limit(lr, hr) == pytest.approx(extrap, abs=1e-9)
    lim = fit_inverse_length([300.0, 600.0], [lr, hr])
    assert lim.q_inf == pytest.approx(extrap, abs=1e-9)


def test_table_6_4_extrapolations_lie_in_473_to_510_mD():
    values = [two_point_limit(lr, hr) for _, lr, hr, _ in TABLE_6_4]
    assert min(values) == pytest.approx(473) and max(values) == pytest.approx(510)


# implied measured bounds of Table 7.2 (a in units of a0; digest §4.2), 7 significant digits
A0 = np.array([8.0, 4.0, 2.0, 1.0, 0.5])
PHI_0 = np.array([0.0921243, 0.1119007, 0.1227767, 0.1284572, 0.1313791])
PHI_215 = np.array([0.1828374, 0.1583219, 0.1462455, 0.1402638, 0.1372924])
TABLE_7_2 = {
    "phi0": [0.131677153054625, 0.133652713629999, 0.134137638623542, 0.134301059825200],
    "phi215": [0.133806445926894, 0.134169143824690, 0.134282116458962, 0.134321011332180],
}


def test_table_7_2_two_point_lines_and_regression():
    lines0 = [two_point_limit(PHI_0[i], PHI_0[i + 1]) for i in range(4)]
    lines215 = [two_point_limit(PHI_215[i], PHI_215[i + 1]) for i in range(4)]
    # the bounds are given to 7 digits, so the intercepts 2φ(c/2) − φ(c) agree to ~2e-7
    np.testing.assert_allclose(lines0, TABLE_7_2["phi0"], atol=3e-7)
    np.testing.assert_allclose(lines215, TABLE_7_2["phi215"], atol=3e-7)
    # and they are the estimate stage's two-point lines (a different code path, same arithmetic)
    np.testing.assert_allclose(
        lines0, [two_point_line(A0[i], PHI_0[i], A0[i + 1], PHI_0[i + 1])[1] for i in range(4)], rtol=1e-12
    )
    lim = regress_porosity_limit(TABLE_7_2["phi0"], TABLE_7_2["phi215"])
    assert lim.phi == pytest.approx(0.134313, abs=5e-7)  # the thesis prints 6 digits
    assert lim.slope == pytest.approx(-0.740, abs=5e-4)
