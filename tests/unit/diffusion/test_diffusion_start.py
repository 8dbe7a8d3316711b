"""Start points of the equilibrium (closed / msd) set-up: uniform over the pore space by rejection over the codes.

Truth: uniformity over the pore voxels (chi-squared goodness of fit against equal counts; the test fails below a
p-value of 1e-4, so a correct sampler fails it with probability 1e-4 for a fixed seed it never does) and uniformity
inside a voxel (mean fractional position 1/2 within 5 standard errors); no start point in solid.
"""

import numpy as np
from scipy import stats

from porepipe.diffusion import _kernels as K
from porepipe.diffusion._api import prepare


def test_rejection_start_is_uniform_over_pore_voxels_and_never_in_solid():
    rng = np.random.default_rng(2)
    pore = (rng.random((7, 6, 5)) < 0.4).astype(np.uint8)
    geom = prepare(pore, (1.0, 2.0, 0.5), (True, True, True), None)
    h = geom.h
    n = 60_000
    pos, idx = np.empty(3), np.empty(3, np.int64)
    state = K._stream_state(5, 0)
    counts = np.zeros(geom.codes.shape, dtype=np.int64)
    frac = np.zeros(3)
    for _ in range(n):
        # the kernel's state is a uint64; Python hands it back as an int, so keep it unsigned between calls
        state = np.uint64(K._uniform_in_codes(geom.codes, h, pos, idx, state))
        assert geom.codes[tuple(idx)] > 0
        counts[tuple(idx)] += 1
        frac += pos / h - idx
    pore_counts = counts[geom.codes > 0]
    assert counts[geom.codes == 0].sum() == 0
    assert stats.chisquare(pore_counts).pvalue > 1e-4
    np.testing.assert_allclose(frac / n, 0.5, atol=5 * np.sqrt(1 / 12 / n))
