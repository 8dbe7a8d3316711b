import numpy as np
import pytest
from skimage.filters import threshold_otsu

from porepipe._shared.errors import PorepipeError
from porepipe.scene import SegmentationMethod
from porepipe.segment import choose_threshold, otsu_threshold, segment


@pytest.mark.parametrize("seed", range(5))
def test_otsu_matches_scikit_image_on_histograms(seed):
    rng = np.random.default_rng(seed)
    hist = rng.integers(0, 1000, 217) * (rng.random(217) < 0.6)
    assert otsu_threshold(hist) == threshold_otsu(hist=(hist, np.arange(217)))


def test_otsu_splits_a_bimodal_volume_between_the_modes():
    rng = np.random.default_rng(1)
    grey = np.concatenate([rng.integers(0, 30, 5000), rng.integers(180, 217, 5000)]).astype(np.uint8)
    t = choose_threshold(np.bincount(grey, minlength=217), SegmentationMethod.otsu).value
    assert 29 <= t < 180
    assert segment(grey, t).sum() == 5000  # pore = the dark half


@pytest.mark.parametrize("value,phase", [(0, "pore"), (216, "matrix"), (100, "pore"), (150, "matrix")])
def test_single_grey_value_says_which_phase(value, phase):
    hist = np.zeros(217, dtype=np.int64)
    hist[value] = 1000
    decision = choose_threshold(hist, SegmentationMethod.otsu)
    assert f"whole volume is {phase}" in decision.note
    assert bool(segment(np.array([value], np.uint8), decision.value)[0]) == (phase == "pore")


def test_fixed_threshold_range_is_checked():
    hist = np.ones(217, dtype=np.int64)
    assert choose_threshold(hist, SegmentationMethod.fixed, 0).value == 0
    with pytest.raises(PorepipeError, match="0..215"):
        choose_threshold(hist, SegmentationMethod.fixed, 216)
    with pytest.raises(PorepipeError, match="217 bins"):
        choose_threshold(np.ones(10), SegmentationMethod.otsu)


def test_trivial_threshold_is_the_thesis_fig_7_3_rule():
    # Zauner (2020) Fig. 7.3: "pore are all voxels with g_i(a) < 128" -- independent of the histogram
    hist = np.zeros(217, dtype=np.int64)
    hist[[0, 216]] = 1
    th = choose_threshold(hist, SegmentationMethod.trivial)
    grey = np.array([126, 127, 128, 129], dtype=np.uint8)
    assert segment(grey, th.value).tolist() == [1, 1, 0, 0]


def test_trivial_and_otsu_refuse_a_threshold_value():
    from porepipe.scene import Segmentation

    with pytest.raises(ValueError, match="only used with method fixed"):
        Segmentation(method="trivial", threshold=100)
