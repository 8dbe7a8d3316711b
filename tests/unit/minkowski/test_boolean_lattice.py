"""Building blocks of the lattice Miles formulae: union volumes against closed forms, code probabilities against
their defining identities."""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.minkowski import _boolean as B
from porepipe.minkowski import _weights as W

BALL = 4.0 / 3.0 * np.pi


def lens_union(d, r=1.0):
    """|B(0, r) ∪ B(d e, r)| = 2 v - lens volume π (4r + d)(2r - d)² / 12 for d < 2r."""
    return 2 * BALL * r**3 - (np.pi / 12 * (4 * r + d) * (2 * r - d) ** 2 if d < 2 * r else 0.0)


@pytest.mark.parametrize("d", [0.0, 0.05, 0.7, 1.99, 2.5])
def test_two_ball_union_volume_is_exact(d):
    rng = np.random.default_rng(int(d * 100))
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    centres = np.array([[0.1, 0.2, 0.3], [0.1, 0.2, 0.3] + d * u])
    # quadrature tolerance is 1e-12 r³; 1e-10 leaves room for rounding in the arc sums
    assert B.union_of_balls_volume(centres, 1.0) == pytest.approx(lens_union(d), abs=1e-10)


def test_disjoint_and_nested_unions():
    cube = W.VERTICES * 3.0  # 8 balls of radius 1, pairwise disjoint
    assert B.union_of_balls_volume(cube, 1.0) == pytest.approx(8 * BALL, abs=1e-10)
    assert B.union_of_balls_volume(np.zeros((3, 3)), 2.0) == pytest.approx(8 * BALL, abs=1e-10)


def test_disc_union_area_closed_form():
    # two unit discs at distance d: 2π - lens, lens = 2 acos(d/2) - (d/2) sqrt(4 - d²)
    d = 1.2
    lens = 2 * np.arccos(d / 2) - d / 2 * np.sqrt(4 - d * d)
    area = B.union_of_discs_area(
        np.array([0.0, d, 0.3]), np.array([0.0, 0.0, 0.0]), np.array([1.0, 1.0, 0.2])
    )
    assert area == pytest.approx(2 * np.pi - lens, abs=1e-13)


def test_cell_union_volumes_respect_symmetry_and_monotonicity():
    vol = B.cell_union_volumes(1.0, (0.125, 0.125, 0.125))
    masks = np.arange(256)
    assert np.allclose(vol[1 << np.arange(8)], BALL)
    # adding a vertex never shrinks the union
    for b in range(8):
        grow = masks[(masks >> b & 1) == 0]
        assert np.all(vol[grow | 1 << b] >= vol[grow] - 1e-12)
    # an edge pair of the cell is a two-ball union at distance a (computed without the symmetry reduction)
    assert vol[0b11] == pytest.approx(lens_union(0.125), abs=1e-10)


def test_code_probabilities_are_a_distribution_with_the_right_marginals():
    lam, r, a = 0.1, 1.0, 0.1
    p = B.lattice_code_probabilities(lam, r, a)
    assert p.sum() == pytest.approx(1.0, abs=1e-12)
    assert p.min() > -1e-14
    # one vertex covered with probability 1 - exp(-λ v); two x-neighbours both uncovered with exp(-λ |B ∪ B'|)
    covered0 = (np.arange(256) & 1) == 1
    assert p[covered0].sum() == pytest.approx(1 - np.exp(-lam * BALL), abs=1e-13)
    both_empty = (np.arange(256) & 0b11) == 0
    assert p[both_empty].sum() == pytest.approx(np.exp(-lam * lens_union(a)), abs=1e-12)


def test_bad_input_names_the_argument():
    with pytest.raises(PorepipeError, match="radius_um"):
        B.miles_densities(0.1, -1.0)
    with pytest.raises(PorepipeError, match="centres_um"):
        B.union_of_balls_volume(np.zeros(3), 1.0)
    with pytest.raises(PorepipeError, match="intensity_um3"):
        B.lattice_code_probabilities(0.0, 1.0, 0.1)
