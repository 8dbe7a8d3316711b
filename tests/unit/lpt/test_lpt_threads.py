"""Results must not depend on the thread count (per-thread histograms, chunked percolation with path reuse)."""

import numba
import numpy as np
import pytest

from porepipe._shared.numba_config import set_threads
from porepipe.lpt import Settings, local_porosity_analysis


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs at least 2 numba threads to compare")
def test_one_and_two_threads_agree():
    pore = (np.random.default_rng(9).random((20, 18, 16)) < 0.32).astype(np.uint8)
    settings = Settings(cell_voxels=[1, 3, 8], lambda_stride=2, max_bins=50)
    before = numba.get_num_threads()
    try:
        runs = []
        for threads in (1, 2):
            set_threads(threads)
            runs.append(local_porosity_analysis(pore, periodic=(True, False, True), settings=settings))
    finally:
        set_threads(before)
    # integer counts must be identical; floats derived from them too (same arithmetic on the same integers)
    for name in ("cells", "pore_voxels", "lambda_cells", "percolating", "sv_cells"):
        assert np.array_equal(runs[0][name].values, runs[1][name].values), name
    assert runs[0].phi_var.values.tobytes() == runs[1].phi_var.values.tobytes()  # Σk² is an exact integer sum
