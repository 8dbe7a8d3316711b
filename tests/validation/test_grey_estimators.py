"""Grey-value estimators (Zauner 2020 §7.2–7.3) against the thesis's Table 7.2 and closed-form sphere sets."""

import itertools

import numpy as np
import pytest
from naive import spheres_with_known_union

from porepipe._shared.errors import PorepipeError
from porepipe.estimate import (
    corner_cut,
    estimate_from_histograms,
    regress_porosity_limit,
    surface_estimates,
    two_point_line,
)
from porepipe.voxelize import grey_histogram, voxelize

# Table 7.2: intercepts of the two-point lines of φ(0, a) and φ(215, a) for c = 8, 4, 2, 1 a0
PHI0 = [0.131677153054625, 0.133652713629999, 0.134137638623542, 0.134301059825200]
PHI215 = [0.133806445926894, 0.134169143824690, 0.134282116458962, 0.134321011332180]
K0 = [-0.004944104133756, -0.005437994277600, -0.005680456774371, -0.005843877976029]


def test_table_7_2_regression_gives_thesis_porosity():
    lim = regress_porosity_limit(PHI0, PHI215)
    # the thesis prints φ = 0.134313 ± 0.00001: six digits, so agree to half a unit of the last digit
    assert lim.phi == pytest.approx(0.134313, abs=5e-7)
    assert lim.phi_err == pytest.approx(
        1e-5, rel=0.2
    )  # our standard error 1.12e-5 matches the quoted ±0.00001
    assert lim.slope == pytest.approx(-0.740, abs=5e-4)  # the digest's recomputed slope
    np.testing.assert_allclose(lim.phi_star, [0.1327418, 0.1339109, 0.1342099, 0.1343110], atol=1e-7)


def test_two_point_lines_reproduce_table_7_2_from_the_implied_bounds():
    # the digest's implied measured bounds φ(0, a) at a = 8, 4, 2, 1, 0.5 a0 (7 digits printed)
    a = np.array([8, 4, 2, 1, 0.5])
    phi0 = np.array([0.0921243, 0.1119007, 0.1227767, 0.1284572, 0.1313791])
    for i in range(4):
        k, phi = two_point_line(a[i], phi0[i], a[i + 1], phi0[i + 1])
        assert phi == pytest.approx(PHI0[i], abs=2e-7)  # 7-digit inputs
        assert k == pytest.approx(K0[i], rel=1e-4)


def _cube_plane_cut(s):
    """Independent geometry: volume of {x ∈ [0,1]³ : x+y+z <= s} (inclusion-exclusion) and the area of its cut."""
    vol = sum((-1) ** k * (3 if k in (1, 2) else 1) * max(s - k, 0.0) ** 3 for k in range(4)) / 6.0
    pts = []
    for e in itertools.product([0, 1], repeat=3):  # cube edges: vary one coordinate
        for axis in range(3):
            if e[axis]:
                continue
            fixed = sum(e)
            t = s - fixed
            if 0 <= t <= 1:
                p = np.array(e, float)
                p[axis] = t
                pts.append(p)
    pts = np.unique(np.round(pts, 12), axis=0)
    centre = pts.mean(axis=0)
    n = np.ones(3) / np.sqrt(3)
    u = pts[0] - centre
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    ang = np.arctan2((pts - centre) @ v, (pts - centre) @ u)
    poly = pts[np.argsort(ang)]
    area = 0.5 * np.linalg.norm(sum(np.cross(poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly))))
    return vol, area


@pytest.mark.parametrize("s", [0.3, 0.8, 1.0, 1.2, 1.5])
def test_mean_field_cut_matches_plane_geometry(s):
    vol, area = _cube_plane_cut(s)
    d, a = corner_cut(vol)
    assert d == pytest.approx(s / np.sqrt(3), rel=1e-10)  # plane distance from the corner
    assert a == pytest.approx(area, rel=1e-10)


def test_mean_field_surface_of_a_planar_interface_is_exact():
    # a plane ⟂ (1,1,1) through a periodic stack of unit voxels: every cut voxel has a known fraction; feeding the
    # exact fractions (not sampled grey values) the mean-field area must equal the plane's true area per voxel
    rng = np.random.default_rng(0)
    for s in rng.uniform(0.05, 1.5, 20):
        vol, area = _cube_plane_cut(s)
        assert corner_cut(min(vol, 1 - vol))[1] == pytest.approx(area, rel=1e-10)


@pytest.fixture(scope="module")
def known_union():
    box = 64.0
    c, r, vol, surf = spheres_with_known_union(box, 16, 8.0, 16.0, seed=11)
    res = [2.0, 1.0, 0.5, 0.25]
    hists = [grey_histogram(voxelize(c, r, (box,) * 3, a)) for a in res]
    greys = {a: voxelize(c, r, (box,) * 3, a) for a in res[-1:]}
    return box, res, hists, greys, 1 - vol / box**3, surf / box**3


def test_extrapolated_porosity_within_1e4_of_exact_union(known_union):
    box, res, hists, _, phi, _ = known_union
    ds = estimate_from_histograms(res, hists)
    err = float(ds.phi_limit) - phi
    # acceptance: 1e-4 absolute (measured: -5.8e-5); the reported error bar must cover the true error
    assert abs(err) < 1e-4
    assert abs(err) <= float(ds.phi_limit_err)
    # the bounds bracket the truth at every resolution
    assert np.all(ds.phi_lower.values <= phi) and np.all(ds.phi_upper.values >= phi)
    # the mean grey porosity (Eq. 7.1.1) converges fastest: 1.4e-8 at a = 0.25 here
    assert abs(float(ds.phi_mean_grey.sel(a_um=0.25)) - phi) < 1e-6


def test_segmented_porosity_converges_to_exact_union(known_union):
    _, res, _, greys, phi, _ = known_union
    err = abs((greys[0.25] <= 107).mean() - phi)
    assert (
        err < 1e-4
    )  # measured 3.9e-5 at a = 0.25 (boundary errors of a half threshold cancel to first order)


def test_mean_field_surface_error_against_exact_surface(known_union):
    _, res, hists, _, _, s_exact = known_union
    errors = [surface_estimates(h, a)["S_mf"] / s_exact - 1 for h, a in zip(hists, res)]
    bounds = [surface_estimates(h, a) for h, a in zip(hists, res)]
    print("relative S_mf error per a", dict(zip(res, np.round(errors, 4))))
    # Measured: -3.42 %, -3.35 %, -3.14 %, -3.24 % at a = 2, 1, 0.5, 0.25 µm. The mean field assumes every mixed
    # voxel is cut by one plane ⟂ to a space diagonal; for surfaces of random orientation that underestimates the
    # area by a resolution-independent few per cent (the thesis finds S_mf = 10.06 vs S_ex = 10.3 mm⁻¹, -2.4 %).
    # So S_mf does not converge to S exactly: we pin the bias to [-5 %, -1.5 %] at every resolution.
    assert all(-0.05 < e < -0.015 for e in errors)
    assert all(b["S_min"] <= s_exact <= b["S_max"] for b in bounds)


def _histogram_with_width(width, n=100_000, phi_lower=0.12):
    """A grey histogram whose bounds are φ(0) = phi_lower and φ(215) = phi_lower + width (mixed voxels at g=100)."""
    h = np.zeros(217, dtype=np.int64)
    h[0], h[100] = round(phi_lower * n), round(width * n)
    h[216] = n - h[0] - h[100]
    return h


@pytest.mark.parametrize(
    ("widths", "supported"), [((0.04, 0.03, 0.02), 1), ((0.04, 0.025, 0.02), 0), ((0.02, 0.02, 0.02), 0)]
)
def test_thesis_regression_is_flagged_when_widths_do_not_shrink(widths, supported):
    # rule (Table 7.2): supported only when the pair widths φ** (2-point intercepts 2 w2 - w1, 2 w3 - w2) shrink
    hists = [_histogram_with_width(w) for w in widths]
    if len(set(widths)) == 1:
        with pytest.raises(PorepipeError, match="lever arm"):
            estimate_from_histograms([4.0, 2.0, 1.0], hists)
        return
    ds = estimate_from_histograms([4.0, 2.0, 1.0], hists)
    assert ds.phi_regression.attrs["supported"] == supported
    assert ("lever arm" in ds.phi_regression.attrs["why"]) == (not supported)


def test_porosity_error_bars_cover_the_exact_union_on_small_random_samples():
    # 32 sphere sets (8 spheres, r = 3..7 µm, 32 µm box; exact union porosity from lens formulas) at a = 2..0.25 µm.
    # Calibrated on seeds 100..195 (limit coverage 97 % and 94 %, regression 95 % with the triangle-inequality bar);
    # these seeds are held out. Acceptance: coverage >= 90 % for both, as the sweep's bars; values inside [0, 1].
    res = [2.0, 1.0, 0.5, 0.25]
    hit_limit = hit_regression = 0
    for seed in range(1000, 1032):
        c, r, vol, _ = spheres_with_known_union(32.0, 8, 3.0, 7.0, seed=seed)
        phi = 1 - vol / 32.0**3
        ds = estimate_from_histograms(res, [grey_histogram(voxelize(c, r, (32.0,) * 3, a)) for a in res])
        assert 0.0 <= float(ds.phi_regression) <= 1.0 and 0.0 <= float(ds.phi_limit) <= 1.0
        hit_limit += abs(float(ds.phi_limit) - phi) <= float(ds.phi_limit_err)
        hit_regression += abs(float(ds.phi_regression) - phi) <= float(ds.phi_regression_err)
    print("coverage limit", hit_limit / 32, "regression", hit_regression / 32)
    assert hit_limit >= 29 and hit_regression >= 29
