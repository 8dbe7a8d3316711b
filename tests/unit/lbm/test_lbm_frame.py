"""The thesis's 2-node frame around the Fontainebleau sample (§6.2: ℓ1, ℓ2 ∈ {1, 2, L−1, L}), read as solid.

The thesis does not say what the frame holds. Read as solid, it is what ``lateral: walls`` does: with halfway
bounce-back only the first solid layer matters, so a sample padded by two solid layers on its four lateral faces
and run laterally periodic must give the same flow as the bare sample with ``lateral: walls``; κ̂ differs only by
the superficial velocity's denominator (the padded cross-section is larger: κ̂_pad · A_pad / A = κ̂_walls), and
the mean velocity over the pore voxels is the same (the frame holds no pore voxel).
"""

import numpy as np
import pytest

from porepipe.lbm import Settings, permeability


def test_two_node_solid_frame_is_lateral_walls():
    rng = np.random.default_rng(4)
    pore = rng.random((8, 10, 10)) < 0.75
    pore[:, 4:7, 4:7] = True  # an open channel along x, so the sample percolates
    framed = np.pad(pore, ((0, 0), (2, 2), (2, 2)), constant_values=False)
    base = {"collision": "trt", "tau": 0.8, "tolerance_kappa": 1e-9, "tolerance_velocity": 1e-8}
    walls = permeability(pore, "x", Settings(**base, lateral="walls"), voxel_um=1.0, progress=False)
    padded = permeability(framed, "x", Settings(**base, lateral="periodic"), voxel_um=1.0, progress=False)
    area = pore.shape[1] * pore.shape[2]
    padded_area = framed.shape[1] * framed.shape[2]
    # same lattice problem; both runs stop at their own convergence check (1e-9), hence 1e-7
    assert padded.kappa_lu * padded_area / area == pytest.approx(walls.kappa_lu, rel=1e-7)
    assert padded.mean_velocity_um_s == pytest.approx(walls.mean_velocity_um_s, rel=1e-7)
