"""Geometry: generators, the accessible cluster, wall area and the 1-byte distance codes against naive references."""

import numpy as np
import pytest
from naive_diffusion import chessboard_naive, largest_spanning_naive, wall_area_naive

from porepipe._shared.errors import PorepipeError
from porepipe.diffusion import (
    Settings,
    accessible_pore,
    closed_box,
    constricted_capillary,
    cylinder,
    equilibrium,
    pocketed_capillary,
    prepare,
    rough_capillary,
    slit,
    square_capillary,
    wall_area,
)
from porepipe.diffusion._kernels import (
    _EDGE_CODE,
    _EDGE_CROSS,
    _HALF_WIDTH,
    _PRISM_CODE,
    _PRISM_CROSS,
    _SLAB_CODE,
    _box_codes,
    _chessboard_distance,
)


def _random_pore(shape, p, seed):
    return (np.random.default_rng(seed).random(shape) < p).astype(np.uint8)


@pytest.mark.parametrize("seed", range(4))
def test_codes_equal_scipy_chessboard(seed):
    pore = _random_pore((13, 11, 17), 0.8 + 0.04 * seed, seed)
    codes = np.empty(pore.shape, np.uint8)
    _chessboard_distance(pore, codes)
    np.testing.assert_array_equal(codes, chessboard_naive(pore))


def test_codes_saturate_at_255_and_fit_one_byte():
    pore = np.ones((520, 3, 3), np.uint8)  # distance along x never exceeds 2 here; a long open box instead:
    big = np.ones((600, 600, 1), np.uint8)
    codes = np.empty(big.shape, np.uint8)
    _chessboard_distance(big, codes)
    assert codes.dtype == np.uint8 and codes.max() == 1  # one layer thick: every voxel touches the outside
    codes = np.empty(pore.shape, np.uint8)
    _chessboard_distance(pore, codes)
    np.testing.assert_array_equal(codes, chessboard_naive(pore))


def test_code_ranges_do_not_overlap():
    """Cubes, edge boxes, slabs and prisms each keep their own codes in one byte."""
    assert _EDGE_CODE + 3 * len(_EDGE_CROSS) <= _SLAB_CODE < _PRISM_CODE <= 256 - 3 * len(_PRISM_CROSS)


def _channel_with_pillars(seed):
    """A 30 x 26 x 90 channel with a few solid pillars and plates: flat walls (slabs), long free runs (prisms), and
    boxes that the obstacles cut short."""
    rng = np.random.default_rng(seed)
    pore = np.ones((30, 26, 90), np.uint8)
    for _ in range(5):
        a, b, c = rng.integers(0, 30), rng.integers(0, 26), rng.integers(0, 90)
        pore[a, b : b + 3, c : c + 2] = 0
    pore[8:20, 4:7, 60] = 0
    return pore


@pytest.mark.parametrize(
    "pore",
    [
        _channel_with_pillars(0),
        _channel_with_pillars(1),
        square_capillary(30, 140).pore,
        _random_pore((40, 44, 36), 0.995, 5),
    ],
)
def test_every_code_is_an_all_pore_box_with_the_chessboard_distance_across(pore):
    """Each code's box (per-axis half-widths _HALF_WIDTH, centred on the voxel) lies in the volume and is all pore,
    and its smallest half-width is the voxel's chessboard distance - 1 (what the cube-ahead tries and the prism pass
    rely on); slabs across and prisms along every axis occur, and edge boxes where two flat walls meet."""
    codes = np.empty(pore.shape, np.uint8)
    _box_codes(pore.copy(), codes)
    chess = np.minimum(chessboard_naive(pore), _EDGE_CODE - 1)
    np.testing.assert_array_equal(codes > 0, pore > 0)
    for idx in np.argwhere(codes > 0):
        half = _HALF_WIDTH[:, codes[tuple(idx)]].astype(np.int64)
        lo, hi = idx - half, idx + half + 1
        assert np.all(lo >= 0) and np.all(hi <= pore.shape)
        assert pore[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]].all()
        assert half.min() == chess[tuple(idx)] - 1
    slabs = codes[(codes >= _SLAB_CODE) & (codes < _PRISM_CODE)]
    prisms = codes[codes >= _PRISM_CODE]
    edges = codes[(codes >= _EDGE_CODE) & (codes < _SLAB_CODE)]
    if pore.shape == (30, 26, 90):
        assert {int(np.argmin(_HALF_WIDTH[:, c])) for c in slabs} == {0, 1, 2}  # thin axis
        assert {int(np.argmax(_HALF_WIDTH[:, c])) for c in prisms} == {0, 1, 2}  # long axis
    assert len(slabs) > 0 and len(prisms) > 0
    if pore.shape[2] >= 90:  # the channels and the capillary: along their four edges
        assert {int(np.argmax(_HALF_WIDTH[:, c])) for c in edges} >= {2}  # long axis


def test_cylinder_voxels_are_the_centres_inside():
    vol = cylinder(5.3, 7, voxel=(1.0, 0.5, 1.0))
    n0, n1, _ = vol.pore.shape
    assert (n0, n1) == (11, 22)
    for i in range(n0):
        for j in range(n1):
            x = (i + 0.5) * 1.0 - n0 * 1.0 / 2
            y = (j + 0.5) * 0.5 - n1 * 0.5 / 2
            assert vol.pore[i, j, 0] == (x * x + y * y <= 5.3**2)
    assert np.all(vol.pore == vol.pore[:, :, :1])


def test_generators_shapes_and_porosity():
    assert square_capillary(3, 9).pore.shape == (3, 3, 9)
    s = slit(4, 10, depth=3)
    assert s.pore.shape == (4, 3, 10) and s.periodic.tolist() == [False, True, False]
    a = constricted_capillary(6, 36, 2, 4)
    full = cylinder(6, 36).pore
    assert a.pore.sum() < full.sum() and a.pore[:, :, 0].sum() == full[:, :, 0].sum()
    assert a.pore[:, :, 12].sum() == cylinder(2, 1).pore.sum()  # the throat is the r = 2 disk
    b = pocketed_capillary(6, 30, 3, 4, n_pockets=3)
    assert b.pore.sum() == 6 * 6 * 30 + 3 * 3 * 4 * 4
    c = rough_capillary(8, 40, 0.3, seed=1)
    frac = 1 - c.pore.sum() / c.pore.size
    assert 0.3 * 28 / 64 - 0.05 < frac < 0.3 * 28 / 64 + 0.05  # 28 of 64 cells per layer are wall cells
    assert closed_box((2, 3, 4)).pore.sum() == 24


@pytest.mark.parametrize("seed", range(3))
def test_accessible_cluster_equals_bfs(seed):
    pore = _random_pore((9, 8, 12), 0.62, seed)
    ref = largest_spanning_naive(pore, 2)
    if ref is None:
        with pytest.raises(PorepipeError, match="no face-connected pore path"):
            accessible_pore(pore, 2)
    else:
        np.testing.assert_array_equal(accessible_pore(pore, 2).astype(bool), ref)


def test_accessible_vs_total_porosity():
    pore = np.zeros((5, 5, 6), np.uint8)
    pore[2, 2, :] = 1  # the channel
    pore[0, 0, 1:3] = 1  # a closed bubble: counts in the total, not in the accessible porosity
    g = prepare(pore, 1.0, axis=2)
    assert g.total_porosity == pytest.approx(8 / 150, rel=1e-12)
    assert g.accessible_porosity == pytest.approx(6 / 150, rel=1e-12)


def test_errors_all_solid_and_no_path():
    with pytest.raises(PorepipeError, match="all solid"):
        prepare(np.zeros((3, 3, 3), np.uint8))
    pore = np.ones((4, 4, 6), np.uint8)
    pore[:, :, 3] = 0
    with pytest.raises(PorepipeError, match=r"no face-connected pore path joins the inlet face z = 0"):
        prepare(pore, axis=2)
    with pytest.raises(PorepipeError, match="x = 0"):
        prepare(np.transpose(pore, (2, 1, 0)), axis=0)


def test_error_no_wall_with_every_axis_periodic():
    # an all-pore volume periodic on every axis has no wall: a flight would never end (it hung before the check);
    # one solid voxel gives it walls
    with pytest.raises(PorepipeError, match=r"shape \(6, 6, 6\) has no wall and every axis is periodic"):
        equilibrium(np.ones((6, 6, 6), np.uint8), Settings(setup="msd"), periodic=(1, 1, 1))
    pore = np.ones((6, 6, 6), np.uint8)
    pore[3, 3, 3] = 0
    s = Settings(setup="msd", batches=2, batch_particles=4, msd_time_jiffies=20.0, max_rounds=1)
    assert np.isfinite(equilibrium(pore, s, periodic=(1, 1, 1)).values["D_m2_s"])


@pytest.mark.parametrize("periodic,open_axis", [((0, 0, 0), None), ((0, 1, 0), 2), ((1, 1, 0), None)])
def test_wall_area_equals_face_count(periodic, open_axis):
    pore = _random_pore((6, 7, 5), 0.6, 3)
    h = (1.0, 0.5, 2.0)
    assert wall_area(pore, h, periodic, open_axis) == pytest.approx(
        wall_area_naive(pore, h, periodic, open_axis)
    )
