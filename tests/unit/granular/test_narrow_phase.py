"""The facing-chain narrow phase (issue 15/22): each polygon cut to the corners that face the other, the facing
corner found by climbing from the previous step's, against the whole-polygon clipping it replaced and against an
independent intersection (shapely, i.e. GEOS's overlay) on many random convex pairs; and the simulation with it
against the simulation with the reference clipping.

Tolerances: areas to 1e-12 relative to the overlap, contact point, centroid and normal to 1e-12 absolute on
polygons of size ~1, GEOS's area to 1e-12 of p's area. Both clippings sum a few cross products of coordinates of
order 1 along different edge orders, so they differ by round-off only: observed on the 2000-pair sample (1257
overlapping, 1243 with a contact line) 1e-14 relative in area, 7e-16 in point, centroid and normal, 3e-16
against GEOS; the margin of 100x covers other platforms' rounding of the same sums.
"""

import math

import numpy as np
import pytest

from porepipe.granular import ellipse_polygon, polygon_overlap, regular_polygon
from porepipe.granular._shapes import AngleMode

shapely = pytest.importorskip("shapely")


def _pairs(gen, n):
    """Random convex 3..12-gons on ellipses (RAND1), the second rotated and placed so that most pairs overlap a
    little (the dense-pile case), some deeply, some not at all."""
    for _ in range(n):
        p = ellipse_polygon(
            int(gen.integers(3, 13)), gen.uniform(0.5, 2), gen.uniform(0.5, 2), AngleMode.rand1, gen
        )
        q = ellipse_polygon(
            int(gen.integers(3, 13)), gen.uniform(0.5, 2), gen.uniform(0.5, 2), AngleMode.rand1, gen
        )
        c, s = math.cos(gen.uniform(0, 2 * math.pi)), math.sin(gen.uniform(0, 2 * math.pi))
        ang = gen.uniform(0, 2 * math.pi)
        dist = gen.uniform(0.3, 1.0) * (np.abs(p).max() + np.abs(q).max())
        yield p, q @ np.array([[c, s], [-s, c]]) + dist * np.array([math.cos(ang), math.sin(ang)])


def _same_contact(a, b):
    assert a["area_m2"] == pytest.approx(b["area_m2"], rel=1e-12, abs=1e-15)
    if a["area_m2"] > 0:
        for key in ("point_m", "centroid_m", "normal"):
            np.testing.assert_allclose(a[key], b[key], atol=1e-12, rtol=0)
        assert a["length_m"] == pytest.approx(b["length_m"], rel=1e-12, abs=1e-15)
        # the contact line as an unordered pair of crossings (the two methods may name them in either order)
        pa, pb = np.array([a["c1_m"], a["c2_m"]]), np.array([b["c1_m"], b["c2_m"]])
        if np.isfinite(pa).all() or np.isfinite(pb).all():
            d = min(np.abs(pa - pb).max(), np.abs(pa - pb[::-1]).max())
            assert d < 1e-12


def test_facing_chain_equals_whole_polygon_clipping_and_geos():
    gen = np.random.default_rng(2026)
    proper = 0
    for p, q in _pairs(gen, 2000):
        new = polygon_overlap(p, q)
        old = polygon_overlap(p, q, trim=False)
        _same_contact(new, old)
        geos = shapely.Polygon(p).intersection(shapely.Polygon(q)).area
        assert new["area_m2"] == pytest.approx(geos, abs=1e-12 * shapely.Polygon(p).area)
        proper += new["area_m2"] > 0 and np.isfinite(new["c1_m"]).all()
    assert proper > 1000  # most of the sample are proper contacts with a contact line


def test_facing_chain_on_long_thin_and_many_cornered_partners():
    # a 64-gon drum wall 20x the grain, a 50:1 needle and a 1000-gon (nearly flat corners, long climbs)
    gen = np.random.default_rng(7)
    big, disk = regular_polygon(64, 20.0), regular_polygon(1000, 1.0)
    needle = ellipse_polygon(6, 5.0, 0.1, AngleMode.regular, gen)
    for _ in range(200):
        small = ellipse_polygon(int(gen.integers(3, 12)), 1.0, gen.uniform(0.3, 1), AngleMode.rand1, gen)
        ang = gen.uniform(0, 2 * math.pi)
        u = np.array([math.cos(ang), math.sin(ang)])
        for other, where in ((big, 20.0 + gen.uniform(-1.5, 1.5)), (needle, gen.uniform(0, 3)), (disk, 1.8)):
            q = small + where * u
            for a, b in ((other, q), (q, other)):
                _same_contact(polygon_overlap(a, b), polygon_overlap(a, b, trim=False))


def test_climb_does_not_depend_on_its_start():
    # the facing corners are found by climbing from the previous step's; every start gives the same corner,
    # ties (an edge exactly across the centre line) included: the result is bit-identical for every start
    from porepipe.granular._contact import _overlap_geometry

    gen = np.random.default_rng(3)
    square = np.array([(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)])
    cases = [(square, square + [0.0, 1.9]), (square, square + [1.9, 0.0]), (square, square + [1.9, 1.9])]
    cases += list(_pairs(gen, 50))
    for p, q in cases:
        both = np.zeros((2, max(len(p), len(q)), 2))
        both[0, : len(p)], both[1, : len(q)] = p, q
        cp, cq = p.mean(axis=0), q.mean(axis=0)
        outs = []
        for hp in range(len(p)):
            for hq in range(len(q)):
                k = len(p) + len(q) + 4
                geo, hint = np.empty(11), np.array([[hp, hq]])
                bufs = (
                    np.empty((k, 2)),
                    np.empty(k, np.int64),
                    np.empty((k, 2)),
                    np.empty(k, np.int64),
                    np.empty(k),
                )
                _overlap_geometry(both, 0, len(p), 1, len(q), *cp, *cq, *bufs, geo, True, hint, 0)
                outs.append(np.concatenate([geo, hint[0]]))
        assert all(np.array_equal(o, outs[0]) for o in outs)


@pytest.mark.slow
def test_simulation_with_facing_chain_follows_the_reference():
    # 30 random 7-gons (5 mm) falling onto the floor of a box and each other, 3000 steps (impacts, 50 list
    # rebuilds): the default stepper (facing chain) against the whole-polygon clipping. The two differ by
    # round-off, which colliding grains amplify: observed 1.4e-13 m in position and 1.1e-9 of the largest normal
    # force (10 N); asserted to 1e-11 m and 1e-7 of it.
    from porepipe.granular import Settings, Simulation
    from porepipe.granular import _kernels as K

    box = {"lower_m": (0, 0), "upper_m": (0.06, 0.1)}
    shape = {"size_m": (0.005, 0.005), "corners": 7, "angle_mode": "RAND1", "orientation_dist": "EQUAL"}
    block = {"lower_m": (0, 0), "upper_m": (0.06, 0.05), "grid_m": (0.0095, 0.0095), "shape": shape}
    s = Settings.model_validate({"dt_s": 2e-5, "gravity_m_s2": (0, -9.81), "box": box, "blocks": [block]})
    sims = []
    for trim in (True, False):
        sim = Simulation(s, 1)
        sim._stepper = K.make_stepper(*sim.effects.values(), trim=trim)
        sim.advance(3000)
        sims.append(sim)
    a, b = sims
    assert a.rebuilds > 10 and len(a.contacts()["i"]) > 5
    np.testing.assert_allclose(a.G[0, : a.n_mob, :2], b.G[0, : b.n_mob, :2], rtol=0, atol=1e-11)
    fa, fb = a.contacts()["fn_N"], b.contacts()["fn_N"]
    assert fa.shape == fb.shape
    np.testing.assert_allclose(fa, fb, rtol=0, atol=1e-7 * np.abs(fb).max())
