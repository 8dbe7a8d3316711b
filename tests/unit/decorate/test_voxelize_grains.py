"""Polyhedral grey-value voxeliser: bit-identical to brute force, to a naive numpy oracle, and (for sphere grains) to
the foundation's sphere voxeliser."""

import numpy as np
import pytest

from porepipe.decorate import decorate, iter_grain_slabs, voxelize_grains
from porepipe.decorate._settings import Settings
from porepipe.voxelize import voxelize

from .naive_grains import naive_grey

BOX = (12.0, 12.0, 12.0)


def _packing(n, seed, r=(1.5, 3.0)):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, BOX[0], (n, 3)), rng.uniform(*r, n)


def _settings(**kw):
    fams = kw.pop(
        "families",
        [
            {"name": "q", "generator": "quartz", "count": 4, "elongation": (0, 0.5)},
            {"name": "r", "generator": "random", "count": 3, "facets": 12, "elongation": (0.0, 0.4)},
        ],
    )
    return Settings(families=fams, **kw)


@pytest.mark.parametrize("periodic", [True, False])
def test_boundary_brute_and_naive_identical(periodic):
    centres, radii = _packing(8, 1)
    deco = decorate(centres, radii, _settings(), seed=2)
    fast = voxelize_grains(deco, BOX, 1.0, periodic, method="boundary")
    brute = voxelize_grains(deco, BOX, 1.0, periodic, method="brute")
    naive = naive_grey(deco, BOX, 1.0, periodic)
    assert np.array_equal(fast, brute)
    assert np.array_equal(fast, naive)
    assert (fast == 216).sum() > 0 and ((fast > 0) & (fast < 216)).sum() > 0


def test_sphere_grains_equal_foundation_voxelizer():
    centres, radii = _packing(10, 4)
    deco = decorate(centres, radii, _settings(families=[{"name": "ball", "generator": "sphere"}]), seed=0)
    assert np.array_equal(deco.scales, radii)
    ours = voxelize_grains(deco, BOX, 0.75)
    assert np.array_equal(ours, voxelize(centres, radii, BOX, 0.75))


def test_mixed_spheres_and_polyhedra_match_naive():
    centres, radii = _packing(10, 6)
    settings = _settings(
        families=[{"name": "ball", "generator": "sphere"}, {"name": "q", "generator": "quartz", "count": 3}]
    )
    deco = decorate(centres, radii, settings, seed=5)
    assert set(deco.families[deco.types]) == {0, 1}
    assert np.array_equal(voxelize_grains(deco, BOX, 1.5), naive_grey(deco, BOX, 1.5))


def test_slabs_cover_the_volume_identically():
    centres, radii = _packing(8, 7)
    deco = decorate(centres, radii, _settings(), seed=1)
    whole = voxelize_grains(deco, BOX, 1.0)
    parts = np.concatenate([s for _, s in iter_grain_slabs(deco, BOX, 1.0, slab_planes=5)])
    assert np.array_equal(whole, parts)


def test_empty_packing_is_all_pore():
    deco = decorate(np.zeros((0, 3)), np.zeros(0), _settings(), seed=0)
    assert voxelize_grains(deco, BOX, 2.0).max() == 0
