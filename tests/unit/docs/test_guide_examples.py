"""The Python API guide's code blocks run as printed, in order, in one namespace (a reader pastes them so), and
what they print agrees with the truth each block names: the slit's κ with h²/12 · φ, the mean local porosity with
the global one (Σ φ μ = φ̄ for periodic cells), W of the capillary between 0 and 1."""

import re
from pathlib import Path

import numpy as np

GUIDE = Path(__file__).resolve().parents[3] / "docs" / "guide.md"


def test_every_python_block_of_the_guide_runs_in_order(tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), re.S)
    assert len(blocks) >= 6  # voxelize+segment, minkowski, lpt, permeability, diffusion, granular
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for i, block in enumerate(blocks):
        exec(compile(block, f"{GUIDE.name}[block {i}]", "exec"), namespace)
    capsys.readouterr()
    ns = namespace
    # 8 fluid layers of 10: plane Poiseuille κ = h²/12 per open area; halfway walls at the exact slit faces (2 %)
    np.testing.assert_allclose(ns["result"].kappa_lu, 8**2 / 12 * 0.8, rtol=0.02)
    phi_local = np.arange(ns["hist"].counts.size) / 4**3
    mean_local = np.sum(phi_local * ns["hist"].counts) / ns["hist"].n_cells
    np.testing.assert_allclose(mean_local, ns["pore"].mean(), rtol=1e-12)  # exact identity, round-off only
    np.testing.assert_allclose(float(ns["mf"]["phi"].sel(phase="pore")), ns["pore"].mean(), rtol=1e-12)
    assert 0 < ns["run"].values["W"] < 1
    # adsorption: competitive Langmuir isotherm, 4 standard errors plus 0.3 % (tests/unit/diffusion/test_surface_*)
    theta = ns["surf"]["coverage"][0]
    assert abs(theta - ns["theta_langmuir"]) <= 4 * ns["surf"]["coverage_err"][0] + 3e-3 * theta
    # reverse Eley-Rideal and a side reaction of the product: A and B atoms conserved exactly
    a, b, p, s = ns["rev"]["final_counts"]
    assert (a + p + s, b + p + s) == (2000, 800) and ns["rev"]["er_reverse_reactions"] > 0
