"""A dense image (porosity ~0.32) calibrates to a model that packs to convergence and has the image's porosity.

Before: the calibrated stage (k = 400, sigma_max 0.1, dt Xi = 1) left 34 of 231 spheres converged here (a pair pressed
to sigma_max = 0.1 repels 3.5x weaker than a neighbour's LJ tail pulls at its peak), and the Boolean-model count
update matched the porosity with spheres overlapping far past sigma_max.

The image: 260 spheres of the packer's own truncated-exponential law (r 40-80 µm, alpha 0.05/µm) at sigma_max 0.3 in
a periodic 600 µm box, voxelised at 6 µm; its porosity and S_V are measured on the image itself (the targets).

Its S_V is not matched (the xfail below): with k 400 at sigma_max 0.3 its pairs overlap far past sigma_max (mean 0.32,
largest 1.36, 9.2 overlapping neighbours per sphere), and it has S_V 13.06 mm^-1 at porosity 0.310. The calibrated
dynamics converge (every overlap within sigma_max, 6-8 neighbours), and at this porosity reach S_V 16.6 at
sigma_max 0.4 (the default max_overlap_limit) and no less than 15.0 up to sigma_max 1.0: S_V falls with sigma_max only
until k reaches its floor 400 at ~0.5, after which more, deeper-overlapping spheres hide no more surface.
"""

import h5py
import numpy as np
import pytest

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
LO, HI, ALPHA, COUNT = 40.0, 80.0, 0.05, 260


def _dense_image():
    stage = {"name": "one", "insert": ["a"], "steps": 1500, "dt": 0.25, "k": {"a": 400}, "damping": {"a": 4}}
    law = {"dist": "exponential", "min_um": LO, "max_um": HI, "alpha_per_um": ALPHA}
    settings = PackingSettings.model_validate(
        {"types": [{"name": "a", "count": COUNT, "max_overlap": 0.3, "radius_um": law}], "stages": [stage]}
    )
    packing = pack_spheres(settings, BOX_UM, True, seed=4)
    return voxelize(packing.centres_um, packing.radii_um, BOX_UM, VOXEL_UM, True)


def _realisation_sd(count):
    """sqrt(N) sd(v) / V of the TRUE law (not the fitted one): porosity scatter between packings of N spheres."""
    r = np.linspace(LO, HI, 20001)
    p = np.exp(-ALPHA * r)
    p /= p.sum()
    v = 4.0 / 3.0 * np.pi * r**3
    sd = np.sqrt(np.sum(p * v**2) - np.sum(p * v) ** 2)
    return np.sqrt(count) * sd / np.prod(BOX_UM)


def _surface_sd(s_v, count):
    """S_V sd(r²) / (mean(r²) sqrt(N)) under the TRUE law: S_V scatter between packings of N spheres."""
    r = np.linspace(LO, HI, 20001)
    p = np.exp(-ALPHA * r) / np.exp(-ALPHA * r).sum()
    mean = np.sum(p * r**2)
    return s_v * np.sqrt(np.sum(p * r**4) - mean**2) / (mean * np.sqrt(count))


@pytest.fixture(scope="module")
def dense(tmp_path_factory):
    grey = _dense_image()
    acquire = Settings(calibration=Calibration(decoration=False))  # the default max_overlap 0.1 (Table 8.3)
    exp = image_statistics(segment_phases(grey, acquire.segmentation), VOXEL_UM, acquire)[None]
    scene = calibrated_scene(exp, acquire.calibration, name="dense-model", seed=9)
    match_statistics(
        scene, float(exp.porosity), float(exp.S_V_per_mm), acquire.calibration.porosity_iterations
    )
    model_scene = parse_scene({k: v for k, v in scene.items() if not k.startswith("_")})
    out = tmp_path_factory.mktemp("dense") / "model_statistics.h5"
    model = run_model(model_scene, acquire, out)[None]
    with h5py.File(out) as f:
        kept, converged = int(f.attrs["n_spheres"]), int(f.attrs["packing_converged"])
    return exp, scene, model, kept, converged


def test_dense_image_calibrates_to_a_converged_model_of_its_porosity(dense):
    exp, scene, model, kept, converged = dense
    target = float(exp.porosity)
    assert target < 0.35  # dense: the case that failed
    inserted = scene["packing"]["types"][0]["count"]
    # converged (§5.1: 0 < max sigma <= sigma_max for every sphere kept), and at least 95 % of the inserted spheres
    # kept: the stage deletes the few still overlapping too much at its step limit, no more than 5 %
    assert converged == 1
    assert kept >= 0.95 * inserted
    # porosity: two standard deviations of the realisation scatter of a box of N spheres of the true law,
    # sqrt(N) sd(v) / V (the model is another realisation of the law; N = the 260 spheres of the image): 2 x 0.029
    assert float(model.porosity) == pytest.approx(target, abs=2 * _realisation_sd(COUNT))


@pytest.mark.xfail(
    strict=True,
    reason="S_V 13.06 of this image lies below what converged packings of its radius law reach at its porosity: "
    "15.0-16.8 at sigma_max 0.4-1.0 (coordination 6-8 against the image's 9.2, whose k-400 packing overlaps up to "
    "1.36); S_V falls with sigma_max only up to ~0.5, where k reaches its floor 400",
)
def test_dense_image_model_matches_its_specific_surface(dense):
    exp, scene, model, kept, converged = dense
    # two standard deviations of the S_V realisation scatter of the true law for the image's 260 spheres (2 x 3.0 %)
    assert float(model.S_V_per_mm) == pytest.approx(
        float(exp.S_V_per_mm), abs=2 * _surface_sd(float(exp.S_V_per_mm), COUNT)
    )
