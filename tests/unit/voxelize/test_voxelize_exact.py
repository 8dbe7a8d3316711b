"""The boundary-only voxelisation equals brute force and a naive numpy oracle bit for bit."""

import itertools

import numba
import numpy as np
import pytest
from naive import grey_values_naive

from porepipe.voxelize import VoxelizeMethod, sphere_images, voxelize

BOX = (12.0, 10.0, 8.0)


def _both_equal_oracle(c, r, box, a, periodic=True):
    fast = voxelize(c, r, box, a, periodic, VoxelizeMethod.boundary)
    brute = voxelize(c, r, box, a, periodic, VoxelizeMethod.brute)
    oracle = grey_values_naive(np.asarray(c, float).reshape(-1, 3), np.asarray(r, float), box, a, periodic)
    np.testing.assert_array_equal(fast, oracle)  # exact: same points, same arithmetic
    np.testing.assert_array_equal(brute, oracle)
    return fast


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("periodic", [True, False])
def test_random_polydisperse_sets(seed, periodic):
    rng = np.random.default_rng(seed)
    n = 25
    c = rng.uniform(-1, 13, (n, 3))  # some centres outside the box: wrap (periodic) or clip
    r = np.exp(rng.uniform(np.log(0.1), np.log(4.0), n))  # 0.1 µm (< voxel) to 4 µm
    g = _both_equal_oracle(c, r, BOX, 1.0, periodic)
    assert 0 < g.mean() < 216


def test_spheres_smaller_than_a_voxel():
    rng = np.random.default_rng(5)
    c = rng.uniform(0, 8, (40, 3))
    r = rng.uniform(0.02, 0.3, 40)
    g = _both_equal_oracle(c, r, (8.0, 8.0, 8.0), 1.0)
    assert g.max() < 216


def test_centres_on_voxel_corners_and_sample_points():
    a = 1.0
    h = a / 6
    corners = [[2.0, 3.0, 4.0], [5.0, 5.0, 5.0], [0.0, 0.0, 0.0]]
    samples = [[(6 * 3 + 2 + 0.5) * h, (6 * 1 + 0.5) * h, (6 * 6 + 5.5) * h], [(6 * 7 + 3.5) * h] * 3]
    c = np.array(corners + samples)
    # radii that put sample points exactly on the sphere surface (distance = multiples of h)
    r = np.array([1.0, 2.5 * h * 2, 1.5, 3 * h, h])
    _both_equal_oracle(c, r, (8.0, 8.0, 8.0), a)


def test_sample_points_exactly_on_the_surface_count_as_matrix():
    h = 1.0 / 6
    point = np.array([[(6 * 2 + 0.5) * h, (6 * 2 + 0.5) * h, (6 * 2 + 0.5) * h]])
    g = voxelize(point + [[2 * h, 0, 0]], np.array([2 * h]), (4.0, 4.0, 4.0), 1.0)
    assert g[2, 2, 2] >= 1  # closed ball: the sample point at distance exactly r is inside


def test_spheres_crossing_periodic_faces_and_corners():
    c = np.array([[0.2, 5.0, 4.0], [11.9, 9.9, 7.9], [6.0, 0.0, 8.0]])
    r = np.array([2.3, 3.1, 1.7])
    g = _both_equal_oracle(c, r, BOX, 0.5, periodic=True)
    # a sphere at the corner appears in all eight corners of the volume
    assert g[0, 0, 0] > 0 and g[-1, -1, -1] > 0 and g[0, -1, 0] > 0


def test_empty_box_and_fully_covered_box():
    empty = voxelize(np.zeros((0, 3)), np.zeros(0), BOX, 1.0)
    assert empty.shape == (12, 10, 8) and not empty.any()
    full = voxelize(np.array([[6.0, 5.0, 4.0]]), np.array([20.0]), BOX, 1.0)
    assert (full == 216).all()


def test_sphere_larger_than_periodic_box_wraps_several_times():
    c = np.array([[1.0, 2.0, 3.0]])
    _both_equal_oracle(c, np.array([7.3]), (4.0, 4.0, 4.0), 0.5)


def test_images_cover_only_spheres_that_reach_the_box():
    c = np.array([[5.0, 5.0, 5.0], [0.5, 5.0, 5.0]])
    imgs = sphere_images(c, np.array([1.0, 1.0]), (10.0, 10.0, 10.0), periodic=True)
    assert len(imgs) == 3  # the centre sphere, and the face sphere plus its image across x = 0


def _images_naive(c, r, box, reach=9):
    """Every shift t in [-reach, reach]^3 (x slowest, then y, z), and for each the spheres that reach the box once
    shifted by t*L (in their order): (x, y, z, r) rows.
    """
    rows = []
    for t in itertools.product(range(-reach, reach + 1), repeat=3):
        moved = c + np.array(t) * np.asarray(box)
        keep = np.all((moved + r[:, None] >= 0) & (moved - r[:, None] <= box), axis=1)
        rows.append(np.column_stack([moved[keep], r[keep]]))
    return np.concatenate(rows)


def test_images_equal_a_loop_over_shifts_in_order():
    # the kernels add balls in the order of these rows (ties in x-min keep it): values and order as a loop over
    # the shifts and then the spheres; spheres up to 4 boxes across in z (up to 5 images per axis)
    rng = np.random.default_rng(5)
    box = (10.0, 7.0, 4.0)
    for n in (0, 1, 30):
        c = rng.uniform(-6.0, 14.0, (n, 3))  # |c| + r + L < 9 L_z: the naive shifts reach every image
        r = rng.uniform(0.4, 8.0, n)
        imgs = sphere_images(c, r, box, periodic=True)
        # exact: c + t*L computed once, as in the naive loop
        np.testing.assert_array_equal(imgs, _images_naive(c, r, box))
        assert imgs.flags.c_contiguous


def test_grey_values_of_a_half_space_voxel_are_exact_fractions():
    # a huge sphere whose surface is locally a plane: voxels cut in half have exactly 108 points inside
    r = 1e6
    c = np.array([[-r + 4.0 + 1e-7, 2.0, 2.0]])  # plane at x = 4 (+1e-7), inside x < 4
    g = voxelize(c, np.array([r]), (8.0, 4.0, 4.0), 1.0, periodic=False)
    assert (g[:4] == 216).all() and (g[4:] == 0).all()


@pytest.mark.parametrize("periodic", [True, False])
def test_chord_ends_on_samples_exactly_on_the_surface(periodic):
    # h = a/6 = 1/8, a power of two: sample coordinates, centres on sample points and radii n*h are exact, so
    # dx*dx + dy*dy + dz*dz == r*r holds exactly for the lattice points of Pythagorean quadruples (e.g. 2,5,14 → 15):
    # every row through such a point has a chord end exactly on the surface (the closed ball keeps it)
    a = 0.75
    h = a / 6
    box = (4.5, 4.5, 3.0)  # 36 x 36 x 24 samples
    lattice = np.array([[9, 11, 7], [20, 17, 12], [27, 30, 3], [5, 33, 20], [14, 6, 22], [30, 2, 15]])
    c = (lattice + 0.5) * h
    # 15² = 2²+5²+14², 9² = 1²+4²+8², 7² = 2²+3²+6², 5² = 0²+3²+4², 13² = 3²+4²+12², 3² = 1²+2²+2²
    r = np.array([15, 9, 7, 5, 13, 3]) * h
    g = _both_equal_oracle(c, r, box, a, periodic)
    # the test means something only if samples sit exactly on a surface: count them with the kernels' arithmetic
    axes = [(np.arange(round(6 * e / a)) + 0.5) * h for e in box]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    on_surface = sum(
        int(np.count_nonzero((x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz) == rr * rr))
        for (cx, cy, cz), rr in zip(c, r)
    )
    assert on_surface > 100
    assert 0 < g.mean() < 216


@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize("a", [1.0, 0.25])
def test_large_spheres_cut_by_faces_equal_brute_force(a, periodic):
    # spheres 10-40 voxels wide (at a = 0.25 µm), whose rows hold long runs of whole voxels (set FULL without a test)
    # and shells on both sides; centres near and beyond the faces, so runs are cut by the volume or wrapped across it
    rng = np.random.default_rng(7)
    box = (12.0, 10.0, 8.0)
    c = np.vstack([rng.uniform(-1, 13, (6, 3)), [[0.1, 5.0, 7.9], [11.9, 0.2, 4.0]]])
    r = np.concatenate([rng.uniform(1.25, 5.0, 6), [4.6, 3.3]])
    fast = voxelize(c, r, box, a, periodic, VoxelizeMethod.boundary)
    brute = voxelize(c, r, box, a, periodic, VoxelizeMethod.brute)
    # exact: brute force is the 6^3 sample definition (checked against the numpy oracle above)
    np.testing.assert_array_equal(fast, brute)
    assert (fast == 216).mean() > 0.1 and ((fast > 0) & (fast < 216)).any()


@pytest.mark.parametrize("periodic", [True, False])
def test_overlapping_spheres_with_samples_on_their_surfaces(periodic):
    # Dense overlaps with surfaces through samples: many shell voxels are reached by two or more spheres (their
    # grey value is the popcount of a union bit mask, not one sphere's count) and are partly filled; centres on sample
    # points and radii n*h with h = 1/8 make dx*dx + dy*dy + dz*dz == r*r exact for lattice points on a surface
    a = 0.75
    h = a / 6
    box = (4.5, 4.5, 3.0)
    rng = np.random.default_rng(3)
    c = (rng.integers(0, 36, (30, 3)) % [36, 36, 24] + 0.5) * h
    r = rng.choice(np.array([3, 5, 7, 9, 13]), 30) * h
    g = _both_equal_oracle(c, r, box, a, periodic)
    alone = sum(
        grey_values_naive(c[n : n + 1], r[n : n + 1], box, a, periodic).astype(np.int64) for n in range(30)
    )
    shared = (alone > g) & (g > 0) & (g < 216)  # partly filled voxels where two spheres share samples
    assert shared.sum() >= 20


@pytest.mark.parametrize("periodic", [True, False])
def test_voxels_shared_by_three_or_more_spheres(periodic):
    # A cluster of spheres around one point: the voxels there get samples from three or more spheres, one after
    # the other (the first owns the count, the second makes it a union mask, later ones OR into it); spheres that
    # reach a voxel without a sample in it must leave it alone. Fails if a later sphere overwrites or double-counts.
    a = 0.75
    h = a / 6
    rng = np.random.default_rng(11)
    centre = np.array([2.2, 2.3, 1.6])
    c = centre + rng.uniform(-0.6, 0.6, (12, 3))
    r = rng.uniform(0.35, 0.9, 12)
    # two more whose surfaces pass through samples
    c = np.vstack([c, (np.array([[17, 18, 12], [19, 17, 14]]) + 0.5) * h])
    r = np.concatenate([r, [3 * h, 5 * h]])
    box = (4.5, 4.5, 3.0)
    g = _both_equal_oracle(c, r, box, a, periodic)
    singles = [grey_values_naive(c[n : n + 1], r[n : n + 1], box, a, periodic) for n in range(len(r))]
    partly = sum(((s > 0) & (s < 216)).astype(np.int64) for s in singles)
    assert ((partly >= 3) & (g < 216)).sum() >= 5  # voxels where three or more spheres each put some samples


def test_voxels_partly_filled_by_two_and_by_three_spheres():
    # A voxel the surfaces of two spheres cut counts the union of their samples without masks (the pair path); one
    # cut by a third sphere as well builds the masks of all three (the shared path). Three spheres whose centres are
    # 2 µm apart (r = 2.1 µm) meet near their common centroid: voxels there are partly filled by all three.
    c = np.array([[4.0, 4.0, 4.0], [6.0, 4.0, 4.0], [5.0, 5.7320508, 4.0]]) + 0.013
    r = np.array([2.1, 2.1, 2.1])
    g = _both_equal_oracle(c, r, (10.0, 10.0, 8.0), 0.5, periodic=False)
    partial = [((g > 0) & (g < 216) & _partly_in(c[s], r[s], g.shape, 0.5)) for s in range(3)]
    assert (partial[0] & partial[1]).sum() > (partial[0] & partial[1] & partial[2]).sum() > 0


def _partly_in(centre, radius, shape, a):
    """Voxels a sphere cuts (some corner inside, some outside): where its surface passes."""
    corners = np.stack(np.meshgrid(*[np.arange(n + 1) * a for n in shape], indexing="ij"), -1)
    inside = ((corners - centre) ** 2).sum(-1) <= radius * radius
    windows = [
        inside[i : i + shape[0], j : j + shape[1], k : k + shape[2]]
        for i in (0, 1)
        for j in (0, 1)
        for k in (0, 1)
    ]
    return np.any(windows, axis=0) & ~np.all(windows, axis=0)


@pytest.mark.parametrize("threads", [1, 2])
def test_small_spheres_at_random_sub_voxel_positions(threads):
    # Spheres 10-20 voxels wide (the benchmark's small case) at random sub-voxel centres and radii, dense enough that
    # many shell voxels are cut by two or three spheres; on one thread (one block of planes) and on two (one block
    # each, cut mid-volume): the grey values equal the numpy oracle of the 6^3 sample definition bit for bit
    rng = np.random.default_rng(22)
    box = (24.0, 20.0, 16.0)
    c = rng.uniform(0.0, 1.0, (7, 3)) * box
    r = rng.uniform(5.0, 10.0, 7)
    previous = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        g = _both_equal_oracle(c, r, box, 1.0, periodic=False)
    finally:
        numba.set_num_threads(previous)
    alone = [grey_values_naive(c[n : n + 1], r[n : n + 1], box, 1.0, False) for n in range(len(r))]
    cut = sum(((s > 0) & (s < 216)).astype(np.int64) for s in alone)
    assert ((g > 0) & (g < 216)).mean() > 0.1 and (g == 216).any()
    assert ((cut >= 2) & (g < 216)).sum() > 50 and ((cut >= 3) & (g < 216)).any()
