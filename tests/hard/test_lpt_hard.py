"""Degenerate inputs of the lpt stage: extreme cell sizes, uniform volumes, bad input, anisotropic voxels."""

import h5py
import numpy as np
import pydantic
import pytest
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_binary_volume, read_table
from porepipe.cli import main as cli_main
from porepipe.lpt import Settings, local_porosity_analysis, local_porosity_histogram, percolation_bits
from porepipe.sweep._crop import crop_corner

FLOAT_VARS = ["mu", "phi_mean", "phi_var", "p", "mu_sv", "sv_mean_per_um"]


def analyse(pore, sizes, periodic=(True, True, True), **kw):
    return local_porosity_analysis(pore, periodic=periodic, settings=Settings(cell_voxels=sizes, **kw))


@pytest.mark.parametrize("fill", [0, 1])
def test_uniform_volumes(fill):
    pore = np.full((9, 10, 11), fill, np.uint8)
    ds = analyse(pore, [1, 4, 9], lambda_stride=1)
    # all matrix: μ = δ(φ), nothing percolates; all pore: μ = δ(φ-1), every cell percolates in every direction
    for L in (1, 4, 9):
        d = ds.sel(L=L)
        assert (d.cells_phi1 if fill else d.cells_phi0) == d.cells_total
        np.testing.assert_array_equal(d.p, float(fill))
    assert ds.attrs["L_star"] == 0  # μ(φ0) or μ(1) never vanishes: L* is not reached
    assert np.isnan(ds.attrs["L_star_um"])  # "no value" for the sweep, which fits only finite values
    for name in FLOAT_VARS:
        assert np.isfinite(ds[name]).all(), name
    np.testing.assert_array_equal(ds.sv_mean_per_um, 0.0)  # no interface anywhere


def test_cell_equal_to_sample_inside_placement():
    pore = (np.random.default_rng(0).random((12, 12, 12)) < 0.5).astype(np.uint8)
    ds = analyse(pore, [12], periodic=(False, False, False), lambda_stride=1)
    assert ds.cells_total.item() == 1 and ds.lambda_cells_total.item() == 1
    assert ds.phi_mean.item() == pytest.approx(pore.mean(), rel=1e-15)


def test_cell_not_dividing_the_sample():
    pore = (np.random.default_rng(1).random((20, 21, 22)) < 0.4).astype(np.uint8)
    ds = analyse(pore, [7], periodic=(False, False, False), lambda_stride=3)
    assert ds.cells_total.item() == 14 * 15 * 16
    assert ds.lambda_cells_total.item() == 5 * 5 * 6  # ceil(14/3), ceil(15/3), ceil(16/3)
    np.testing.assert_allclose(ds.mu.sum(), 1.0, atol=1e-12)


def test_mixed_periodicity_wraps_only_periodic_axes():
    pore = (np.random.default_rng(2).random((10, 10, 10)) < 0.4).astype(np.uint8)
    ds = analyse(pore, [4], periodic=(True, False, True))
    assert ds.cells_total.item() == 10 * 7 * 10
    assert "y: fully inside" in ds.placement.item() and "x: periodic wrap" in ds.placement.item()
    inside = local_porosity_analysis(
        pore, periodic=(True, True, True), settings=Settings(cell_voxels=[4], placement="inside")
    )
    assert inside.cells_total.item() == 7**3


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda p: local_porosity_histogram(p, 11), "exceeds the sample"),
        (lambda p: local_porosity_histogram(p, 0), "at least 1"),
        (lambda p: local_porosity_histogram(p.astype(np.float32), 2), "uint8"),
        (lambda p: local_porosity_histogram(p * 2, 2), "only 0 and 1"),
        (lambda p: local_porosity_histogram(p[0], 2), "3-D"),
        (lambda p: local_porosity_histogram(p, 2, stride=0), "stride"),
        (lambda p: local_porosity_histogram(np.ones((260, 260, 260), np.uint8), 256), "give max_bins"),
        (lambda p: percolation_bits(p, 3, np.zeros((2, 3)), np.zeros(3)), "one entry per origin"),
        (lambda p: percolation_bits(p, 3, np.array([[0, 10, 0]])), "must lie in the volume"),
        (
            lambda p: local_porosity_analysis(p, voxel_um=2.0, settings=Settings(cell_um=[0.9])),
            "half a voxel",
        ),
        (lambda p: local_porosity_analysis(p, voxel_um=0.0), "voxel_um"),
    ],
)
def test_bad_input_names_the_problem(call, match):
    pore = np.ones((10, 10, 10), np.uint8)
    with pytest.raises(PorepipeError, match=match):
        call(pore)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"cell_um": [1.0], "cell_voxels": [1]},
        {"directions": ["x", "x"]},
        {"directions": []},
        {"connectivity": 18},
        {"mu_stride": 0},
        {"directions": ["w"]},
        {"cell_voxel": [2]},
    ],
)
def test_bad_settings_are_refused(kwargs):
    with pytest.raises(pydantic.ValidationError):
        Settings(**kwargs)


def test_bool_volume_and_cell_um_rounding():
    pore = np.random.default_rng(3).random((16, 16, 16)) < 0.3
    ds = local_porosity_analysis(
        pore, voxel_um=2.5, settings=Settings(cell_um=[5.0, 6.2, 20.0], surface=False)
    )
    assert ds.L.values.tolist() == [2, 8]  # 6.2/2.5 = 2.48 rounds to 2 as 5.0 does; both are merged
    np.testing.assert_allclose(ds.L_um, [5.0, 20.0])
    assert "'6.2': 2" in ds.attrs["cell_um_to_voxels"]


def write_binary(path, pore, voxel_um=1.0, periodic=(True, True, True)):
    with ResultWriter(path, stage="segment", scene="t") as w:
        w.write_volume("pore", pore, voxel_um=voxel_um, periodic=periodic)


def test_anisotropic_voxels_are_refused(tmp_path):
    path = tmp_path / "binary_a1.h5"
    write_binary(path, np.ones((8, 8, 8), np.uint8))
    with h5py.File(path, "a") as f:
        f["volumes/pore"].attrs["voxel_um"] = np.array(
            [2.0, 2.0, 2.0]
        )  # three equal edges are one cubic voxel
    assert read_binary_volume(path)[1].voxel_um == 2.0
    with h5py.File(path, "a") as f:
        f["volumes/pore"].attrs["voxel_um"] = np.array([1.0, 1.0, 2.0])
    with pytest.raises(PorepipeError, match="anisotropic"):
        read_binary_volume(path)
    write_binary(path, np.ones((8, 8, 8), np.uint8))
    with h5py.File(path, "a") as f:
        f["volumes/pore"].attrs["voxel_um"] = np.array([1.0, 1.0, 2.0])
    code = cli_main(["lpt", str(path), "-o", str(tmp_path / "lpt_a1.h5"), "--cell-voxels", "2"])
    assert code == 2 and not (tmp_path / "lpt_a1.h5").exists()


def test_cli_writes_dataset_and_plots(tmp_path):
    pore = (np.random.default_rng(4).random((20, 20, 20)) < 0.35).astype(np.uint8)
    src = tmp_path / "binary_a2.h5"
    write_binary(src, pore, voxel_um=2.0)
    out = tmp_path / "lpt_a2.h5"
    assert (
        cli_main(
            [
                "lpt",
                str(src),
                "-o",
                str(out),
                "--cell-um",
                "2",
                "8",
                "20",
                "--lambda-stride",
                "2",
                "--threads",
                "1",
            ]
        )
        == 0
    )
    ds = read_table(out)
    assert ds.L.values.tolist() == [1, 4, 10] and ds.attrs["voxel_um"] == 2.0
    assert ds.pore_voxels.sum("bin").values.tolist() == [int(pore.sum()) * L**3 for L in (1, 4, 10)]
    with xr.open_dataset(out, engine="h5netcdf") as opened:  # readable by plain xarray
        assert set(opened.alpha.values) == {"x", "y", "z", "3", "c"}
    for kind in ("mu", "lambda", "p", "sv"):
        assert (tmp_path / f"lpt_a2_{kind}.png").stat().st_size > 1000
    # REV sub-sample: corner cube, not periodic, cells larger than it left out and said so
    rev = tmp_path / "lpt_a2_s16.h5"
    assert (
        cli_main(
            [
                "lpt",
                str(src),
                "-o",
                str(rev),
                "--cell-um",
                "2",
                "8",
                "20",
                "--subsample-um",
                "16",
                "--no-plots",
                "--no-surface",
            ]
        )
        == 0
    )
    ds = read_table(rev)
    assert ds.L.values.tolist() == [1, 4] and np.atleast_1d(ds.attrs["skipped_cell_voxels"]).tolist() == [10]
    assert ds.attrs["wrap"].tolist() == [0, 0, 0] and "corner cube" in ds.attrs["sample"]
    assert ds.pore_voxels.sel(L=1).sum() == pore[:8, :8, :8].sum()
    assert cli_main(["lpt", str(src), "-o", str(rev), "--subsample-um", "100"]) == 2
    # the workflow's sample-size sweep: a file from `porepipe subsample` is recognised as a sub-sample
    part = tmp_path / "binary_a2_L16.h5"
    crop_corner(src, 16.0, part)
    assert (
        cli_main(
            [
                "lpt",
                str(part),
                "-o",
                str(tmp_path / "lpt_a2_L16.h5"),
                "--cell-um",
                "2",
                "8",
                "20",
                "--no-plots",
            ]
        )
        == 0
    )
    ds = read_table(tmp_path / "lpt_a2_L16.h5")
    assert ds.L.values.tolist() == [1, 4] and "corner cube of 16 µm" in ds.attrs["sample"]


def test_plots_of_one_voxel_cells_only_draw_without_a_warning(tmp_path):
    """With cells of one voxel only (``--cell-um 3`` at 4 µm rounds to L = 1) the S_V plot has no curve, and its
    legend() printed matplotlib's 'No artists with labels' warning into every such run's log."""
    pore = (np.random.default_rng(4).random((12, 12, 12)) < 0.35).astype(np.uint8)
    src = tmp_path / "binary_a4.h5"
    write_binary(src, pore, voxel_um=4.0)
    out = tmp_path / "lpt_a4.h5"
    assert (
        cli_main(["lpt", str(src), "-o", str(out), "--cell-um", "3", "--threads", "1"]) == 0
    )  # warnings: errors
    assert read_table(out).L.values.tolist() == [1]
    assert (tmp_path / "lpt_a4_sv.png").is_file()
