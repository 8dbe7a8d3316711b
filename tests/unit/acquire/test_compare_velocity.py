"""Table 8.5's rows in the model-vs-experiment table: mean flow velocity and its variance (µm/s) beside κ."""

import numpy as np
import pytest
import xarray as xr

from porepipe.acquire._compare import _table


def _perm(v, var, kappa):
    return xr.Dataset({"mean_velocity_um_s": v, "velocity_variance_um2_s2": var, "kappa_mD": kappa})


def test_velocity_rows_sit_beside_kappa_with_their_relative_difference():
    table = _table(
        {"": xr.Dataset(), "permeability": _perm(2.0, 8.0, 100.0)},
        {"": xr.Dataset(), "permeability": _perm(1.5, 10.0, 90.0)},
    )
    rows = table.sel(quantity=["mean_velocity_um_s", "velocity_variance_um2_s2", "kappa_mD"])
    np.testing.assert_allclose(rows.relative_difference.values, [-0.25, 0.25, -0.1])
    assert list(rows.unit.values) == ["µm/s", "µm²/s²", "mD"]


def test_statistics_without_velocities_keep_the_kappa_row():
    old = xr.Dataset({"kappa_mD": 100.0})
    table = _table({"": xr.Dataset(), "permeability": old}, {"": xr.Dataset(), "permeability": old})
    assert "kappa_mD" in table.quantity.values and "mean_velocity_um_s" not in table.quantity.values
    assert float(table.sel(quantity="kappa_mD").difference) == pytest.approx(0.0)
