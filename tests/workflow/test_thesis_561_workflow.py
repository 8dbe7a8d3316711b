"""§5.6.1 by the workflow: `porepipe run thesis-5.6.1-ci` packs PP and FP, measures both and fills Tables 5.1/5.2.

One workflow run (module fixture) of the shipped -ci scenes in a temporary directory. The -ci box is 1/27 of the
thesis's (capped grain radii), so its numbers are not the thesis's: these tests check that the rows come from the
pipeline, the scenes' claims (PP is FP's grain matrix, bit for bit) and the porosity against an independent
Monte-Carlo estimate of the same spheres. The full-size comparison is in the README.
"""

import csv
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from porepipe.packing import read_packing

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "config" / "scenes"
FP, PP = "thesis-5.6.1-ci", "thesis-5.6.1-pp-ci"

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("thesis-561")
    for name in (FP, PP):
        shutil.copy(SCENES / f"{name}.yaml", cwd / f"{name}.yaml")
    out = subprocess.run(
        [sys.executable, "-m", "porepipe.cli", "run", f"{FP}.yaml", "--cores", "2"],
        cwd=cwd,
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    return cwd / "results"


def _table(results, key):
    with open(results / FP / "report" / f"table_{key}.csv", newline="") as f:
        return list(csv.DictReader(f))


def _mc_porosity(path, n=200_000, k=24):
    """Monte-Carlo porosity of a periodic packing: a point is solid if one of its k nearest centres per type covers
    it (k = 24 covers every sphere that can reach a point here: radii differ by at most 2x within a type)."""
    d = read_packing(path)
    box = float(d["box_um"][0])
    x, r, t = np.asarray(d["centres_um"]) % box, np.asarray(d["radii_um"]), np.asarray(d["types"])
    p = np.random.default_rng(0).random((n, 3)) * box
    solid = np.zeros(n, bool)
    for ty in np.unique(t):
        m = t == ty
        dist, idx = cKDTree(x[m], boxsize=box).query(p, k=min(k, int(m.sum())))
        solid |= np.any(dist < r[m][idx], axis=1)
    phi = 1.0 - solid.mean()
    return phi, np.sqrt(phi * (1 - phi) / n)


def test_pp_is_the_grain_matrix_of_fp(run):
    pp, fp = read_packing(run / PP / "pack" / "packing.h5"), read_packing(run / FP / "pack" / "packing.h5")
    grains = np.asarray(fp["types"]) == 0
    np.testing.assert_array_equal(pp["centres_um"], fp["centres_um"][grains])
    np.testing.assert_array_equal(pp["radii_um"], fp["radii_um"][grains])
    assert (~grains).sum() > 1000  # fines survived the fill


def test_tables_5_1_and_5_2_hold_both_models_from_the_pipeline(run):
    t51, t52 = _table(run, "5_1"), _table(run, "5_2")
    for rows, quantity in ((t51, "phi"), (t52, "kappa")):
        for model in ("PP", "FP"):
            (row,) = [
                r for r in rows if r["row"] == f"{model} a = 1 um" and r["quantity"].startswith(quantity)
            ]
            assert np.isfinite(float(row["porepipe"])) and row["source and cost"]
            assert float(row["difference"]) == pytest.approx(float(row["porepipe"]) - float(row["thesis"]))
    # the fines fill pores: FP is less porous than PP
    phi = {
        r["row"][:2]: float(r["porepipe"])
        for r in t51
        if r["row"].endswith("a = 1 um") and r["quantity"] == "phi"
    }
    assert phi["FP"] < phi["PP"]


def test_pp_porosity_matches_an_independent_monte_carlo_of_its_spheres(run):
    """φ of PP at a = 1 µm (grains ≥ 20 voxels across: the voxel error is a few 1e-3) against 2·10⁵ random points;
    tolerance 0.006 = 4 Monte-Carlo standard errors (0.001) + 0.002 voxelisation."""
    rows = _table(run, "5_1")
    (row,) = [r for r in rows if r["row"] == "PP a = 1 um" and r["quantity"] == "phi"]
    phi, err = _mc_porosity(run / PP / "pack" / "packing.h5")
    assert abs(float(row["porepipe"]) - phi) < 4 * err + 0.002
