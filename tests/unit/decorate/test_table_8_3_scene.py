"""The shipped Table 8.3 scenes (Zauner 2020, calibrated Bentheimer model) carry the table's parameters."""

from pathlib import Path

import numpy as np
import pytest

from porepipe.scene import load_scene

SCENES = Path(__file__).resolve().parents[3] / "config" / "scenes"


@pytest.mark.parametrize("name", ["bentheimer-8.3", "bentheimer-8.3-ci"])
def test_scene_has_table_8_3s_parameters(name):
    scene = load_scene(SCENES / f"{name}.yaml")
    (grain,) = scene.packing.types
    assert grain.count / np.prod(scene.domain.size_um) * 1e9 == pytest.approx(
        556, rel=2e-3
    )  # spheres per mm³
    assert (2 * grain.radius_um.min_um, 2 * grain.radius_um.max_um) == (45, 280)  # sizes read as diameters
    assert grain.max_overlap == 0.1
    (family,) = scene.decoration.families
    assert (family.generator.value, family.count, family.facets, family.elongation) == (
        "random",
        512,
        36,
        (0, 0.4),
    )
    om = scene.decoration.orientation
    assert (om.mode.value, om.passes, om.trials_per_grain) == ("overlap_minimizer", 3, 5)  # N_Z^OM, N_K^OM
    assert om.cell_volume_um3 == pytest.approx(500.0**3)  # "500 µm³" read as (500 µm)³
