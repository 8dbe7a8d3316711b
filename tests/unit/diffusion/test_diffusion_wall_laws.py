"""Each wall law's angular and speed distribution by Kolmogorov-Smirnov tests (digest §13.4), 20 000 reflections.

p-value threshold 1e-3 at a fixed seed: a correct law passes; each test also shows that the neighbouring law's
samples are rejected (p < 1e-6), so the test can fail.
"""

import math

import numpy as np
import pytest
from numba import njit
from scipy import stats

from porepipe.diffusion import _kernels as K

N = 20000


@njit(cache=True)
def _sample(law, mixed, wall_speed, event, alpha, n, seed):
    out = np.empty((n, 4))
    state = K._stream_state(seed, 0)
    u = np.empty(3)
    for k in range(n):
        u[0], u[1], u[2] = 0.3, -0.4, math.sqrt(1 - 0.25)  # incoming, flying +z into the wall
        if event & 1 == 0:
            u[event >> 1] = -abs(u[event >> 1])
        speed, state = K._reflect(law, mixed, wall_speed, event, u, 1.0, 1.0, alpha, state)
        out[k, :3] = u
        out[k, 3] = speed
    return out


CDF = {  # P(cos θ <= c) about the wall normal
    K.LAMBERT: lambda c: c**2,  # sin² θ uniform
    K.ISOTROPIC: lambda c: c,  # cos θ uniform
    K.COSINE_DTHETA: lambda c: 1 - np.sqrt(1 - c**2),  # sin θ uniform
}


@pytest.mark.parametrize(
    "law,other", [(K.LAMBERT, K.ISOTROPIC), (K.ISOTROPIC, K.LAMBERT), (K.COSINE_DTHETA, K.LAMBERT)]
)
@pytest.mark.parametrize("event", [5, 0, 3])
def test_diffuse_law_polar_and_azimuth(law, other, event):
    s = _sample(law, False, K.SPEED_KEPT, event, 1.0, N, 11 + event)
    axis, sign = event >> 1, (-1.0 if event & 1 else 1.0)
    cos = sign * s[:, axis]
    assert cos.min() > 0  # always back into the pore, never parallel to the wall
    np.testing.assert_allclose(np.linalg.norm(s[:, :3], axis=1), 1.0, atol=1e-12)
    assert stats.kstest(cos, CDF[law]).pvalue > 1e-3
    assert stats.kstest(cos, CDF[other]).pvalue < 1e-6
    a, b = (axis + 1) % 3, (axis + 2) % 3
    phi = (np.arctan2(s[:, b], s[:, a]) + np.pi) / (2 * np.pi)
    assert stats.kstest(phi, "uniform").pvalue > 1e-3
    assert np.all(s[:, 3] == 1.0)  # speed kept


def test_lambert_projects_uniformly_on_the_disk():
    s = _sample(K.LAMBERT, False, K.SPEED_KEPT, 5, 1.0, N, 3)
    r2 = s[:, 0] ** 2 + s[:, 1] ** 2  # projected radius² uniform on [0, 1] for a uniform disk
    assert stats.kstest(r2, "uniform").pvalue > 1e-3


def test_specular_is_exact_mirror():
    s = _sample(K.SPECULAR, False, K.SPEED_KEPT, 5, 1.0, 10, 1)
    np.testing.assert_array_equal(s[:, :3], np.tile([0.3, -0.4, -math.sqrt(0.75)], (10, 1)))


def test_maxwell_mixture_specular_fraction():
    alpha = 0.3
    s = _sample(K.LAMBERT, True, K.SPEED_KEPT, 5, alpha, N, 5)
    mirror = np.all(np.abs(s[:, :3] - [0.3, -0.4, -math.sqrt(0.75)]) < 1e-15, axis=1)
    k = int(mirror.sum())
    assert stats.binomtest(k, N, 1 - alpha).pvalue > 1e-3
    assert stats.kstest(-s[~mirror, 2], CDF[K.LAMBERT]).pvalue > 1e-3


def test_thermal_reemission_speed_is_flux_weighted_maxwell():
    s = _sample(K.LAMBERT, False, K.SPEED_FLUX, 5, 1.0, N, 8)
    sigma = math.sqrt(math.pi / 8.0)  # v̄ = 1
    x = s[:, 3] ** 2 / (2 * sigma**2)  # ~ Gamma(2): f ~ v³ exp(-v²/2σ²)
    assert stats.kstest(x, stats.gamma(2).cdf).pvalue > 1e-3
    assert stats.kstest(s[:, 3], stats.maxwell(scale=sigma).cdf).pvalue < 1e-6  # not plain MB
    assert s[:, 3].mean() == pytest.approx(3 * math.pi / 8, rel=0.01)  # E[v] of the flux law = 3π/8 · v̄


@njit(cache=True)
def _speeds(dist, n, seed):
    out = np.empty(n)
    state = K._stream_state(seed, 0)
    for k in range(n):
        out[k], state = K._speed(dist, 1.0, state)
    return out


def test_maxwell_speed_distribution_has_mean_one():
    v = _speeds(K.SPEED_MAXWELL, N, 2)
    sigma = math.sqrt(math.pi / 8.0)
    assert stats.kstest(v, stats.maxwell(scale=sigma).cdf).pvalue > 1e-3
    assert v.mean() == pytest.approx(1.0, abs=4 * v.std() / math.sqrt(N))
