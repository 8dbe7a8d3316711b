"""Decoration: scaling rules, assignment by sphere type and size class, reproducibility, grains.h5 round trip."""

import numpy as np
import pytest

from porepipe._shared.store import ResultWriter
from porepipe.decorate import decorate, decoration_dataset, read_grains, world_grains
from porepipe.decorate._settings import Settings

FAMS = [
    {"name": "q", "generator": "quartz", "count": 3},
    {"name": "r", "generator": "random", "count": 2, "facets": 20},
]


def _spheres(n=200, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 50, (n, 3)), rng.uniform(2, 6, n)


@pytest.mark.parametrize("rule", ["equal_volume", "circumscribed", "inscribed"])
def test_scale_rules(rule):
    centres, radii = _spheres(20)
    deco = decorate(centres, radii, Settings(families=FAMS, scale=rule), seed=1)
    world = world_grains(deco)
    for g in range(len(deco)):
        t = deco.library[deco.types[g]]
        s = deco.scales[g]
        if rule == "equal_volume":
            assert t.volume * s**3 == pytest.approx(4 / 3 * np.pi * radii[g] ** 3, rel=1e-12)
        elif rule == "circumscribed":  # farthest vertex on the sphere
            verts = t.vertices @ deco.rotations[g].T * s
            assert np.linalg.norm(verts, axis=1).max() == pytest.approx(radii[g], rel=1e-12)
        else:  # nearest face plane tangent to the sphere
            planes = world.planes[world.plane_ptr[g] : world.plane_ptr[g + 1]]
            assert planes[:, 3].min() == pytest.approx(radii[g], rel=1e-12)


def test_assignment_by_type_and_size_class():
    centres, radii = _spheres(4000, 2)
    sphere_types = np.arange(4000) % 2
    settings = Settings(
        families=FAMS,
        assign=[
            {"sphere_type": 1, "probabilities": {"r": 1.0}},
            {"radius_min_um": 4.0, "probabilities": {"q": 0.25, "r": 0.75}},
        ],
    )
    deco = decorate(centres, radii, settings, seed=3, sphere_types=sphere_types)
    fam = deco.families[deco.types]
    assert (fam[sphere_types == 1] == 1).all()
    big = (sphere_types == 0) & (radii >= 4.0)
    small = (sphere_types == 0) & (radii < 4.0)
    assert (fam[small] == 0).mean() == pytest.approx(
        0.5, abs=4 * np.sqrt(0.25 / small.sum())
    )  # no rule: uniform
    assert (fam[big] == 0).mean() == pytest.approx(0.25, abs=4 * np.sqrt(0.25 * 0.75 / big.sum()))
    # types within a family are drawn uniformly: all 3 quartz types are used
    assert set(deco.types[fam == 0]) == {0, 1, 2}


def test_same_seed_same_decoration():
    centres, radii = _spheres(30)
    a = decorate(centres, radii, Settings(families=FAMS), seed=9)
    b = decorate(centres, radii, Settings(families=FAMS), seed=9)
    c = decorate(centres, radii, Settings(families=FAMS), seed=10)
    assert np.array_equal(a.rotations, b.rotations) and np.array_equal(a.types, b.types)
    assert not np.array_equal(a.rotations, c.rotations)


def test_grains_file_round_trip(tmp_path):
    centres, radii = _spheres(25)
    settings = Settings(families=FAMS + [{"name": "ball", "generator": "sphere"}])
    deco = decorate(centres, radii, settings, seed=4)
    path = tmp_path / "grains.h5"
    with ResultWriter(path, stage="decorate") as w:
        w.write_table(decoration_dataset(deco, radii))
    back, r2 = read_grains(path)
    assert np.array_equal(r2, radii)
    assert np.array_equal(back.types, deco.types) and np.array_equal(back.rotations, deco.rotations)
    assert np.array_equal(back.scales, deco.scales)
    for t, u in zip(deco.library, back.library):
        assert t.name == u.name and t.kind == u.kind
        assert u.volume == pytest.approx(t.volume, rel=1e-12)
        assert np.array_equal(u.normals, t.normals)
