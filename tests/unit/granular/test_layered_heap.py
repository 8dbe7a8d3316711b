"""The CI layered heap (config/scenes/granular-heap-layered-ci.yaml): a shrinking line source builds a wedge whose
flank angle follows from geometry alone, and its floor pressure shows no dip beyond its fluctuations.

Truths used: a spot |x| < w/2 of the floor receives grains until the source (width w (1 - t/T)) has shrunk past it,
so the local height falls linearly from the centre: a wedge of area A (solid area / packing fraction) and base w
has height 2A/w and flank angle atan(4A/w²). Schinner 2001 §4.2.1: layered heaps have no floor-pressure dip (the
central lowering is smaller than the fluctuations).
"""

import math
from pathlib import Path

import numpy as np
import pytest

from porepipe.granular import analyse_heap, frame_particles, read_granular, run
from porepipe.scene import load_scene

SCENE = Path(__file__).parents[3] / "config" / "scenes" / "granular-heap-layered-ci.yaml"


#: seeds of the flank-angle check: one run's flank fit scatters by 0.17 (relative sd of measured / expected over 8
#: runs: seeds 1-6, and seed 1 before two round-off-level changes of the contact kernel: 0.70-1.25), so the check is
#: on the mean of four runs (standard error ~0.085)
SEEDS = (1, 2, 3, 4)


@pytest.fixture(scope="module")
def heaps(tmp_path_factory):
    scene = load_scene(SCENE)
    runs = []
    for seed in SEEDS:
        path = tmp_path_factory.mktemp(f"layered{seed}") / "granular.h5"
        tables = read_granular(run(scene.granular, path, seed=seed, progress=False))
        runs.append((analyse_heap(tables), tables))
    return runs, scene.granular.drop_sources[0].width_m


def test_layered_heap_flank_angle_follows_the_shrinking_source(heaps):
    runs, w = heaps
    ratios = []
    for h, tables in runs:
        parts = frame_particles(tables, -1)
        area = parts["area"][parts["active"]].sum() / h["rho_rel"]
        measured = 0.5 * (h["repose_left_rad"] + h["repose_right_rad"])
        ratios.append(measured / math.atan(4 * area / w**2))
        # the wedge's height 2A/w; 15 %: the highest vertex stands up to one grain radius (2 mm of ~24 mm) above it
        assert h["height_m"] == pytest.approx(2 * area / w, rel=0.15)
        # below the poured heaps' repose angle (27° ± 5° over 3 seeds of granular-heap-poured): no avalanches
        assert math.degrees(measured) < 22
    # 20 % on the mean of 4 runs (2.4 standard errors, see SEEDS; measured 0.97 for seeds 1-4): the flank fits use
    # the highest centroids of ~6 layers of grains 4 mm wide (the top is rounded and the foot spreads, a grain of
    # roughness on an 8 cm flank is ~3°), rho_rel is measured in the core only. A source that does not shrink (a
    # layer, ~0°) or a point source (~27°) fails.
    assert np.mean(ratios) == pytest.approx(1.0, rel=0.2)


def test_layered_heap_has_no_dip_beyond_its_fluctuations(heaps):
    h = heaps[0][0][0]  # the scene's own seed
    assert h["floor_load_N_m"] == pytest.approx(
        h["weight_N_m"], rel=0.02
    )  # static: the floor carries the heap
    assert h["dip"]["dip"] <= h["dip"]["fluctuation"]
    assert np.isfinite(h["dip"]["fluctuation"]) and h["dip"]["fluctuation"] > 0
