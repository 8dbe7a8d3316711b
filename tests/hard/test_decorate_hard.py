"""Hard cases of the grain model: degenerate plane sets, sub-voxel grains, grains across periodic faces, elongation 0,
bad scene sections."""

import numpy as np
import pytest
from pydantic import ValidationError

from porepipe._shared.errors import PorepipeError
from porepipe.decorate import (
    anisotropic_rotations,
    decorate,
    grain_images,
    mean_overlap_volume,
    minimise_overlap,
    neighbour_pairs,
    om_cells,
    pair_overlap_volume,
    points_in_grains,
    polyhedron,
    random_type,
    read_plane_file,
    sphere_type,
    von_mises_fisher,
    voxelize_grains,
    world_grains,
)
from porepipe.decorate._settings import Settings
from tests.unit.decorate.naive_grains import naive_grey


@pytest.mark.parametrize(
    "normals, offsets, what",
    [
        (np.vstack([np.eye(3), -np.eye(3)[:2]]), np.ones(5), "unbounded"),  # no -z plane
        (np.vstack([np.eye(3), [[1, 1, 1]]]), np.ones(4), "unbounded"),  # all normals in one half-space
        (np.vstack([np.eye(3), -np.eye(3)]), np.array([1, 1, 1, -2, 1, 1.0]), "empty"),  # x <= 1 and x >= 2
        (np.vstack([np.eye(3), -np.eye(3)]), np.array([0, 1, 1, 0, 1, 1.0]), "empty or flat"),  # 0 <= x <= 0
    ],
)
def test_degenerate_plane_sets_name_the_type(normals, offsets, what):
    with pytest.raises(PorepipeError, match=rf"grain type 'bad-one'.*{what}"):
        polyhedron("bad-one", normals, offsets)


@pytest.mark.parametrize(
    "normals, offsets, match",
    [
        (np.ones((3, 3)), np.ones(3), "need >= 4"),
        (
            np.vstack([np.eye(3), -np.eye(3)]) * np.array([[1], [1], [1], [1], [1], [0]]),
            np.ones(6),
            "zero normal",
        ),
        (np.vstack([np.eye(3), -np.eye(3)]), np.array([1, 1, np.nan, 1, 1, 1]), "NaN or Inf"),
        (np.eye(3), np.ones(4), "need normals"),
    ],
)
def test_malformed_plane_sets(normals, offsets, match):
    with pytest.raises(PorepipeError, match=rf"'odd'.*{match}"):
        polyhedron("odd", normals, offsets)


def test_plane_file_errors(tmp_path):
    bad = tmp_path / "bad.planes"
    bad.write_text("a 1 0 0\n")
    with pytest.raises(PorepipeError, match=r"bad.planes:1: expected"):
        read_plane_file(bad)
    open_ = tmp_path / "open.planes"
    open_.write_text("slab 1 0 0 1\nslab -1 0 0 1\nslab 0 1 0 1\nslab 0 -1 0 1\n")
    with pytest.raises(PorepipeError, match=r"'slab'.*unbounded"):
        read_plane_file(open_)
    with pytest.raises(PorepipeError, match="does not exist"):
        read_plane_file(tmp_path / "missing.planes")


def test_grains_much_smaller_than_a_voxel():
    """Grains of radius a/20 hit at most a few sample points; boundary-only equals brute force and the naive oracle."""
    rng = np.random.default_rng(8)
    box = (10.0, 10.0, 10.0)
    deco = decorate(rng.uniform(0, 10, (60, 3)), np.full(60, 0.1), Settings(), seed=1)
    grey = voxelize_grains(deco, box, 2.0)
    assert np.array_equal(grey, voxelize_grains(deco, box, 2.0, method="brute"))
    assert np.array_equal(grey, naive_grey(deco, box, 2.0))
    assert grey.max() <= 2  # a body of diameter < 0.3 µm holds at most a few points of a 0.333 µm lattice


def test_grain_crossing_periodic_faces():
    """A grain at a box corner: its 8 pieces equal the naive periodic oracle, and their volume the whole grain's."""
    box = (12.0, 12.0, 12.0)
    fams = [{"name": "q", "generator": "quartz", "count": 1, "elongation": (0.4, 0.4)}]
    corner = decorate(np.array([[0.2, 11.9, 0.05]]), np.array([3.0]), Settings(families=fams), seed=2)
    grey = voxelize_grains(corner, box, 0.5)
    assert np.array_equal(grey, naive_grey(corner, box, 0.5))
    centred = decorate(np.array([[6.2, 5.9, 6.05]]), np.array([3.0]), Settings(families=fams), seed=2)
    assert np.array_equal(corner.rotations, centred.rotations)
    v_corner = grey.sum(dtype=np.int64) / 216 * 0.5**3
    v_centre = voxelize_grains(centred, box, 0.5).sum(dtype=np.int64) / 216 * 0.5**3
    exact = 4 / 3 * np.pi * 27
    # different lattice offsets of the same body: both within 1 % of the exact volume (measured ~1e-4 at a/r = 1/6)
    assert v_corner == pytest.approx(exact, rel=1e-2) and v_centre == pytest.approx(exact, rel=1e-2)


def test_elongation_zero():
    t = random_type("round", np.random.default_rng(1), facets=36, elongation=0.0)
    ext = np.ptp(t.vertices, axis=0)
    assert (
        t.n_faces == 36 and ext.max() / ext.min() < 1.3
    )  # near-isotropic tangent polytope of the unit sphere
    s = Settings(families=[{"name": "q", "generator": "quartz", "count": 2, "elongation": (0.0, 0.0)}])
    deco = decorate(np.array([[5.0, 5.0, 5.0]]), np.array([2.0]), s, seed=0)
    assert deco.library[0].n_faces == 18


@pytest.mark.parametrize(
    "section, match",
    [
        ({"assign": [{"probabilities": {"nope": 1.0}}]}, "unknown families"),
        ({"assign": [{"probabilities": {"quartz": 0.5}}]}, "sum to 1"),
        ({"families": [{"name": "r", "generator": "random", "elongation": (0.5, 0.2)}]}, "reversed"),
        ({"families": [{"name": "f", "generator": "file"}]}, "give `file`"),
        ({"families": [{"name": "a"}, {"name": "a"}]}, "distinct"),
        ({"orientation": {"axis": (0, 0, 0)}}, "non-zero"),
        ({"scale": "bigger"}, "equal_volume"),
    ],
)
def test_bad_decoration_sections(section, match):
    with pytest.raises(ValidationError, match=match):
        Settings(**section)


def test_overlap_minimiser_needs_the_box():
    with pytest.raises(PorepipeError, match="box_um"):
        decorate(np.zeros((2, 3)), np.ones(2), Settings(orientation={"mode": "overlap_minimizer"}))


@pytest.mark.parametrize(
    "points",
    [
        [[np.nan, 5.0, 5.0]],  # before: reported inside a grain
        [[5.0, 5.0]],  # before: the kernel read a z past the array
    ],
)
def test_points_in_grains_refuses_nan_or_two_coordinates(points):
    deco = decorate(np.array([[5.0, 5.0, 5.0]]), np.array([2.0]), Settings(), seed=0)
    with pytest.raises(PorepipeError, match=r"points need shape \(M, 3\) and finite values"):
        points_in_grains(np.array(points), deco, (10.0, 10.0, 10.0))


@pytest.mark.parametrize(
    "axis, kappa, match",
    [
        (
            (0.0, 0.0, 0.0),
            1.0,
            "axis .* must be a finite non-zero 3-vector",
        ),  # before: NaN and a RuntimeWarning
        ((0.0, 0.0, np.nan), 1.0, "axis .* must be a finite non-zero 3-vector"),  # before: NaN vectors
        ((0.0, 0.0, 1.0), np.nan, "kappa must be >= 0"),  # before: NaN rotations, silently
        ((0.0, 0.0, 1.0), -5.0, "kappa must be >= 0"),  # before: uniform, silently
    ],
)
def test_orientations_refuse_a_zero_axis_or_a_concentration_without_a_meaning(axis, kappa, match):
    with pytest.raises(PorepipeError, match=match):
        von_mises_fisher(np.random.default_rng(0), 3, axis, kappa)
    with pytest.raises(PorepipeError, match=match):
        anisotropic_rotations(np.random.default_rng(0), 3, axis, kappa)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"perturbation": np.nan},  # before: OverflowError of numpy's uniform
        {"perturbation": -0.1},  # before: numpy's "high - low < 0"
        {"elongation": np.nan},  # before: "perturbation 0.1 too large?"
        {"elongation": 1.0},  # before: "perturbation 0.1 too large?"
        {"elongation": 2.0},  # before: a mirrored body, silently
        {"facets": 3},  # before: "perturbation 0.1 too large?"
    ],
)
def test_random_type_refuses_parameters_without_a_body(kwargs):
    with pytest.raises(
        PorepipeError, match=r"needs facets >= 4, 0 <= elongation < 1 and a finite perturbation"
    ):
        random_type("r", np.random.default_rng(0), **{"facets": 12, **kwargs})


@pytest.mark.parametrize("families", [np.array([3]), np.array([0, 0]), np.zeros(0, np.int64)])
def test_decorate_refuses_a_library_that_does_not_cover_the_families(families):
    # before: IndexError when a sphere drew a family without a type
    lib = [sphere_type("s")] * min(len(families), 1)
    with pytest.raises(PorepipeError, match="library: family indices .* cover the 1 decoration.families"):
        decorate(np.array([[5.0, 5.0, 5.0]]), np.array([2.0]), Settings(), library=(lib, families))


def test_pair_overlap_volume_refuses_a_grain_index_out_of_range():
    deco = decorate(np.array([[5.0, 5.0, 5.0], [8.0, 5.0, 5.0]]), np.array([2.0, 2.0]), Settings(), seed=0)
    with pytest.raises(PorepipeError, match=r"grains i = 0, j = 5; allowed: 0..1"):  # before: IndexError
        pair_overlap_volume(deco, 0, 5, (10.0, 10.0, 10.0))


@pytest.mark.parametrize("volume", [0.0, np.nan])  # before: divide-by-zero / invalid-cast warnings
def test_om_cells_refuse_a_cell_volume_that_is_not_positive_and_finite(volume):
    with pytest.raises(PorepipeError, match="cell_volume_um3 must be positive and finite"):
        om_cells(np.array([[5.0, 5.0, 5.0], [8.0, 5.0, 5.0]]), np.array([10.0, 10.0, 10.0]), True, volume)


def _two_grains():
    return decorate(np.array([[5.0, 5.0, 5.0], [8.0, 5.0, 5.0]]), np.array([2.0, 2.0]), Settings(), seed=0)


_BOX_CALLS = {
    "grain_images": lambda d, box, per: grain_images(d.centres_um, world_grains(d).half_um, box, per),
    "neighbour_pairs": lambda d, box, per: neighbour_pairs(d, box, per),
    "points_in_grains": lambda d, box, per: points_in_grains(np.full((1, 3), 5.0), d, box, per),
    "pair_overlap_volume": lambda d, box, per: pair_overlap_volume(d, 0, 1, box, per),
    "mean_overlap_volume": lambda d, box, per: mean_overlap_volume(d, box, per),
    "voxelize_grains": lambda d, box, per: voxelize_grains(d, box, 1.0, per),
    "om_cells": lambda d, box, per: om_cells(d.centres_um, box, per, 8.0),
    "minimise_overlap": lambda d, box, per: minimise_overlap(d, box, per, trials=2, passes=1),
    "decorate": lambda d, box, per: decorate(d.centres_um, np.array([2.0, 2.0]), Settings(), box_um=box),
}


@pytest.mark.parametrize("name", sorted(_BOX_CALLS))
@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize(
    "box",
    [
        (0.0, 10.0, 10.0),  # before: OverflowError / scipy's "data must be finite" / a divide-by-zero warning
        (-10.0, 10.0, 10.0),  # before: no grain images and no pairs, silently
        (
            np.nan,
            10.0,
            10.0,
        ),  # before: OverflowError, scipy's ValueError, or silently ignored without periodicity
        (np.inf, 10.0, 10.0),  # before: invalid-value warnings
        (10.0, 10.0),  # before: numpy's broadcast error
    ],
)
def test_decorate_functions_refuse_a_box_without_3_positive_finite_edges(name, periodic, box):
    deco = _two_grains()
    arg = "box" if name == "om_cells" else "box_um"
    with pytest.raises(PorepipeError, match=rf"^{name}: {arg} must be 3 positive finite edge lengths \(µm\)"):
        _BOX_CALLS[name](deco, box, periodic)
