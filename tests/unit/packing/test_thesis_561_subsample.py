"""The §5.6.1 sub-sample (config/scenes/data/thesis-5.6.1-sub-make.py) holds exactly the packing's content of its
corner cube: every point of [0, 100]³ µm is inside a cropped sphere iff it is inside a sphere of the periodic packing.

Truth: the periodic packing classified independently by a periodic k-d tree (scipy's ``boxsize``), on random points.
"""

import importlib.util
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

MAKE = Path(__file__).resolve().parents[3] / "config" / "scenes" / "data" / "thesis-5.6.1-sub-make.py"


def _make_module():
    spec = importlib.util.spec_from_file_location("thesis_561_sub_make", MAKE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _inside(points, centres, radii, boxsize=None):
    """Whether each point lies in a sphere (minimum-image distances when ``boxsize`` is given)."""
    hits = cKDTree(centres, boxsize=boxsize).query_ball_point(points, r=radii.max())
    out = np.zeros(len(points), bool)
    for i, js in enumerate(hits):
        d = points[i] - centres[js]
        if boxsize is not None:
            d -= boxsize * np.round(d / boxsize)
        out[i] = (np.sqrt((d * d).sum(1)) <= radii[js]).any()
    return out


def test_the_corner_cube_holds_exactly_the_periodic_packings_content():
    mod = _make_module()
    rng = np.random.default_rng(3)
    box = np.array([250.0, 250.0, 250.0])
    centres = rng.uniform(-50, 300, (400, 3))  # some outside the box: the crop wraps them first
    radii = rng.uniform(4.0, 30.0, 400)
    c, r = mod.corner(centres, radii, box)
    assert (r > 0).all() and len(r) < len(radii) + 200
    # images across the faces at 0 were kept (centres below 0), and nothing that cannot reach the cube
    assert (c.min(axis=0) < 0).all()
    gap = np.maximum(0.0, np.maximum(-c, c - mod.CUBE_UM))
    assert (np.sqrt((gap * gap).sum(1)) < r).all()
    points = rng.uniform(0, mod.CUBE_UM, (3000, 3))
    expected = _inside(points, np.mod(centres, box), radii, boxsize=box)
    np.testing.assert_array_equal(_inside(points, c, r), expected)
