"""Particles (§2.2.1): mass properties by triangle decomposition against closed forms; convexity; generators."""

import math

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.granular import check_convex, ellipse_polygon, polygon_properties, rectangle, regular_polygon
from porepipe.granular._shapes import (
    AngleMode,
    Dist,
    corner_numbers,
    draw,
    inscribed_radius,
    truncated_unit_gauss,
)


@pytest.mark.parametrize(("a", "b"), [(1.0, 1.0), (0.3, 2.0), (1e-3, 5e-3)])
def test_rectangle_mass_properties(a, b):
    # closed forms: m = rho a b, I = m (a^2 + b^2)/12; rtol 1e-12 = a few ulps of sums of O(10) terms
    rho = 2500.0
    shift = np.array([3.0 * a, -7.0 * b])
    p = polygon_properties(rectangle(a, b) + shift, rho)
    m = rho * a * b
    assert p["mass_kg"] == pytest.approx(m, rel=1e-12)
    assert p["inertia_kg_m2"] == pytest.approx(m * (a * a + b * b) / 12.0, rel=1e-12)
    np.testing.assert_allclose(p["centroid_m"], shift, rtol=0, atol=1e-12 * (a + b) * 10)
    np.testing.assert_allclose(p["vertices_m"].mean(axis=0), 0.0, atol=1e-12 * (a + b))


@pytest.mark.parametrize("n", [3, 4, 7, 64, 1000])
def test_regular_polygon_against_closed_form_and_disk_limit(n):
    # regular n-gon, circumradius R: A = n R^2 sin(2pi/n)/2, I = m R^2 (1 + 2 cos^2(pi/n))/6 -> m R^2/2 (disk)
    R, rho = 0.01, 5000.0
    p = polygon_properties(regular_polygon(n, R, phase_rad=0.3), rho)
    area = 0.5 * n * R * R * math.sin(2 * math.pi / n)
    assert p["area_m2"] == pytest.approx(area, rel=1e-12)
    assert p["inertia_kg_m2"] == pytest.approx(
        rho * area * R * R * (1 + 2 * math.cos(math.pi / n) ** 2) / 6, rel=1e-11
    )
    disk = 0.5 * rho * math.pi * R**4
    # the polygon -> disk error is O(1/n^2): 2 pi^2/(3 n^2) relative in the area, I scales like area * R^2
    assert abs(p["inertia_kg_m2"] / disk - 1) < 4 * math.pi**2 / n**2


def test_triangle_inertia_against_integral():
    # right triangle legs a, b at the origin: I_centroid = m (a^2 + b^2)/18
    a, b = 0.3, 0.7
    p = polygon_properties([(0, 0), (a, 0), (0, b)], 1.0)
    assert p["inertia_kg_m2"] == pytest.approx(0.5 * a * b * (a * a + b * b) / 18.0, rel=1e-12)


def test_clockwise_input_is_reoriented():
    v = rectangle(1.0, 2.0)[::-1]
    out = check_convex(v)
    e = np.roll(out, -1, axis=0) - out
    assert np.sum(out[:, 0] * np.roll(out[:, 1], -1) - np.roll(out[:, 0], -1) * out[:, 1]) > 0
    assert len(out) == 4 and np.all(np.linalg.norm(e, axis=1) > 0)


@pytest.mark.parametrize(
    ("verts", "why"),
    [
        ([(0, 0), (1, 0)], "at least 3"),
        ([(0, 0), (2, 0), (1, 0.2), (1, 2)], "not a convex"),
        ([(0, 0), (1, 0), (2, 0), (1, 1)], "not a convex"),  # collinear corner
        ([(0, 0), (1, 0), (1, 1), (1, 1), (0, 1)], "not a convex"),  # repeated corner
        ([(0, 0), (1, 0), (0, 0)], "not a convex"),
    ],
)
def test_bad_polygons_are_named_errors(verts, why):
    with pytest.raises(PorepipeError, match=rf"particle 17: .*{why}"):
        check_convex(verts, "particle 17")


def test_pentagram_is_rejected():
    star = regular_polygon(5, 1.0)[[0, 2, 4, 1, 3]]
    with pytest.raises(PorepipeError, match="star"):
        check_convex(star, "star")


@pytest.mark.parametrize("mode", list(AngleMode))
def test_ellipse_generator_gives_convex_polygons_on_the_ellipse(mode):
    gen = np.random.default_rng(3)
    for _ in range(50):
        v = ellipse_polygon(9, 0.02, 0.01, mode, gen)
        check_convex(v, "generated")
        if mode is not AngleMode.special_rectangle:
            # every corner satisfies (x/a)^2 + (y/b)^2 = 1 to round-off
            np.testing.assert_allclose((v[:, 0] / 0.02) ** 2 + (v[:, 1] / 0.01) ** 2, 1.0, rtol=1e-12)
            assert len(v) <= 9


def test_regular_mode_is_the_regular_polygon():
    v = ellipse_polygon(6, 1.0, 1.0, AngleMode.regular, np.random.default_rng(0))
    np.testing.assert_allclose(v, regular_polygon(6, 1.0), atol=1e-15)


def test_rand1_angles_stay_in_their_sectors():
    gen = np.random.default_rng(5)
    n = 10
    for _ in range(20):
        v = ellipse_polygon(n, 1.0, 1.0, AngleMode.rand1, gen)
        phi = np.sort(np.mod(np.arctan2(v[:, 1], v[:, 0]) + math.pi / n, 2 * math.pi))
        sector = np.floor(phi / (2 * math.pi / n))
        assert np.array_equal(sector, np.arange(n))  # one corner per sector [(i-1/2), (i+1/2)] 2pi/n


def test_bevelled_and_rounded_rectangles():
    a, b, c = 2.0, 1.0, 0.1
    cut = polygon_properties(rectangle(a, b, cut=c), 1.0)
    # area = ab minus four corner triangles of legs ca, cb
    assert cut["area_m2"] == pytest.approx(a * b - 2 * c * a * c * b, rel=1e-12)
    r = 0.2
    rnd = polygon_properties(rectangle(a, b, round_radius_m=r, round_corners=200), 1.0)
    # area = ab - (4 - pi) r^2 in the limit of many corners; 200 corners per quarter: error ~ 1e-5 r^2
    assert rnd["area_m2"] == pytest.approx(a * b - (4 - math.pi) * r * r, abs=1e-4 * r * r)


def test_truncated_gauss_moments():
    # mean 0.5 exactly by symmetry; sd of N(0.5, 0.1) truncated at ±5 sigma = 0.1 (1 - 1.5e-5); n = 2e5: se 2.2e-4
    u = truncated_unit_gauss(np.random.default_rng(1), 200_000)
    assert u.min() >= 0 and u.max() <= 1
    assert abs(u.mean() - 0.5) < 1.2e-3
    assert abs(u.std() - 0.1) < 1.5e-3


def test_size_distributions():
    gen = np.random.default_rng(2)
    x = draw(Dist.equal, 2.0, 0.25, gen, 100_000)
    assert x.min() >= 1.5 and x.max() <= 2.5 and abs(x.mean() - 2.0) < 0.01  # se 0.29/316 ~ 1e-3
    g = draw(Dist.gauss, 2.0, 0.25, gen, 100_000)
    # GAUSS maps the unit truncated Gaussian onto [c(1-I), c(1+I)]: sd = 2 c I x 0.1
    assert g.min() >= 1.5 and g.max() <= 2.5 and abs(g.std() - 0.1) < 0.005
    assert np.all(draw(Dist.const, 2.0, 0.25, gen, 5) == 2.0)


def test_corner_numbers():
    gen = np.random.default_rng(4)
    n = corner_numbers(Dist.equal, 9, 2, gen, 10_000)
    assert set(np.unique(n)) == {7, 8, 9, 10, 11}
    counts = np.bincount(n)[7:]
    assert counts.min() > 1800  # 2000 each expected, sd 40
    assert np.all(corner_numbers(Dist.const, 6, 0, gen, 10) == 6)
    g = corner_numbers(Dist.gauss, 9, 2, gen, 10_000)
    assert g.min() >= 7 and g.max() <= 11 and abs(g.mean() - 9) < 0.05


def test_inscribed_radius():
    assert inscribed_radius(regular_polygon(6, 1.0)) == pytest.approx(math.cos(math.pi / 6), rel=1e-12)
    assert inscribed_radius(rectangle(4.0, 0.5)) == pytest.approx(0.25, rel=1e-12)
