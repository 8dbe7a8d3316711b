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


@pytest.mark.parametrize("method", ["otsu", "trivial"])
def test_cli_refuses_a_threshold_the_method_does_not_use(tmp_path, capsys, method):
    # before: `porepipe segment g.h5 --method otsu --threshold 100` wrote Otsu's binary and dropped the threshold
    # without a word; a scene's segmentation refuses the pair, and the command line now does too
    from porepipe._shared.grey import write_grey_volume
    from porepipe._shared.store import ResultWriter
    from porepipe.cli import main

    grey = np.random.default_rng(0).choice(np.array([10, 200], np.uint8), (8, 8, 8))
    with ResultWriter(tmp_path / "grey_a1.h5", stage="voxelize") as w:
        write_grey_volume(w, [(0, grey)], grey.shape, 1.0, True, {})
    out = tmp_path / "binary_a1.h5"
    argv = ["segment", str(tmp_path / "grey_a1.h5"), "-o", str(out), "--method", method, "--threshold", "100"]
    assert main(argv) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("porepipe segment: error: segment options: ")
    assert line.endswith("`threshold` is only used with method fixed; remove it or set method: fixed")
    assert not out.exists()
    assert main(argv[:4] + ["--method", "fixed", "--threshold", "100"]) == 0 and out.exists()
