"""The CI poured heap (config/scenes/granular-heap-ci.yaml): reproducible for a fixed seed and thread count, in
static balance, and read out by analyse_heap and the report's heap section."""

from pathlib import Path

import numpy as np
import pytest

from porepipe.granular import analyse_heap, read_granular, run
from porepipe.scene import load_scene

SCENE = Path(__file__).parents[3] / "config" / "scenes" / "granular-heap-ci.yaml"


@pytest.fixture(scope="module")
def heaps(tmp_path_factory):
    scene = load_scene(SCENE)
    d = tmp_path_factory.mktemp("heap")
    return [run(scene.granular, d / f"run{k}.h5", seed=scene.seed, progress=False) for k in range(2)]


def test_ci_heap_is_reproducible(heaps):
    a, b = (read_granular(p) for p in heaps)
    np.testing.assert_array_equal(a["frames"]["position_m"].values, b["frames"]["position_m"].values)
    np.testing.assert_array_equal(a["contacts"]["fx_N"].values, b["contacts"]["fx_N"].values)


def test_ci_heap_balance_and_shape(heaps, tmp_path):
    from porepipe.report._granular import granular_report

    h = analyse_heap(read_granular(heaps[0]))
    # static balance: the floor carries the heap (residual kinetic energy ~1e-5 of m g h; 2 % covers it)
    assert h["floor_load_N_m"] == pytest.approx(h["weight_N_m"], rel=0.02)
    # a heap, not a layer: flanks steeper than 10° and below the grains' friction angle atan(0.6) = 31° + 5°
    for side in ("repose_left_rad", "repose_right_rad", "repose_integral_rad"):
        assert np.radians(10) < h[side] < np.radians(36)
    page = granular_report(heaps[0], tmp_path / "index.html", kind="heap").read_text()
    assert "granular_floor_pressure.png" in page and (tmp_path / "granular_floor_pressure.png").is_file()
