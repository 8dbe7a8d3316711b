"""Velocity-orientation histograms of the event-driven gas (Mahler 2001 §3.7, Figs. 3.21-3.22).

Truths: the histogram's cells have equal solid angle (cos bins × azimuth bins), so independent isotropic directions
fill them evenly (χ² test) and a beam lands in one cell; a dense gas in a closed box with Lambert walls is in
equilibrium, hence isotropic: its histogram over 10 sample times, ~3 collisions per particle apart (so the samples
are nearly independent), passes the same χ² test at the 0.1 % level.
"""

import numpy as np
from scipy import stats

from porepipe.diffusion import _edmd as D


def test_histogram_cells_have_equal_solid_angle_and_a_beam_hits_one_cell():
    rng = np.random.default_rng(0)
    h = D.orientation_histogram(rng.normal(size=(20000, 3)), 2, 4)
    assert h.shape == (4, 8) and h.sum() == 20000
    assert stats.chisquare(h.ravel()).pvalue > 1e-3
    beam = np.tile(
        [0.0, 0.1, 1.0], (5, 1)
    )  # +z tilted toward +y: top cos bin, azimuth π/2 in cell [π/2, 3π/4)
    h = D.orientation_histogram(beam, 2, 4)
    assert h[3, 6] == 5 and h.sum() == 5
    assert D.orientation_histogram(np.zeros((3, 3)), 2, 4).sum() == 0  # no direction at rest


def test_dense_gas_in_a_lambert_box_is_isotropic():
    gas = D.make_gas(np.ones((2, 2, 2), np.uint8), 5.0, {"N2": 1000}, seed=1)
    physics = D.Physics(pairs=True, wall_law="lambert")
    m = D.measure(gas, 100.0, samples=10, physics=physics, orientation_bins=4, axis=2)
    assert m["collision_rate"] * 100.0 / 10 > 2.5  # collisions per particle between samples
    h = m["orientation"]
    assert h.sum() == 10 * 1000
    assert stats.chisquare(h.ravel()).pvalue > 1e-3
