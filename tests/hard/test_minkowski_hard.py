"""Degenerate volumes give finite, exact answers; bad input gives a PorepipeError naming the problem."""

import re

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.minkowski import (
    Adjacency,
    configuration_histogram,
    configuration_histogram_slabs,
    minkowski_functionals,
    minkowski_functions_of_threshold,
    specific_surface_from_histogram,
)
from porepipe.minkowski import _weights as W

G = W.geometry((1.0, 1.0, 1.0))


def _finite(ds):
    for name in ("phi", "S_V", "K_V", "T_V", "chi"):
        assert np.all(np.isfinite(ds[name].values)), name


@pytest.mark.parametrize("fill", [0, 1])
@pytest.mark.parametrize("periodic", [True, False])
def test_all_pore_and_all_matrix(fill, periodic):
    ds = minkowski_functionals(np.full((5, 4, 3), fill, np.uint8), 2.0, periodic)
    _finite(ds)
    pore = ds.sel(phase="pore")
    assert float(pore.phi) == fill and float(pore.S_V) == 0.0 and float(pore.K_V) == 0.0
    # a full periodic box is the 3-torus (χ = 0); a full box in a window is a ball (χ = 1) ... but minus sampling
    # counts only the cells, whose local weights are 0 for a full cell: χ = 0 either way, and the empty phase has 0.
    assert float(pore.chi) == 0.0 and float(ds.chi.sel(phase="matrix")) == 0.0


@pytest.mark.parametrize("adjacency", list(Adjacency))
def test_single_pore_voxel(adjacency):
    v = np.zeros((5, 5, 5), np.uint8)
    v[2, 2, 2] = 1
    ds = minkowski_functionals(v, 1.0, False, adjacency)
    pore, window = ds.sel(phase="pore"), float(ds.attrs["window_um3"])
    assert float(pore.chi) == 1.0
    assert float(pore.phi) * window == pytest.approx(1.0, rel=1e-14)
    # Crofton values of a point: 2 transitions on one line per direction; χ = 1 in one plane of each family
    assert float(pore.S_V) * window == pytest.approx(4 * np.sum(G.line_weight / G.line_length_um), rel=1e-14)
    assert float(pore.K_V) * window == pytest.approx(
        2 * np.pi * np.sum(G.plane_weight * G.plane_spacing_um), rel=1e-14
    )


def test_single_voxel_volume():
    for fill in (0, 1):
        ds = minkowski_functionals(np.full((1, 1, 1), fill, np.uint8), 1.0, True)
        _finite(ds)
        assert int(ds.histogram.sel(phase="pore").sum()) == 1
    with pytest.raises(PorepipeError, match="axis x has 1 voxel"):
        minkowski_functionals(np.ones((1, 1, 1), np.uint8), 1.0, False)


def test_periodic_plate_one_voxel_thick():
    # plate normal to x, periodic in all axes: exact 13-direction Crofton value, K_V = 0, χ = 0 (T² × interval)
    v = np.zeros((8, 6, 7), np.uint8)
    v[3] = 1
    ds = minkowski_functionals(v, 0.5, True)
    pore = ds.sel(phase="pore")
    cos_x = np.abs(W.DIRECTIONS[:, 0]) / np.linalg.norm(W.DIRECTIONS, axis=1)
    expected = 2 / (8 * 0.5) * 2 * np.sum(G.line_weight * cos_x)  # true S_V = 2/(8 a); factor 0.926
    assert float(pore.S_V) == pytest.approx(expected, rel=1e-13)
    assert float(pore.K_V) == 0.0
    assert float(pore.chi) == 0.0 and float(ds.chi.sel(phase="matrix")) == 0.0
    assert float(pore.phi) == pytest.approx(1 / 8, rel=1e-14)


def test_plate_and_line_in_a_window():
    plate = np.zeros((3, 9, 9), np.uint8)
    plate[1, 2:7, 2:7] = 1
    line = np.zeros((3, 3, 12), np.uint8)
    line[1, 1, 1:11] = 1
    for v, n in ((plate, 25), (line, 10)):
        for adjacency in Adjacency:
            ds = minkowski_functionals(v, 1.0, False, adjacency)
            _finite(ds)
            assert float(ds.chi.sel(phase="pore")) == 1.0
            assert float(ds.phi.sel(phase="pore")) * float(ds.attrs["window_um3"]) == pytest.approx(
                n, rel=1e-14
            )


@pytest.mark.parametrize("shape", [(1, 9, 9), (2, 9, 9), (9, 1, 9), (9, 9, 2)])
def test_thin_dimensions(shape):
    # a disc extruded along a thin axis: periodic -> an infinite cylinder (χ = 0). Non-periodic with thickness 2,
    # minus sampling treats the window as a sample of a stationary structure (edge-corrected), so the slab cutting
    # through it also gives 0; padded with background along the thin axis it is a finite body with χ = 1.
    x, y = np.meshgrid(np.arange(9) - 4, np.arange(9) - 4, indexing="ij")
    disc = (x * x + y * y <= 9).astype(np.uint8)
    thin = int(np.argmin(shape))
    v = np.ascontiguousarray(np.moveaxis(np.repeat(disc[None], shape[thin], 0), 0, thin))
    periodic = [False, False, False]
    periodic[thin] = True
    ds = minkowski_functionals(v, 1.0, periodic)
    _finite(ds)
    assert float(ds.chi.sel(phase="pore")) == 0.0
    if shape[thin] == 2:
        assert float(minkowski_functionals(v, 1.0, False).chi.sel(phase="pore")) == 0.0
        pad = [(0, 0)] * 3
        pad[thin] = (1, 1)
        assert float(minkowski_functionals(np.pad(v, pad), 1.0, False).chi.sel(phase="pore")) == 1.0


def test_beyond_2_to_the_31_voxels_with_64_bit_counts():
    # 17 identical slabs of 2^27 voxels streamed from a generator (one slab in memory): 2.28e9 cells; the result
    # must be 17 x the periodic histogram of one slab, and the code-0 count itself exceeds 2^31.
    slab = np.zeros((16, 1024, 8192), np.uint8)
    slab[3:9, 100:200, 1000:2000] = 1
    slab[12, ::16, ::16] = 1
    hist, shape = configuration_histogram_slabs((slab for _ in range(17)), periodic=True)
    assert shape == (272, 1024, 8192)
    assert hist.sum() == 272 * 1024 * 8192 > 2**31
    assert hist[0] > 2**31
    np.testing.assert_array_equal(hist, 17 * configuration_histogram(slab, True))


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.zeros((4, 4), np.uint8), "must be 3-D"),
        (np.zeros((4, 4, 4), np.float32), "uint8 or bool"),
        (np.zeros((4, 1, 4), np.uint8), "axis y has 1 voxel"),
    ],
)
def test_bad_volumes(bad, match):
    with pytest.raises(PorepipeError, match=match):
        minkowski_functionals(bad, 1.0, False)


@pytest.mark.parametrize("voxel", [0.0, -1.0, float("nan"), (1.0, 2.0)])
def test_bad_voxel_size(voxel):
    with pytest.raises(PorepipeError, match="voxel_um"):
        minkowski_functionals(np.zeros((3, 3, 3), np.uint8), voxel, True)


def test_bad_adjacency_and_slabs():
    with pytest.raises(PorepipeError, match="adjacency 'eight'"):
        minkowski_functionals(np.zeros((3, 3, 3), np.uint8), 1.0, True, "eight")
    with pytest.raises(PorepipeError, match="slab 1"):
        configuration_histogram_slabs([np.zeros((2, 3, 3), np.uint8), np.zeros((2, 3, 4), np.uint8)])
    with pytest.raises(PorepipeError, match="no slabs"):
        configuration_histogram_slabs([])
    with pytest.raises(PorepipeError, match="3-D uint8"):
        minkowski_functions_of_threshold(np.zeros((3, 3, 3), np.float64), 1.0)


@pytest.mark.parametrize(
    ("grey_shape", "grey_voxel", "grey_periodic"),
    [((8, 8, 8), 1.0, (True, True, True)), ((4, 4, 4), 2.0, (True, True, True)), ((4, 4, 4), 1.0, (0, 0, 0))],
)
def test_grey_volume_on_another_grid_is_refused(tmp_path, grey_shape, grey_voxel, grey_periodic):
    """``minkowski binary_a4.h5 --grey grey_a2.h5`` wrote the 2 µm grey volume's threshold table beside the 4 µm
    binary volume's functionals without a word; a grey volume of another shape, voxel size or periodicity is now one
    line, before any work and with no result file."""
    from porepipe._shared.store import ResultWriter
    from porepipe.minkowski._run import run

    with ResultWriter(tmp_path / "binary.h5", stage="segment", scene="t") as w:
        w.write_volume("pore", np.ones((4, 4, 4), np.uint8), voxel_um=1.0, periodic=(True, True, True))
    with ResultWriter(tmp_path / "grey.h5", stage="voxelize", scene="t") as w:
        w.write_volume("grey", np.zeros(grey_shape, np.uint8), voxel_um=grey_voxel, periodic=grey_periodic)
    with pytest.raises(PorepipeError, match="is not on the grid of binary volume"):
        run(tmp_path / "binary.h5", tmp_path / "m.h5", grey_path=tmp_path / "grey.h5", threads=1)
    assert not (tmp_path / "m.h5").exists()


# -- extreme voxel sizes ---------------------------------------------------------------------------------------------
_POWERS = {"phi": 0, "S_V": -1, "K_V": -2, "T_V": -3, "chi": 0}


@pytest.mark.parametrize("a", [1e-100, 1e-20, 1.0, 1e20, 1e100])
@pytest.mark.parametrize("shape", [(1.0, 1.0, 1.0), (1.0, 2.0, 3.0)])
def test_extreme_voxel_sizes_scale_exactly(a, shape):
    """``voxel_um`` 1e100 died in SphericalVoronoi ('Rank of input points must be at least 3') and 1e-100 with 'SVD
    did not converge': the Crofton weights were computed from the physical edge lengths. They are now computed in
    voxel units and the functionals scaled afterwards: at voxel size a they are those at a = 1 times a^k."""
    body = np.zeros((7, 8, 9), np.uint8)
    body[1:5, 2:6, 2:7] = 1
    body[2, 3, 3] = 0  # a cavity: χ = 2
    ref = minkowski_functionals(body, shape, periodic=False)
    ds = minkowski_functionals(body, tuple(a * s for s in shape), periodic=False)
    assert float(ref.chi.sel(phase="pore")) == 2.0
    for name, k in _POWERS.items():
        np.testing.assert_allclose(ds[name].values, ref[name].values * a**k, rtol=1e-12, atol=0, err_msg=name)
    assert float(ds.attrs["window_um3"]) == pytest.approx(float(ref.attrs["window_um3"]) * a**3, rel=1e-12)
    hist = configuration_histogram(body, False)
    assert specific_surface_from_histogram(hist, a) == pytest.approx(
        specific_surface_from_histogram(hist, 1.0) / a, rel=1e-12
    )


@pytest.mark.parametrize(
    ("a", "what"), [(1e-110, "T_V"), (1e110, "T_V"), (1e-200, "K_V"), (1e300, "K_V"), (1e-310, "S_V")]
)
def test_voxel_size_beyond_float64_is_refused(tmp_path, a, what):
    """A functional that over- or underflows float64 in µm units is refused naming the voxel size (no inf, no 0,
    no result file)."""
    from porepipe._shared.store import ResultWriter
    from porepipe.minkowski._run import run

    body = np.zeros((6, 6, 6), np.uint8)
    body[1:4, 1:4, 1:4] = 1
    with pytest.raises(
        PorepipeError, match=rf"voxel_um = {re.escape(repr(a))} µm: {what} = .* beyond the float64 range"
    ):
        minkowski_functionals(body, a, periodic=False)
    with ResultWriter(tmp_path / "binary.h5", stage="segment", scene="t") as w:
        w.write_volume("pore", body, voxel_um=a, periodic=(False, False, False))
    with pytest.raises(PorepipeError, match=rf"voxel_um = {re.escape(repr(a))} µm"):
        run(tmp_path / "binary.h5", tmp_path / "m.h5", threads=1)
    assert not (tmp_path / "m.h5").exists()


@pytest.mark.parametrize("a", [1e-100, 1e100])
def test_extreme_voxel_size_with_grey_thresholds(tmp_path, a):
    """The run with a grey volume at an extreme voxel size writes finite tables scaled like those at 1 µm."""
    import xarray as xr

    from porepipe._shared.store import ResultWriter
    from porepipe.minkowski._run import THRESHOLD_GROUP, run

    grey = np.random.default_rng(7).integers(0, 217, (6, 6, 6)).astype(np.uint8)
    for size in (1.0, a):
        with ResultWriter(tmp_path / f"binary{size!r}.h5", stage="segment", scene="t") as w:
            w.write_volume("pore", (grey <= 108).astype(np.uint8), voxel_um=size)
        with ResultWriter(tmp_path / f"grey{size!r}.h5", stage="voxelize", scene="t") as w:
            w.write_volume("grey", grey, voxel_um=size)
        run(
            tmp_path / f"binary{size!r}.h5",
            tmp_path / f"m{size!r}.h5",
            grey_path=tmp_path / f"grey{size!r}.h5",
        )
    for group in (None, THRESHOLD_GROUP):
        with (
            xr.open_dataset(tmp_path / "m1.0.h5", engine="h5netcdf", group=group) as ref,
            xr.open_dataset(tmp_path / f"m{a!r}.h5", engine="h5netcdf", group=group) as ds,
        ):
            for name, k in _POWERS.items():
                assert np.all(np.isfinite(ds[name].values))
                np.testing.assert_allclose(ds[name].values, ref[name].values * a**k, rtol=1e-12, atol=0)


@pytest.mark.parametrize("voxel", [(1.0, 1.0, 1e-6), (1e-100, 1e-100, 1e-94), (2e6, 1.0, 1.0)])
def test_voxel_edges_too_unequal_for_crofton_weights_are_refused(voxel):
    """Edges a million times apart died in scipy's SphericalVoronoi ('Duplicate generators present'); now one line."""
    with pytest.raises(PorepipeError, match=r"voxel_um = .* times the shortest; allowed: up to 100000"):
        minkowski_functionals(np.zeros((3, 3, 3), np.uint8), voxel, True)


def test_voxel_edges_1e5_apart_still_work():
    ds = minkowski_functionals(np.eye(4, dtype=np.uint8)[:, :, None].repeat(3, 2), (1.0, 1.0, 1e-5), True)
    _finite(ds)
