"""Crop, resampling and segmentation against independent truths (skimage on the full image, exact fractions)."""

import numpy as np
import pytest
from skimage.filters import threshold_multiotsu, threshold_otsu

from porepipe._shared.errors import PorepipeError
from porepipe.acquire._io import Image
from porepipe.acquire._prepare import crop_box, denoise, load_region, resample_cubic, segment_phases
from porepipe.acquire._settings import Crop, Denoise, Segmentation


def test_centre_crop_and_bounds():
    assert crop_box((10, 8, 6), Crop(size=(4, 4, 2), centre=True)) == (slice(3, 7), slice(2, 6), slice(2, 4))
    with pytest.raises(PorepipeError, match="exceeds the image shape"):
        crop_box((10, 8, 6), Crop(size=(11, 4, 2)))
    with pytest.raises(PorepipeError, match="outside the image"):
        crop_box((10, 8, 6), Crop(start=(8, 0, 0), size=(4, 4, 2)))


def test_load_region_reads_big_endian_as_native():
    data = np.arange(24, dtype=">u2").reshape(2, 3, 4)
    region = load_region(Image(data, (1.0, 1.0, 1.0), "mem"), Crop(start=(1, 0, 0), size=(1, 3, 4)))
    assert region.dtype.byteorder in "=|"
    np.testing.assert_array_equal(region, np.arange(12, 24).reshape(1, 3, 4))


def test_resample_linear_ramp_is_exact_in_the_interior():
    # linear interpolation reproduces a linear function exactly away from the clamped ends
    z_um = (np.arange(6) + 0.5) * 3.0
    grey = np.broadcast_to(z_um * 10, (4, 4, 6)).astype(np.float32)
    out, edge = resample_cubic(grey, (1.0, 1.0, 3.0))
    assert edge == 1.0 and out.shape == (4, 4, 18)
    centres_um = np.arange(18) + 0.5
    inner = (centres_um > z_um[0]) & (centres_um < z_um[-1])
    np.testing.assert_allclose(out[0, 0, inner], 10 * centres_um[inner], rtol=1e-5)


def test_median_removes_salt_noise():
    grey = np.full((9, 9, 9), 50, np.uint8)
    grey[4, 4, 4] = 255
    assert denoise(grey, Denoise.median, 3).max() == 50


def test_otsu_matches_scikit_image_on_the_image():
    rng = np.random.default_rng(3)
    grey = np.where(rng.random((20, 20, 20)) < 0.3, 70, 170) + rng.normal(0, 12, (20, 20, 20))
    grey = np.clip(grey, 0, 255).astype(np.uint8)
    ph = segment_phases(grey, Segmentation())
    assert ph.thresholds[0] == threshold_otsu(grey)  # skimage on the voxels, not our histogram
    np.testing.assert_array_equal(ph.pore(), (grey <= threshold_otsu(grey)).astype(np.uint8))


def test_multi_otsu_three_phases_matches_scikit_image():
    rng = np.random.default_rng(4)
    levels = rng.choice([40, 120, 200], size=(16, 16, 16), p=[0.25, 0.15, 0.6])
    grey = np.clip(levels + rng.normal(0, 8, levels.shape), 0, 255).astype(np.uint8)
    seg = Segmentation(method="multi_otsu", phases=["pore", "cement", "grain"])
    ph = segment_phases(grey, seg)
    np.testing.assert_allclose(ph.thresholds, threshold_multiotsu(grey, classes=3))
    expected = np.digitize(levels, [80, 160])
    np.testing.assert_array_equal(
        ph.labels, expected
    )  # noise 8 << level gap 80: every voxel classified right


def test_user_thresholds_put_a_grey_value_on_a_threshold_in_the_lower_phase():
    # the g <= g_th convention of §4.7.2, per threshold: t goes to the phase below it, t + 1 to the one above
    thresholds = [60, 115, 180]
    grey = np.array([0, 60, 61, 115, 116, 180, 181, 255], np.uint8).reshape(8, 1, 1)
    seg = Segmentation(
        method="thresholds",
        phases=["pore", "sedimentation", "cementation", "grains"],
        thresholds=thresholds,
    )
    np.testing.assert_array_equal(segment_phases(grey, seg).labels.ravel(), [0, 0, 1, 1, 2, 2, 3, 3])


def test_inverted_phases_pore_bright():
    grey = np.array([10, 10, 200, 200, 200], np.uint8).reshape(5, 1, 1)
    seg = Segmentation(method="thresholds", thresholds=[100], phases=["pore", "matrix"], invert=True)
    np.testing.assert_array_equal(segment_phases(grey, seg).pore().ravel(), [0, 0, 1, 1, 1])


def test_float_image_histogram_thresholds_in_grey_units():
    rng = np.random.default_rng(6)
    grey = np.where(rng.random((12, 12, 12)) < 0.4, -1.0, 2.0) + rng.normal(0, 0.1, (12, 12, 12))
    ph = segment_phases(grey, Segmentation(bins=512))
    # Otsu's between-class variance is flat across the empty gap; any threshold in it is a maximiser
    assert grey[grey < 0.5].max() <= ph.thresholds[0] < grey[grey > 0.5].min()
    np.testing.assert_array_equal(ph.pore(), (grey < 0.5).astype(np.uint8))


def test_non_local_means_reduces_noise_of_a_flat_section():
    rng = np.random.default_rng(8)
    grey = np.clip(100 + rng.normal(0, 10, (32, 32, 1)), 0, 255).astype(np.uint8)
    out = denoise(grey, Denoise.nl_means)
    assert out.dtype == np.uint8 and out.shape == grey.shape
    assert (
        out.std() < 0.5 * grey.std()
    )  # NLM on pure noise averages many similar patches: std drops well below half
