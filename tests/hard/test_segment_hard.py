"""Degenerate grey histograms given to the segmentation: a threshold or a clear PorepipeError, never a silent 0."""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.segment import choose_threshold, otsu_threshold


@pytest.mark.parametrize(
    "hist",
    [
        [5.0],  # one bin: before an IndexError
        [1.0, np.nan, 3.0],  # before: threshold 0
        [1.0, np.inf, 3.0],  # before: RuntimeWarning, threshold 0
        [5.0, -1.0, 3.0],  # before: threshold 0
    ],
)
def test_otsu_refuses_a_histogram_that_is_not_counts(hist):
    with pytest.raises(PorepipeError, match="otsu needs a 1-D histogram of >= 2 bins with finite counts"):
        otsu_threshold(hist)


def test_choose_threshold_refuses_nan_counts():
    hist = np.zeros(217)
    hist[[10, 200]] = np.nan  # before: an Otsu threshold of 0 was returned
    with pytest.raises(PorepipeError, match="finite counts"):
        choose_threshold(hist, "otsu")
