"""The per-particle counter-based generator: range, uniformity and stream independence."""

import numpy as np
from numba import njit
from scipy import stats

from porepipe.diffusion._kernels import _stream_state, _uniform


@njit(cache=True)
def _draw(seed, particle, n):
    out = np.empty(n)
    s = _stream_state(seed, particle)
    for k in range(n):
        out[k], s = _uniform(s)
    return out


def test_uniform_range_and_ks():
    x = _draw(12345, 7, 200000)
    assert x.min() > 0.0 and x.max() <= 1.0
    assert (
        stats.kstest(x, "uniform").pvalue > 1e-3
    )  # fixed seed: a true U(0,1] passes, a biased one would not


def test_streams_of_neighbouring_particles_are_uncorrelated():
    a = np.array([_draw(9, p, 64) for p in range(2000)])
    # first draws across particles are uniform, and draw k of particle p is uncorrelated with draw k of p+1
    assert stats.kstest(a[:, 0], "uniform").pvalue > 1e-3
    r = np.corrcoef(a[:-1, :].ravel(), a[1:, :].ravel())[0, 1]
    assert abs(r) < 4 / np.sqrt(a[:-1].size)  # 4 σ of the null correlation coefficient
    assert not np.array_equal(_draw(9, 0, 8), _draw(10, 0, 8))
