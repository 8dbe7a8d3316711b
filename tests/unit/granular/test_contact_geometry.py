"""Narrow phase: overlap area, contact line c1c2, normal and application point (Fig. 2.4), against a slow
reference (hull of inside corners and edge crossings) and against the emergent force laws of §2.2.2."""

import math

import numpy as np
import pytest
from naive_granular import overlap

from porepipe.granular import ellipse_polygon, polygon_overlap, rectangle, regular_polygon
from porepipe.granular._shapes import AngleMode


def _random_pair(gen):
    p = ellipse_polygon(
        int(gen.integers(3, 12)), gen.uniform(0.5, 2), gen.uniform(0.5, 2), AngleMode.rand1, gen
    )
    q = ellipse_polygon(
        int(gen.integers(3, 12)), gen.uniform(0.5, 2), gen.uniform(0.5, 2), AngleMode.rand1, gen
    )
    c, s = math.cos(gen.uniform(0, 6.3)), math.sin(gen.uniform(0, 6.3))
    q = q @ np.array([[c, s], [-s, c]]) + gen.uniform(-3, 3, 2)
    return p, q


def test_overlap_matches_reference_on_random_pairs():
    # 400 random pairs of 3..11-gons; areas agree to 1e-12 of the polygon area scale (round-off of both methods)
    gen = np.random.default_rng(11)
    hits = 0
    for _ in range(400):
        p, q = _random_pair(gen)
        ref_area, crossings = overlap(p, q)
        got = polygon_overlap(p, q)
        assert got["area_m2"] == pytest.approx(ref_area, abs=1e-12 * 16)
        if ref_area > 0 and len(crossings) == 2:
            hits += 1
            pair = np.array([got["c1_m"], got["c2_m"]])
            d = np.linalg.norm(pair[:, None] - crossings[None], axis=2)
            assert min(d[0, 0] + d[1, 1], d[0, 1] + d[1, 0]) < 1e-10
            np.testing.assert_allclose(got["point_m"], crossings.mean(axis=0), atol=1e-10)
            t = pair[1] - pair[0]
            assert abs(np.dot(got["normal"], t)) < 1e-10 * np.linalg.norm(
                t
            )  # normal is perpendicular to c1c2
            assert got["length_m"] == pytest.approx(np.linalg.norm(t), rel=1e-10)
            # oriented from p towards q: q's centroid lies on the normal's side
            assert np.dot(got["normal"], q.mean(axis=0) - p.mean(axis=0)) > 0
    assert hits > 50  # the sample must contain many proper contacts


def test_near_chain_clipping_on_long_and_thin_partners():
    # The clip uses only the corners of q facing p along the centre line (and stops early when the centre line
    # separates them): checked where that chain is long or wraps round -- a 64-gon "drum wall" 20x larger than
    # the grain, a needle 50:1 -- and in both argument orders, against the slow reference (areas to 1e-12 of
    # the area scale, as above).
    gen = np.random.default_rng(5)
    big = regular_polygon(64, 20.0)
    needle = ellipse_polygon(6, 5.0, 0.1, AngleMode.regular, gen)
    for _ in range(300):
        small = ellipse_polygon(int(gen.integers(3, 12)), 1.0, gen.uniform(0.3, 1), AngleMode.rand1, gen)
        ang = gen.uniform(0, 2 * math.pi)
        for other, where in ((big, 20.0 + gen.uniform(-1.5, 1.5)), (needle, gen.uniform(0, 3))):
            q = small + where * np.array([math.cos(ang), math.sin(ang)])
            for a, b in ((other, q), (q, other)):
                ref_area, _ = overlap(a, b)
                scale = 1e-12 * max(1.0, ref_area)
                assert polygon_overlap(a, b)["area_m2"] == pytest.approx(ref_area, abs=scale * 16)


def test_disjoint_and_touching_give_zero_area():
    sq = rectangle(1.0, 1.0)
    assert polygon_overlap(sq, sq + [1.5, 0.0])["area_m2"] == 0.0
    assert polygon_overlap(sq, sq + [1.0, 0.0])["area_m2"] == pytest.approx(
        0.0, abs=1e-15
    )  # parallel touching
    tri = np.array([(0.5, 0.0), (1.5, -0.5), (1.5, 0.5)])  # vertex exactly on the square's edge
    assert polygon_overlap(sq, tri)["area_m2"] == pytest.approx(0.0, abs=1e-15)


def test_vertex_exactly_on_edge_and_shared_corner_are_finite():
    sq = rectangle(1.0, 1.0)
    tri = np.array([(0.4, 0.0), (1.5, -0.5), (1.5, 0.5)])  # tip 0.1 inside
    got = polygon_overlap(sq, tri)
    ref, _ = overlap(sq, tri)
    assert got["area_m2"] == pytest.approx(ref, rel=1e-12)
    np.testing.assert_allclose(got["normal"], [1.0, 0.0], atol=1e-12)
    shifted = polygon_overlap(sq, sq + [0.9, 0.9])  # corner-to-corner, crossings on both boundaries
    assert shifted["area_m2"] == pytest.approx(0.01, rel=1e-12)
    np.testing.assert_allclose(shifted["normal"], [math.sqrt(0.5)] * 2, atol=1e-12)


def test_coincident_and_contained_polygons_fall_back():
    sq = rectangle(1.0, 1.0)
    got = polygon_overlap(sq, sq)
    assert got["area_m2"] == pytest.approx(1.0, rel=1e-12)
    assert np.all(np.isfinite(got["normal"])) and np.linalg.norm(got["normal"]) == pytest.approx(1.0)
    small = polygon_overlap(sq, 0.2 * sq + [0.1, 0.0])
    assert small["area_m2"] == pytest.approx(0.04, rel=1e-12)
    np.testing.assert_allclose(small["normal"], [1.0, 0.0], atol=1e-12)  # centroid direction
    assert small["length_m"] == pytest.approx(0.2, rel=1e-12)  # width across the normal


def _area_exponent(poly, floor_y, depths):
    floor = rectangle(10.0, 1.0) + [0.0, floor_y - 0.5]
    lo = poly[:, 1].min()
    areas = [polygon_overlap(poly - [0, lo - floor_y + h], floor)["area_m2"] for h in depths]
    return np.polyfit(np.log(depths), np.log(areas), 1)[0]


def test_emergent_force_laws():
    # F = E A / l with constant l, so F ~ A(h): disk ~ h^(3/2) (cap area 4/3 sqrt(2R) h^(3/2)), flat face ~ h,
    # 45-degree tip ~ h^2 (§2.2.2, Figs. 2.5/2.6). Depths 1e-4..1e-3 of the size; 1000-gon so that the
    # cap spans many edges; tolerance 0.03 on the exponent.
    depths = np.geomspace(1e-4, 1e-3, 6)
    assert _area_exponent(regular_polygon(1000, 1.0), 0.0, depths) == pytest.approx(1.5, abs=0.03)
    assert _area_exponent(rectangle(1.0, 1.0), 0.0, depths) == pytest.approx(1.0, abs=1e-6)
    tip = rectangle(1.0, 1.0) @ np.array([[1, 1], [-1, 1]]) / math.sqrt(2)
    assert _area_exponent(tip, 0.0, depths) == pytest.approx(2.0, abs=1e-6)
    disk = regular_polygon(1000, 1.0)
    h = 1e-3
    cap = polygon_overlap(disk - [0, -1.0 + h], rectangle(10.0, 1.0) + [0, -0.5])["area_m2"]
    assert cap == pytest.approx(4.0 / 3.0 * math.sqrt(2.0) * h**1.5, rel=0.02)
