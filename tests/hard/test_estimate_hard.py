"""Grey-value estimators on samples without partial voxels: the porosity is exact, never an error (issue 20, item 9)."""

import numpy as np
import pytest

from porepipe.estimate._api import estimate_from_histograms


@pytest.mark.parametrize(("grey", "phi"), [(0, 1.0), (216, 0.0)])
def test_single_phase_sample_gives_phi_one_or_zero(grey, phi):
    hists = np.zeros((3, 217), np.int64)
    hists[:, grey] = [1000, 8000, 64000]  # one phase at 4, 2, 1 µm
    ds = estimate_from_histograms([4.0, 2.0, 1.0], hists)
    assert float(ds.phi_limit) == phi
    assert float(ds.phi_regression) == phi
    assert float(ds.phi_limit_err) == 0.0
    for name in ("S_min", "S_mf", "S_max"):
        np.testing.assert_array_equal(ds[name].values, 0.0)  # no interface: no surface


def test_faces_on_voxel_planes_give_the_exact_porosity():
    # a matrix slab a quarter of the box thick, its faces on voxel planes at every resolution: g is 0 or 216
    hists = np.zeros((3, 217), np.int64)
    for row, voxels in enumerate((1000, 8000, 64000)):
        hists[row, 216], hists[row, 0] = voxels // 4, voxels - voxels // 4
    ds = estimate_from_histograms([4.0, 2.0, 1.0], hists)
    assert float(ds.phi_limit) == 0.75
    assert ds.phi_regression.attrs["error_method"] == "exact"
