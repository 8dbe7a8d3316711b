"""The scaled-down thesis scenes (§5.6.1 filled packing, §5.6.2 rough walls) converge through the CLI."""

from pathlib import Path

import numpy as np
import pytest

from porepipe.packing import read_packing
from porepipe.packing._run import run as pack_scene

SCENES = Path(__file__).parents[2] / "config" / "scenes"


@pytest.mark.parametrize("name", ["filled-packing-ci", "rough-walls-ci"])
def test_ci_scene_converges(name, tmp_path):
    out = tmp_path / "packing.h5"
    pack_scene(SCENES / f"{name}.yaml", out, xyzr=tmp_path / "p.xyzr", progress=False)
    d = read_packing(out)
    assert d["all_converged"]
    sig_t = np.array([0.3, 0.25] if name.startswith("filled") else [0.35, 0.2])[d["types"]]
    assert np.all((d["max_overlap"] > 0) & (d["max_overlap"] <= sig_t))
    assert np.bincount(d["types"]).min() > 50  # both types survive the protocol
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "p.xyzr")[:, 3], d["radii_um"])
