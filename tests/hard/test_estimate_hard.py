"""Grey-value estimators on samples without partial voxels: the porosity is exact, never an error (issue 20, item 9)."""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.estimate import regress_porosity_limit, richardson_limit
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


def test_richardson_limit_is_exact_on_a_parabola_and_refuses_what_it_cannot_fit():
    """q = 0.3 + 0.05 a - 0.02 a² through three resolutions: the limit 0.3 to round-off; a repeated resolution (a
    singular fit, which numpy only warned about), a non-positive one, mismatched lengths or a NaN value give one
    clear line instead of a number."""
    a = np.array([4.0, 2.0, 1.0])
    limit, err = richardson_limit(a, 0.3 + 0.05 * a - 0.02 * a**2)
    assert limit == pytest.approx(0.3, abs=1e-14)
    assert err > 0  # the linear two-point limit differs: the error estimate sees the curvature
    for bad_a, bad_q, match in (
        ([4.0, 1.0, 1.0], [0.31, 0.30, 0.30], "distinct positive"),
        ([2.0, 1.0, 0.0], [0.31, 0.30, 0.30], "distinct positive"),
        ([4.0, 2.0, 1.0], [0.31, 0.30], "one value per resolution"),
        ([4.0, 2.0, 1.0], [0.31, np.nan, 0.30], "finite values"),
    ):
        with pytest.raises(PorepipeError, match=match):
            richardson_limit(bad_a, bad_q)


def test_regression_refuses_non_finite_intercepts():
    """A NaN intercept made LAPACK print 'illegal value' and raise LinAlgError; now one line names the intercepts."""
    with pytest.raises(PorepipeError, match="finite intercepts"):
        regress_porosity_limit([0.3, np.nan], [0.35, 0.33])


def _scaled_series(scale):
    """A three-resolution series (2, 1, 0.5) × ``scale`` µm with partial voxels, and its estimate."""
    rng = np.random.default_rng(11)
    hists = np.zeros((3, 217), np.int64)
    for row, voxels in enumerate((1000, 8000, 64000)):
        mixed = voxels // (8 * (row + 1))
        hists[row] = np.bincount(rng.integers(1, 216, mixed), minlength=217)
        hists[row, 0] = (voxels - mixed) * 3 // 4 + row
        hists[row, 216] = voxels - hists[row].sum()
    return estimate_from_histograms([2.0 * scale, 1.0 * scale, 0.5 * scale], hists)


# power of the voxel size in each variable (the rest are dimensionless)
_POWERS = {"a_um": 1, "pair_coarse_um": 1, "pair_fine_um": 1, "S_min": -1, "S_mf": -1, "S_max": -1, "k_0": -1}
_POWERS["k_215"] = -1


@pytest.mark.parametrize("scale", [1e-20, 1e20, 1e100])
def test_extreme_voxel_sizes_give_the_scaled_estimate(scale):
    """At voxel sizes around 1e100 µm the three-point limit was silently wrong (0.718 for 0.427: a² overflowed in
    numpy.polyfit's column scaling); the fit is now done in a / 2^e, so every limit is the one at ~1 µm and every
    length-dependent value the 1 µm one times a^k (rel 1e-12: the voxel sizes themselves differ in rounding)."""
    ref, ds = _scaled_series(1.0), _scaled_series(scale)
    for name in ds.variables:
        k = _POWERS.get(name, 0)
        np.testing.assert_allclose(
            ds[name].values, ref[name].values * scale**k, rtol=1e-12, atol=0, err_msg=name
        )
    assert float(ds.phi_limit) == pytest.approx(float(ref.phi_limit), rel=1e-12)  # the a_i differ in rounding


def test_voxel_sizes_near_1e_minus_100_do_not_hang():
    """At 1e-100 µm, a² underflowed in numpy.polyfit's column scaling (division by zero) and LAPACK never returned
    ('DLASCL parameter number 4 had an illegal value', then a hang); now the estimate is the one at 1 µm scaled."""
    import subprocess
    import sys

    code = (
        "import numpy as np, tests.hard.test_estimate_hard as t\n"
        "ref, ds = t._scaled_series(1.0), t._scaled_series(1e-100)\n"
        "np.testing.assert_allclose(float(ds.phi_limit), float(ref.phi_limit), rtol=1e-12)\n"
        "np.testing.assert_allclose(ds.S_mf.values, ref.S_mf.values * 1e100, rtol=1e-12)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]


@pytest.mark.parametrize("scale", [1e-110, 1e110, 1e-300, 1e300])
def test_surface_estimates_scale_where_a_cubed_leaves_float64(scale):
    """S_b(g, a) was area(a) / a³: at 1e-110 µm a³ underflowed (S = NaN, inf), at 1e110 µm it overflowed (S = 0),
    though S ~ 1/a is representable; it is now S_b(g, 1) / a."""
    ref, ds = _scaled_series(1.0), _scaled_series(scale)
    for name in ("S_min", "S_mf", "S_max", "k_0", "k_215"):
        np.testing.assert_allclose(
            ds[name].values, ref[name].values / scale, rtol=1e-12, atol=0, err_msg=name
        )


@pytest.mark.parametrize("scale", [1e-310, 1e308])
def test_surface_beyond_float64_is_refused(scale):
    with pytest.raises(PorepipeError, match=r"voxel_um = .* µm: S_min = .* beyond the float64 range"):
        _scaled_series(scale)
