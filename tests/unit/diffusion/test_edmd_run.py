"""Setups edmd and reaction through the stage's file door and CLI: result readable with xarray, bad input refused."""

import numpy as np
import pytest
import xarray as xr

from porepipe._shared.store import ResultWriter
from porepipe.cli import main as cli_main
from porepipe.diffusion import square_capillary


def _binary(path, pore, voxel_um=0.01, periodic=(0, 0, 0)):
    with ResultWriter(path, stage="segment", scene="t", scene_hash="abc") as w:
        w.write_volume("pore", pore, voxel_um=voxel_um, periodic=periodic)
    return path


def test_cli_edmd_writes_collision_figures(tmp_path, capsys):
    """A periodic 2³-voxel box of 10 nm voxels with 300 N2: the result holds Z next to Enskog's (within 15 %: a
    short run of ~1000 collisions has a 3 % 1-σ count error, and the box is dense enough for χ = 1.03), D_self and
    the MB KS p-value."""
    binary = _binary(tmp_path / "binary_a0.01.h5", np.ones((2, 2, 2), np.uint8), periodic=(1, 1, 1))
    out = tmp_path / "e.h5"
    rc = cli_main(
        [
            "diffusion",
            str(binary),
            "--setup",
            "edmd",
            "--gas-particles",
            "N2=300",
            "--duration-ps",
            "40",
            "-o",
            str(out),
        ]
    )
    assert rc in (0, None)
    assert "lambda_eff" in capsys.readouterr().out
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert float(ds["collision_rate"]) == pytest.approx(float(ds["collision_rate_enskog"]), rel=0.15)
    assert float(ds["D_self_m2_s"]) > 0
    assert 0 <= float(ds["ks_pvalue"]) <= 1
    assert ds["speed_histogram"].values.sum() == 300
    assert abs(float(ds["energy_rel_drift"])) < 1e-12


def test_cli_reaction_writes_eta_and_refuses_bad_probability(tmp_path, capsys):
    binary = _binary(tmp_path / "binary_a0.01.h5", square_capillary(4, 16).pore)
    out = tmp_path / "r.h5"
    args = [
        "diffusion",
        str(binary),
        "--setup",
        "reaction",
        "--reaction-w",
        "0.05",
        "--reaction-particles",
        "2000",
    ]
    assert cli_main([*args, "-o", str(out)]) in (0, None)
    assert "eta" in capsys.readouterr().out
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert 0 < float(ds["eta"]) < 1
    assert float(ds["phi"]) > 0
    assert ds["z_react"].values.sum() == int(ds["reactions"])
    bad = tmp_path / "bad.h5"
    assert cli_main([*args[:-4], "--reaction-w", "1.5", "-o", str(bad)]) == 2
    assert "--reaction-w = 1.5" in capsys.readouterr().err  # the option typed, not the key reactions.w
    assert not bad.exists()
