"""Orientation sampling: Haar-uniform rotations, von Mises–Fisher axes, alignment."""

import numpy as np
import pytest
from scipy import stats

from porepipe.decorate import anisotropic_rotations, uniform_rotations, von_mises_fisher
from porepipe.decorate._rotation import align_z

N = 20_000
#: KS tests at p > 1e-4: a false alarm once in 10 000 runs (fixed seeds make it deterministic anyway)
P_MIN = 1e-4


def test_rotations_are_proper_orthogonal():
    r = uniform_rotations(np.random.default_rng(0), 500)
    assert np.allclose(r @ r.transpose(0, 2, 1), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(r), 1.0, atol=1e-12)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_rotated_axes_uniform_on_sphere(axis):
    """For Haar rotations, R e_k is uniform on S²: each coordinate uniform on [-1, 1] (Archimedes), azimuth uniform."""
    r = uniform_rotations(np.random.default_rng(axis + 1), N)
    v = r[:, :, axis]
    for c in range(3):
        assert stats.kstest(v[:, c], stats.uniform(-1, 2).cdf).pvalue > P_MIN
    azimuth = np.arctan2(v[:, 1], v[:, 0])
    assert stats.kstest(azimuth, stats.uniform(-np.pi, 2 * np.pi).cdf).pvalue > P_MIN
    # E[R] = 0 under Haar measure; each entry has variance 1/3
    assert np.abs(r.mean(axis=0)).max() < 4 * np.sqrt(1 / 3 / N)


@pytest.mark.parametrize("kappa", [0.5, 4.0, 30.0])
def test_von_mises_fisher_mean_cosine(kappa):
    """E[cos θ] = coth κ − 1/κ about the preferred axis."""
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    v = von_mises_fisher(np.random.default_rng(7), N, axis, kappa)
    cos = v @ axis
    expected = 1 / np.tanh(kappa) - 1 / kappa
    assert abs(cos.mean() - expected) < 4 * cos.std() / np.sqrt(N)
    assert np.allclose(np.linalg.norm(v, axis=1), 1.0)


def test_anisotropic_with_zero_concentration_is_uniform():
    r = anisotropic_rotations(np.random.default_rng(3), N, (0, 0, 1), 0.0)
    for k in range(3):
        assert stats.kstest(r[:, 2, k], stats.uniform(-1, 2).cdf).pvalue > P_MIN


def test_anisotropic_axis_follows_preferred_axis():
    r = anisotropic_rotations(np.random.default_rng(4), 2000, (0, 1, 0), 200.0)
    assert np.mean(np.abs(r[:, :, 2] @ np.array([0, 1.0, 0]))) > 0.99


def test_align_z_including_antipode():
    d = np.array([[0, 0, 1.0], [0, 0, -1.0], [1, 0, 0], [0.6, 0, 0.8]])
    rot = align_z(d)
    assert np.allclose(rot[:, :, 2], d, atol=1e-12)
