"""Calibration closes the loop: a synthetic "experiment" made by our own packer (known radius distribution,
count, overlap) is imaged, measured, calibrated, re-packed and re-measured; the model agrees with the experiment.

Tolerances: the model is a *different realisation* (other sphere positions and radii drawn from the fitted law) of
a box holding only ~150 spheres, so porosity and S_V fluctuate between realisations with identical parameters; the
calibration matches both to within that scatter (sqrt(N) sd(v) / V for φ, S_V sd(r²) / (mean(r²) sqrt(N)) for S_V:
0.026 and 3.2 % here). Measured (experiment seed 4, model seed 9): experiment φ 0.533, S_V 15.55 mm^-1; fit exponential
on [40.0, 79.1] µm, alpha 0.045/µm (truth [40, 80], 0.05); matched in 2 rounds to 162 spheres at sigma_max 0.376:
φ 0.517, S_V 16.02. The experiment was packed at sigma_max 0.3 with k 400, whose pairs overlap past sigma_max
(largest 0.79); the calibrated dynamics keep overlaps within sigma_max, so the model needs a larger one for the same
S_V. Over experiment seeds 1..5 (model seed 9) the matched count is 151, 150, 145, 162, 150 (truth 150: -3 % .. +8 %),
sigma_max 0.376-0.4, and S_V within its tolerance in 4 of 5 (seed 3 stops at max_overlap_limit 0.4, +7.9 %). The
bounds (6 % for φ, 12 % for S_V, 20 % for the count) cover that realisation scatter.
"""

import numpy as np
import pytest
from scipy import stats

from porepipe.acquire._api import image_statistics
from porepipe.acquire._calibrate import calibrated_scene
from porepipe.acquire._matching import match_statistics
from porepipe.acquire._model import run_model
from porepipe.acquire._prepare import segment_phases
from porepipe.acquire._settings import Calibration, Settings
from porepipe.packing import Settings as PackingSettings
from porepipe.packing import pack_spheres
from porepipe.scene import parse_scene
from porepipe.voxelize import voxelize

BOX_UM = [600.0, 600.0, 600.0]
VOXEL_UM = 6.0
LO, HI, ALPHA = 40.0, 80.0, 0.05


def _surface_sd(s_v, count=150):
    """S_V sd(r²) / (mean(r²) sqrt(N)) under the TRUE law: S_V scatter between packings of N spheres."""
    r = np.linspace(LO, HI, 20001)
    p = np.exp(-ALPHA * r) / np.exp(-ALPHA * r).sum()
    mean = np.sum(p * r**2)
    return s_v * np.sqrt(np.sum(p * r**4) - mean**2) / (mean * np.sqrt(count))


def _experiment():
    stage = {
        "name": "one",
        "insert": ["a"],
        "steps": 600,
        "dt": 0.25,
        "k": {"a": 400},
        "damping": {"a": 4},
        "freezing": {"lock_step": 10},
        "stochastic_forces": {"step_size": 0.05},
    }
    settings = PackingSettings.model_validate(
        {
            "types": [
                {
                    "name": "a",
                    "count": 150,
                    "max_overlap": 0.3,
                    "radius_um": {"dist": "exponential", "min_um": LO, "max_um": HI, "alpha_per_um": ALPHA},
                }
            ],
            "stages": [stage],
        }
    )
    packing = pack_spheres(settings, BOX_UM, True, seed=4)
    grey = voxelize(packing.centres_um, packing.radii_um, BOX_UM, VOXEL_UM, True)
    return packing, grey


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    packing, grey = _experiment()
    # the experiment is made of spheres, so the model is too (decoration off)
    acquire = Settings(calibration=Calibration(max_overlap=0.3, steps=600, decoration=False))
    phases = segment_phases(grey, acquire.segmentation)  # the image: grey 0..216 read as an 8-bit scan
    exp = image_statistics(phases, VOXEL_UM, acquire)[None]
    scene = calibrated_scene(exp, acquire.calibration, name="loop-model", seed=9)
    match_statistics(
        scene, float(exp.porosity), float(exp.S_V_per_mm), acquire.calibration.porosity_iterations
    )
    model_scene = parse_scene({k: v for k, v in scene.items() if not k.startswith("_")})
    out = tmp_path_factory.mktemp("loop") / "model_statistics.h5"
    model = run_model(model_scene, acquire, out)[None]
    return packing, exp, scene, model


def test_radius_distribution_recovered(loop):
    packing, exp, scene, model = loop
    spec = scene["packing"]["types"][0]["radius_um"]
    # fitted support within one voxel of the true [40, 80] µm: the radius estimate carries ±0.5 voxel digitisation
    assert spec["min_um"] == pytest.approx(LO, abs=VOXEL_UM)
    assert spec["max_um"] == pytest.approx(HI, abs=VOXEL_UM)
    # the measured grain radii are a sample of the true law: two-sample KS against the packed radii at 0.1 %
    assert stats.ks_2samp(exp.inscribed_radius_um.values[exp.cut.values == 0], packing.radii_um).pvalue > 1e-3
    # the fitted decay rate is the true 0.05/µm within two standard errors of its maximum-likelihood estimate from
    # the n grains centred in the image, 1 / sqrt(n Var(r)) (Fisher information of alpha = Var(r) under the true
    # law): 0.0083/µm for n = 132. Before, the fit used the 83 grains clear of the boundary, which under-represent
    # large spheres (a sphere of radius r stays clear with probability ~ (L - 2r)³ / L³): 0.074, three errors off
    r = np.linspace(LO, HI, 20001)
    p = np.exp(-ALPHA * r) / np.exp(-ALPHA * r).sum()
    var_r = np.sum(p * r**2) - np.sum(p * r) ** 2
    n_centred = int((exp.counted.values == 1).sum())
    assert spec["alpha_per_um"] == pytest.approx(ALPHA, abs=2.0 / np.sqrt(n_centred * var_r))


def test_model_matches_experiment(loop):
    packing, exp, scene, model = loop
    assert float(model.porosity) == pytest.approx(float(exp.porosity), rel=0.06)
    assert float(model.S_V_per_mm) == pytest.approx(float(exp.S_V_per_mm), rel=0.12)
    # S_V matched as well as the porosity: within two standard deviations of its realisation scatter, computed here
    # from the TRUE law (not the fitted one) for the 150 spheres of the experiment, S_V sd(r²) / (mean(r²) sqrt(N))
    # = 3.3 %. Before S_V was matched, the model (sigma_max 0.3, porosity matched) had S_V 17.1, +10 %
    assert float(model.S_V_per_mm) == pytest.approx(
        float(exp.S_V_per_mm), abs=2 * _surface_sd(float(exp.S_V_per_mm))
    )
    # the sphere count after porosity matching: within 20 % of the 150 packed spheres (realisation scatter, above)
    assert scene["packing"]["types"][0]["count"] == pytest.approx(150, rel=0.20)
    # grain radii of model and experiment measured the same way come from one law: two-sample KS at 0.1 %
    assert stats.ks_2samp(model.equivalent_radius_um.values, exp.equivalent_radius_um.values).pvalue > 1e-3


def test_sphere_count_recovered(loop):
    packing, exp, scene, model = loop
    # marker-based counting + watershed: 130 of 150 here; small spheres buried in larger neighbours give no
    # distance-transform peak of their own, so the count is biased low. Bound 15 %
    count = float(exp.grains_per_mm3) * np.prod(BOX_UM) * 1e-9
    assert count == pytest.approx(150, rel=0.15)
