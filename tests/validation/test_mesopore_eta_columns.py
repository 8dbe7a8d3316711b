"""Why the thesis's η(w) (Table 4.2, with the w = 0.2 "no reverse" row of Table 4.3) looks flatter than ours, in
numbers. The thesis gives no dimensions for its capillaries A/B/C (figure only); our scenes chose length/width ≈ 6
before any run, which puts them about 2.7× deeper in Thiele terms (Φ²/w ≈ 640 for C against the thesis's 85).

- The thesis's column C is a plain slab-Thiele curve: η = tanh Φ/Φ with Φ² = 85·w fits its six values within
  0.013 (data check, no simulation). So C is not flatter than Thiele: it is a shorter pore.
- A short rough channel (10 × 10 × 20 voxels, 30 % wall roughness) with isotropic walls and the thesis's isotropic
  inlet gives the whole column C back.
- Column A is not Thiele-shaped (apparent Φ²/w falls from ~870 at w = 0.001 to ~70 at 0.5; η ∝ w^-0.2 over three
  decades): the signature of compartments behind tight constrictions. A short tube (radius 6, length 18) with two
  throats of radius 1 gives it back; our scene's mild throats (radius 3 of 6) do not (η(0.5) = 0.08 vs 0.17).

The geometries were found by hand (a few tries, two numbers each), so the agreement shows that such pores exist and
what they look like, not that they are the thesis's. Tolerance 0.035 (the largest deviation seen, at w = 0.5 and
0.2) plus 3 σ of our η (25 000 histories per w: σ ≈ 0.03 at w = 0.001, ≤ 0.01 above).
"""

import numpy as np
import pytest

from porepipe.diffusion._edmd import reactive_pore
from porepipe.diffusion._geometry import constricted_capillary, rough_capillary
from porepipe.diffusion._reactions import eta_of_phi

W = np.array([0.001, 0.01, 0.05, 0.1, 0.2, 0.5])
#: Table 4.2 with the w = 0.2 "no reverse" row of Table 4.3
THESIS = {"A": [0.77, 0.47, 0.34, 0.30, 0.25, 0.17], "C": [0.96, 0.78, 0.47, 0.35, 0.24, 0.15]}


def test_thesis_column_c_is_one_thiele_curve():
    """Data check: Φ² = 85·w reproduces all six printed values of C within 0.013 (they are given to 0.005)."""
    eta = np.array([eta_of_phi(np.sqrt(85.0 * w)) for w in W])
    assert np.max(np.abs(eta - THESIS["C"])) < 0.013


def _column(pore):
    runs = [
        reactive_pore(pore, 2, w, wall_law="isotropic", inlet_law="isotropic", particles=25000, seed=3)
        for w in W
    ]
    return np.array([r["eta"] for r in runs]), np.array([r["eta_err"] for r in runs])


@pytest.mark.parametrize(
    "column, make",
    [("C", lambda: rough_capillary(10, 20, 0.3)), ("A", lambda: constricted_capillary(6, 18, 1, 2))],
)
def test_short_capillaries_give_the_thesis_columns_back(column, make):
    eta, err = _column(make().pore)
    assert np.all(np.abs(eta - THESIS[column]) <= 0.035 + 3 * err)


def test_our_scene_a_is_too_deep_and_its_throats_too_mild():
    """The scene's A (radius 6, length 60, throats of radius 3) at w = 0.5: η = 0.08, less than half the thesis's."""
    run = reactive_pore(
        constricted_capillary(6, 60, 3, 4).pore,
        2,
        0.5,
        wall_law="isotropic",
        inlet_law="isotropic",
        particles=25000,
    )
    assert run["eta"] < 0.6 * THESIS["A"][-1]
