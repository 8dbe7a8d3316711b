"""Volumes larger than the memory budget (issue 23): the chunked paths give what the in-memory paths give.

Truth is the in-memory computation of the same volume (itself tested against naive counts and analytic values in
tests/unit/minkowski and tests/unit/lpt). Integer counts must be bit-identical; the LPT sum of k² is a float summed
in another order, so its derived moments agree to 1e-12 relative (round-off of ~1e8 terms is far below that).
"""

import numpy as np
import pytest

import porepipe.lpt._chunked as lpt_chunked
import porepipe.minkowski._chunked as mink_chunked
from porepipe._shared.chunked import Box, plan_boxes, read_box
from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_table, read_volume
from porepipe.lpt import Settings as LptSettings
from porepipe.lpt import local_porosity_analysis
from porepipe.lpt._run import run as lpt_run
from porepipe.minkowski import configuration_histogram, threshold_histograms
from porepipe.minkowski._run import run as minkowski_run
from porepipe.minkowski._settings import Settings as MinkowskiSettings
from porepipe.scene import SceneError, parse_scene
from porepipe.segment._run import run as segment_run
from porepipe.segment._settings import SegmentationMethod
from porepipe.voxelize._run import run as voxelize_run

PERIODIC = [(True, True, True), (False, True, False), (False, False, False)]


def _store(tmp_path, name, volume, periodic, file="v.h5"):
    path = tmp_path / file
    with ResultWriter(path, stage="test") as w:
        w.write_volume(name, volume, voxel_um=1.0, periodic=periodic)
    return path


def _force_edge(monkeypatch, module, edge):
    """Boxes of core edge ``edge`` (rounded up to the stride alignment) whatever the budget."""
    monkeypatch.setattr(module, "choose_edge", lambda *a, align=1, **k: -(-edge // align) * align)


def test_read_box_wraps_like_modular_indexing():
    rng = np.random.default_rng(0)
    vol = rng.integers(0, 255, (7, 5, 6), dtype=np.uint8)
    for _ in range(50):
        start = tuple(int(rng.integers(0, n)) for n in vol.shape)
        read = tuple(int(rng.integers(1, 2 * n)) for n in vol.shape)
        got = read_box(vol, Box(start, read, read))
        idx = [(s + np.arange(r)) % n for s, r, n in zip(start, read, vol.shape)]
        np.testing.assert_array_equal(got, vol[np.ix_(*idx)])


def test_boxes_tile_the_volume_once():
    for wrap in PERIODIC:
        boxes = plan_boxes((10, 7, 9), 4, 2, wrap)
        hits = np.zeros((10, 7, 9), int)
        for b in boxes:
            hits[tuple(slice(s, s + c) for s, c in zip(b.start, b.core))] += 1
            for s, c, r, n, w in zip(b.start, b.core, b.read, (10, 7, 9), wrap):
                assert r == (c + 2 if w else min(c + 2, n - s))
        assert (hits == 1).all()


@pytest.mark.parametrize("periodic", PERIODIC)
@pytest.mark.parametrize("edge", [5, 8, 64])
def test_minkowski_histograms_chunked_are_identical(tmp_path, monkeypatch, periodic, edge):
    rng = np.random.default_rng(edge)
    shape = (23, 17, 19)
    pore = (rng.random(shape) < 0.4).astype(np.uint8)
    grey = rng.integers(0, 217, shape).astype(np.uint8)
    path = _store(tmp_path, "pore", pore, periodic)
    gpath = _store(tmp_path, "grey", grey, periodic, "g.h5")
    _force_edge(monkeypatch, mink_chunked, edge)
    got = mink_chunked.configuration_histogram_chunked(path, "pore", shape, periodic, 1)
    np.testing.assert_array_equal(got, configuration_histogram(pore, periodic))
    got = mink_chunked.threshold_histograms_chunked(gpath, "grey", shape, periodic, 1, n_levels=217)
    np.testing.assert_array_equal(got, threshold_histograms(grey, periodic, 217))


def _assert_same_dataset(ref, got):
    assert set(ref.data_vars) == set(got.data_vars)
    for key in ref.data_vars:
        a, b = ref[key].values, got[key].values
        if a.dtype.kind == "f":
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-15, err_msg=key)
        else:
            np.testing.assert_array_equal(b, a, err_msg=key)


@pytest.mark.parametrize("periodic", PERIODIC[:2])
@pytest.mark.parametrize("edge", [4, 7, 64])
def test_lpt_chunked_is_identical(tmp_path, monkeypatch, periodic, edge):
    rng = np.random.default_rng(edge)
    shape = (22, 19, 17)
    pore = (rng.random(shape) < 0.45).astype(np.uint8)
    path = _store(tmp_path, "pore", pore, periodic)
    _force_edge(monkeypatch, lpt_chunked, edge)
    for settings in (
        LptSettings(cell_voxels=[1, 3, 6], plots=False),
        LptSettings(cell_voxels=[2, 7], mu_stride=2, lambda_stride=3, max_bins=20, plots=False),
    ):
        ref = local_porosity_analysis(pore, voxel_um=1.0, periodic=periodic, settings=settings)
        got = lpt_chunked.local_porosity_analysis_chunked(
            path, shape, voxel_um=1.0, periodic=periodic, settings=settings, budget_mb=1
        )
        _assert_same_dataset(ref, got)
        assert {k: str(v) for k, v in ref.attrs.items()} == {k: str(v) for k, v in got.attrs.items()}


def test_stages_choose_the_chunked_path_over_the_budget(tmp_path, monkeypatch):
    """A 1.3 MB volume with a 1 MB budget: minkowski and lpt go box by box (spied) and write the same tables."""
    rng = np.random.default_rng(5)
    pore = (rng.random((120, 110, 100)) < 0.4).astype(np.uint8)
    path = _store(tmp_path, "pore", pore, (True, True, True))
    calls = []
    real = mink_chunked.configuration_histogram_chunked
    monkeypatch.setattr(
        "porepipe.minkowski._run.configuration_histogram_chunked",
        lambda *a, **k: calls.append(a) or real(*a, **k),
    )
    ref = minkowski_run(path, tmp_path / "m1.h5", MinkowskiSettings())
    got = minkowski_run(path, tmp_path / "m2.h5", MinkowskiSettings(), memory_budget_mb=1)
    assert len(calls) == 1
    _assert_same_dataset(ref, got)
    settings = LptSettings(cell_voxels=[1, 8], plots=False, lambda_max_cells=500)
    ref = lpt_run(path, tmp_path / "l1.h5", settings)
    got = lpt_run(path, tmp_path / "l2.h5", settings, memory_budget_mb=1)
    assert "read in boxes" in got.attrs["sample"] and "read in boxes" not in ref.attrs["sample"]
    _assert_same_dataset(read_table(tmp_path / "l1.h5"), read_table(tmp_path / "l2.h5"))


def test_budget_too_small_for_one_box_names_budget_and_box(tmp_path):
    pore = np.zeros((120, 110, 100), np.uint8)
    path = _store(tmp_path, "pore", pore, (True, True, True))
    out = tmp_path / "lpt.h5"
    with pytest.raises(
        PorepipeError,
        match=r"resources\.memory_budget_mb = 1 MB is too small for one chunk: an lpt box for L = 100 of 100x100x100 voxels \(core edge 1 \+ halo 99\) needs \d+ MB; give at least",
    ):
        settings = LptSettings(cell_voxels=[100], lambda_stride=1, plots=False)
        lpt_run(path, out, settings, memory_budget_mb=1)
    assert not out.exists() and not list(tmp_path.glob(".*lpt*"))


def _scene(tmp_path, budget=None, size=24.0):
    raw = {
        "name": "chunks",
        "domain": {"size_um": [size] * 3},
        "spheres": {"inline": [[5, 6, 7, 4.5], [15, 14, 16, 6.0], [22, 3, 20, 3.5]]},
        "resolutions_um": [0.25],
    }
    if budget is not None:
        raw["resources"] = {"memory_budget_mb": budget}
    return parse_scene(raw, tmp_path)


def test_voxelize_and_segment_within_a_budget_write_the_same_volumes(tmp_path):
    """96^3 voxels: a 1 MB budget holds 3 planes of voxelize (with one thread's work arrays) and 64 of segment."""
    voxelize_run(_scene(tmp_path), 0.25, tmp_path / "g1.h5", threads=1, progress=False)
    voxelize_run(_scene(tmp_path, 1), 0.25, tmp_path / "g2.h5", threads=1, progress=False)
    g1, g2 = read_volume(tmp_path / "g1.h5", "grey")[0], read_volume(tmp_path / "g2.h5", "grey")[0]
    np.testing.assert_array_equal(g1, g2)
    np.testing.assert_array_equal(
        read_table(tmp_path / "g1.h5").grey_histogram, read_table(tmp_path / "g2.h5").grey_histogram
    )
    segment_run(tmp_path / "g1.h5", tmp_path / "b1.h5", SegmentationMethod.otsu)
    segment_run(tmp_path / "g1.h5", tmp_path / "b2.h5", SegmentationMethod.otsu, memory_budget_mb=1)
    np.testing.assert_array_equal(
        read_volume(tmp_path / "b1.h5", "pore")[0], read_volume(tmp_path / "b2.h5", "pore")[0]
    )


def test_voxelize_and_segment_refuse_a_budget_below_one_plane(tmp_path):
    scene = _scene(tmp_path, 1, size=96.0)  # 384^2 planes: 37 bytes/voxel of work arrays = 5.5 MB per thread
    with pytest.raises(
        PorepipeError,
        match=r"resources\.memory_budget_mb = 1 MB is too small for one chunk: one x plane of 384x384",
    ):
        voxelize_run(scene, 0.25, tmp_path / "g.h5", threads=1, progress=False)
    assert not (tmp_path / "g.h5").exists()
    voxelize_run(_scene(tmp_path, size=96.0), 0.5, tmp_path / "g.h5", threads=1, progress=False)
    with pytest.raises(PorepipeError, match=r"memory_budget_mb = 0.*allowed: a whole number of MB >= 1"):
        segment_run(tmp_path / "g.h5", tmp_path / "b.h5", SegmentationMethod.otsu, memory_budget_mb=0)
    assert not (tmp_path / "b.h5").exists()


def test_voxelize_at_a_resolution_whose_plane_exceeds_the_machine_is_one_line(tmp_path):
    """``porepipe voxelize --a 1e-4`` on the mini's 100 µm box (a resolution the scene does not list, so its check did
    not see it) raised numpy's 29 TiB allocation error of a 32-plane slab; without a budget the machine's memory now
    bounds the slab, and a single plane beyond it is refused before the result file is opened."""
    with pytest.raises(PorepipeError, match=r"one x plane of 384000x384000 .* more than this machine's"):
        voxelize_run(_scene(tmp_path, size=96.0), 0.00025, tmp_path / "g.h5", threads=1, progress=False)
    assert not (tmp_path / "g.h5").exists()


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (0, r"resources\.memory_budget_mb.*greater than or equal to 1"),
        ("lots", r"resources\.memory_budget_mb.*integer"),
        (2.5, r"resources\.memory_budget_mb.*integer"),
    ],
)
def test_scene_budget_key_is_validated(tmp_path, value, message):
    with pytest.raises(SceneError, match=message):
        _scene(tmp_path, value)


def test_scene_unknown_resources_key_is_named(tmp_path):
    raw = {
        "name": "chunks",
        "domain": {"size_um": [8, 8, 8]},
        "spheres": {"inline": [[4, 4, 4, 2]]},
        "resolutions_um": [1],
        "resources": {"memory_mb": 100},
    }
    with pytest.raises(SceneError, match=r"resources\.memory_mb.*memory_budget_mb"):
        parse_scene(raw, tmp_path)


def test_a_volume_beyond_this_machine_needs_a_budget(tmp_path):
    """64·10^12 voxels: refused without a budget (the message points to the key), accepted with one."""
    raw = {
        "name": "huge",
        "domain": {"size_um": [10000.0] * 3},
        "spheres": {"inline": [[4, 4, 4, 2]]},
        "resolutions_um": [0.25],
    }
    with pytest.raises(SceneError, match=r"more than this machine's .* set resources\.memory_budget_mb"):
        parse_scene(raw, tmp_path)
    assert (
        parse_scene({**raw, "resources": {"memory_budget_mb": 4000}}, tmp_path).resources.memory_budget_mb
        == 4000
    )


def test_command_line_budget_reaches_the_chunked_paths(tmp_path, capsys):
    """--memory-budget-mb of minkowski and lpt (the workflow passes the scene's via --scene) gives the same tables."""
    from porepipe.cli import main

    rng = np.random.default_rng(9)
    path = _store(tmp_path, "pore", (rng.random((120, 110, 100)) < 0.4).astype(np.uint8), (True,) * 3)
    for budget in ([], ["--memory-budget-mb", "1"]):
        tag = "chunked" if budget else "whole"
        assert main(["minkowski", str(path), "-o", str(tmp_path / f"m_{tag}.h5"), *budget]) == 0
        lpt = ["lpt", str(path), "-o", str(tmp_path / f"l_{tag}.h5"), "--cell-voxels", "4", "--no-plots"]
        assert main([*lpt, "--lambda-max-cells", "300", *budget]) == 0
    _assert_same_dataset(read_table(tmp_path / "m_whole.h5"), read_table(tmp_path / "m_chunked.h5"))
    _assert_same_dataset(read_table(tmp_path / "l_whole.h5"), read_table(tmp_path / "l_chunked.h5"))
    assert "read in boxes" in read_table(tmp_path / "l_chunked.h5").attrs["sample"]
    # refused by argparse and named by the option (tests/hard/test_option_names)
    with pytest.raises(SystemExit) as stop:
        main(["minkowski", str(path), "-o", str(tmp_path / "m0.h5"), "--memory-budget-mb", "0"])
    assert stop.value.code == 2
    assert "argument --memory-budget-mb: 0: give 1 or more" in capsys.readouterr().err
    assert not (tmp_path / "m0.h5").exists()
