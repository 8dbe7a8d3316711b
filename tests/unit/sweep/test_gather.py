"""Gathering result files into sweep.h5: generic quantity discovery, cost records, corner sub-samples."""

import numpy as np
import pytest
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_attrs, read_volume
from porepipe.sweep import (
    FULL,
    build_sweep,
    crop_corner,
    gather,
    parse_name,
    read_benchmarks,
    subsample_offsets,
)


def _result(path, ds, stage):
    with ResultWriter(path, stage=stage, scene="t") as w:
        w.write_table(ds)
    return path


def _engine_file(tmp_path, a, value, sample=None):
    """A result of an engine the sweep has never heard of: 0-d, labelled 1-d, curve and integer variables."""
    ds = xr.Dataset(
        {
            "kappa": ((), value),
            "surface": ("phase", [2 * value, 3 * value]),
            "curve": ("t", np.arange(20.0)),
            "count": ((), 7),
        },
        coords={"phase": ["pore", "matrix"]},
        attrs={"phi_bar": 0.25, "tau": 0.8},
    )
    tag = f"_L{sample:g}" if sample else ""
    return _result(tmp_path / "newengine" / f"new_a{a:g}{tag}_x.h5", ds, "newengine")


def test_parse_name():
    assert parse_name("perm_a0.5_x") == ("perm", 0.5, FULL, "x")
    assert parse_name("lpt_a2_s50") == ("lpt", 2.0, 50.0, "")
    assert parse_name("minkowski_a1_L25") == ("minkowski", 1.0, 25.0, "")
    assert parse_name("estimate") == ("estimate", None, FULL, "")


def test_new_engine_joins_without_code_changes(tmp_path):
    paths = [_engine_file(tmp_path, a, 10.0 + a) for a in (4.0, 2.0, 1.0)]
    paths.append(_engine_file(tmp_path, 2.0, 99.0, sample=20))
    ds = gather(paths)
    assert sorted(ds.quantity.values) == [
        "newengine_x.kappa",
        "newengine_x.phi_bar",
        "newengine_x.surface[matrix]",
        "newengine_x.surface[pore]",
    ]
    full = ds.value.sel(quantity="newengine_x.kappa", sample_um=FULL)
    np.testing.assert_array_equal(full.values, [14.0, 12.0, 11.0])  # copied values: exact
    assert float(ds.value.sel(quantity="newengine_x.surface[matrix]", a_um=2.0, sample_um=20.0)) == 297.0
    assert np.isnan(float(ds.value.sel(quantity="newengine_x.kappa", a_um=4.0, sample_um=20.0)))
    # each run's cost comes from its store attributes
    wall = ds.wall_s.sel(quantity="newengine_x.kappa", sample_um=FULL).values
    assert wall.tolist() == [read_attrs(p)["wall_s"] for p in paths[:3]]


def test_per_resolution_table_and_benchmarks(tmp_path):
    a = np.array([4.0, 2.0, 1.0])
    est = xr.Dataset(
        {
            "phi_lower": ("a_um", [0.1, 0.2, 0.25]),
            "phi_limit": ((), 0.3),
            "hist": (("a_um", "g"), np.zeros((3, 5))),
        },
        coords={"a_um": a},
    )
    path = _result(tmp_path / "estimate.h5", est, "estimate")
    cost = tmp_path / "cost"
    cost.mkdir()
    head = "s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\tmean_load\tcpu_time\n"
    (cost / "estimate.tsv").write_text(head + "1.5\t0:00:01\t150.0\t1\t1\t1\t0\t0\t0\t0.7\n")
    assert read_benchmarks(cost)[("estimate", None, FULL, "")]["bench_cpu_s"] == 0.7
    ds = build_sweep([path], cost_dir=cost)
    assert ds.quantity.values.tolist() == ["estimate.phi_lower"]
    np.testing.assert_array_equal(ds.value.sel(sample_um=FULL).values[0], [0.1, 0.2, 0.25])
    assert (ds.bench_s.values == 1.5).all() and (ds.bench_max_rss_mb.values == 150.0).all()
    assert set(ds.form.values) == {"power", "linear"}


def test_upstream_cost_and_voxels_from_volumes(tmp_path):
    vols = []
    for a in (2.0, 1.0):
        with ResultWriter(tmp_path / f"binary_a{a:g}.h5", stage="segment") as w:
            w.write_volume("pore", np.ones((int(8 / a),) * 3, np.uint8), voxel_um=a)
        vols.append(tmp_path / f"binary_a{a:g}.h5")
    crop_corner(vols[1], 4.0, tmp_path / "binary_a1_L4.h5")
    vols.append(tmp_path / "binary_a1_L4.h5")
    ds = gather([_engine_file(tmp_path, a, a) for a in (2.0, 1.0)], vols)
    assert ds.voxels.sel(sample_um=FULL).values.tolist() == [64, 512]
    assert float(ds.voxels.sel(a_um=1.0, sample_um=4.0)) == 64
    # the sub-sample's upstream cost includes the whole volume it was cut from
    full = float(ds.upstream_wall_s.sel(a_um=1.0, sample_um=FULL))
    crop = read_attrs(tmp_path / "binary_a1_L4.h5")["wall_s"]
    assert float(ds.upstream_wall_s.sel(a_um=1.0, sample_um=4.0)) == pytest.approx(full + crop, rel=1e-12)


def test_crop_is_the_corner_cube_and_not_periodic(tmp_path):
    rng = np.random.default_rng(5)
    pore = (rng.random((12, 10, 9)) < 0.4).astype(np.uint8)
    with ResultWriter(tmp_path / "binary_a0.5.h5", stage="segment", scene="t") as w:
        w.write_volume(
            "pore", pore, voxel_um=0.5, origin_um=(1.0, 2.0, 3.0), attrs={"threshold": 108, "method": "otsu"}
        )
    crop_corner(tmp_path / "binary_a0.5.h5", 4.0, tmp_path / "binary_a0.5_L4.h5")
    cube, attrs = read_volume(tmp_path / "binary_a0.5_L4.h5", "pore")
    np.testing.assert_array_equal(cube, pore[:8, :8, :8])
    assert attrs["periodic"] == [0, 0, 0] and attrs["origin_um"] == [1.0, 2.0, 3.0]
    assert attrs["threshold"] == 108 and attrs["method"] == "otsu" and attrs["voxel_um"] == 0.5


@pytest.mark.parametrize(
    "edge_um", [4.25, 5.0, -1.0]
)  # not whole voxels; larger than the 9-voxel axis; negative
def test_crop_rejects_bad_edges(tmp_path, edge_um):
    with ResultWriter(tmp_path / "b.h5", stage="segment") as w:
        w.write_volume("pore", np.zeros((12, 10, 9), np.uint8), voxel_um=0.5)
    with pytest.raises(PorepipeError, match="sub-sample edge"):
        crop_corner(tmp_path / "b.h5", edge_um, tmp_path / "c.h5")


def test_no_quantities_is_an_error(tmp_path):
    path = _result(tmp_path / "x_a1.h5", xr.Dataset({"n": ((), 3)}), "x")
    with pytest.raises(PorepipeError, match="no scalar quantity"):
        gather([path])


@pytest.mark.parametrize(
    ("count", "shape", "n", "starts"), [(8, (8, 8, 8), 4, [0, 4]), (64, (10, 10, 10), 4, [0, 2, 4, 6])]
)
def test_subsample_grid_spreads_cubes_from_face_to_face(count, shape, n, starts):
    # offsets round(i (N - n) / (m - 1)) per axis, x fastest: the first and last cube touch the low and high faces
    offsets = [subsample_offsets(k, count, n, shape) for k in range(count)]
    assert offsets[1] == (starts[1], 0, 0) and offsets[len(starts)] == (0, starts[1], 0)
    assert sorted(set(offsets)) == sorted((x, y, z) for x in starts for y in starts for z in starts)


def test_subsample_replicas_are_averaged_with_their_spread(tmp_path):
    # 8 disjoint 4³ cubes of an 8³ random volume: the gathered value and rev_spread are numpy's mean and std
    # (ddof = 1) of the cubes' porosities, which are computed here from the array, not by the code under test
    rng = np.random.default_rng(9)
    pore = (rng.random((8, 8, 8)) < 0.3).astype(np.uint8)
    with ResultWriter(tmp_path / "binary_a1.h5", stage="segment", scene="t") as w:
        w.write_volume("pore", pore, voxel_um=1.0, origin_um=(10.0, 0.0, 0.0))
    paths, expected = [], []
    for k in range(8):
        crop_corner(tmp_path / "binary_a1.h5", 4.0, tmp_path / f"binary_a1_L4_k{k}.h5", index=k, count=8)
        cube, attrs = read_volume(tmp_path / f"binary_a1_L4_k{k}.h5", "pore")
        ox, oy, oz = 4 * (k % 2), 4 * (k // 2 % 2), 4 * (k // 4)
        np.testing.assert_array_equal(cube, pore[ox : ox + 4, oy : oy + 4, oz : oz + 4])
        assert attrs["origin_um"] == [10.0 + ox, oy, oz]
        expected.append(pore[ox : ox + 4, oy : oy + 4, oz : oz + 4].mean())
        ds = xr.Dataset({"phi": ((), float(cube.mean()))})
        paths.append(_result(tmp_path / "m" / f"m_a1_L4_k{k}.h5", ds, "m"))
    ds = gather(paths)
    sel = {"quantity": "m.phi", "a_um": 1.0, "sample_um": 4.0}
    assert float(ds.value.sel(sel)) == pytest.approx(np.mean(expected), rel=1e-12)
    assert float(ds.rev_spread.sel(sel)) == pytest.approx(np.std(expected, ddof=1), rel=1e-12)
    assert int(ds.rev_count.sel(sel)) == 8
    assert parse_name("m_a1_L4_k7") == ("m", 1.0, 4.0, "")
