"""The workflow on the mini scene: the DAG holds only what the analyses need, and a full run produces results."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pint
import pytest
import xarray as xr
import yaml

from porepipe import open_result
from porepipe._shared.store import read_attrs, read_volume

ROOT = Path(__file__).resolve().parents[2]
MINI = ROOT / "config" / "scenes" / "mini.yaml"


def _porepipe(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "porepipe.cli", *args], cwd=cwd, capture_output=True, text=True
    )


def _planned_rules(scene_path, cwd):
    out = _porepipe("run", str(scene_path), "--cores", "1", "-n", cwd=cwd)
    assert out.returncode == 0, out.stderr + out.stdout
    # Snakemake's dry run prints a job-stats table "rule  count" ... ; collect rule names with their counts
    table = re.findall(r"^(\w+)\s+(\d+)\s*$", out.stdout, flags=re.M)
    return {name: int(count) for name, count in table if name != "total"}


def test_dry_run_lists_only_the_rules_the_analyses_need(tmp_path):
    rules = _planned_rules(MINI, tmp_path)
    scene = yaml.safe_load(MINI.read_text())
    n_res = len(scene["resolutions_um"])
    assert rules == {
        "all": 1,
        "pack": 1,
        "voxelize": n_res,
        "segment": n_res,
        "estimate": 1,
        "minkowski": n_res,
        "lpt": n_res,
        "permeability": 1,
        "sweep": 1,
        "report": 1,
    }, rules


def test_dry_run_without_segmentation_has_no_segment_jobs(tmp_path):
    scene = yaml.safe_load(MINI.read_text())
    scene["analyses"] = ["estimate"]
    path = tmp_path / "only-estimate.yaml"
    path.write_text(yaml.safe_dump(scene))
    rules = _planned_rules(path, tmp_path)
    assert rules == {"all": 1, "pack": 1, "voxelize": len(scene["resolutions_um"]), "estimate": 1}, rules


@pytest.mark.slow
def test_mini_scene_runs_end_to_end(mini_local_run):
    cwd, out, _ = mini_local_run
    assert out.returncode == 0, out.stderr[-3000:]
    res = cwd / "results" / "mini"
    assert f"results of scene 'mini' are in {res}" in out.stdout
    scene = yaml.safe_load(MINI.read_text())
    for a in scene["resolutions_um"]:
        grey, attrs = read_volume(res / "voxelize" / f"grey_a{a:g}.h5", "grey")
        assert grey.shape == (round(100 / a),) * 3 and attrs["voxel_um"] == a
        pore, pattrs = read_volume(res / "segment" / f"binary_a{a:g}.h5", "pore")
        assert set(pattrs) >= {"threshold", "method", "voxel_um", "origin_um", "periodic"}
        assert ((grey <= pattrs["threshold"]) == pore.astype(bool)).all()
        assert (res / "cost" / f"voxelize_a{a:g}.tsv").is_file()
    with xr.open_dataset(res / "estimate" / "estimate.h5", engine="h5netcdf") as ds:
        assert ds.phi_lower.values.min() <= float(ds.phi_limit) <= ds.phi_upper.values.max()
    assert read_attrs(res / "estimate" / "estimate.h5")["stage"] == "estimate"
    with xr.open_dataset(res / "minkowski" / "minkowski_a1.h5", engine="h5netcdf") as mk:
        assert abs(float(mk.phi_pore) - pore.mean()) < 1e-12  # same volume, same porosity
    report = (res / "report" / "index.html").read_text()
    assert "<img" in report and "<table" in report
    leftovers = [p for p in res.rglob("*") if p.name.startswith(".")]
    assert not leftovers, leftovers
    _check_self_described(res)


def _units_of(var) -> str | None:
    if var.attrs.get("units_from") == "unit":  # sweep: per-quantity units in the coordinate `unit`
        return "1"
    return var.attrs.get("units")


def _check_self_described(res: Path) -> None:
    """Every result of the run opens as one Dataset whose every numeric variable has units pint reads."""
    ureg = pint.UnitRegistry()
    files = [p for p in res.rglob("*.h5") if p.name != "checkpoint.h5"]
    kinds = {p.parent.name for p in files}
    assert kinds >= {
        "pack",
        "voxelize",
        "segment",
        "estimate",
        "minkowski",
        "lpt",
        "permeability",
        "sweep",
    }, kinds
    for path in files:
        with open_result(path) as ds:
            for name, var in ds.variables.items():
                if var.dtype.kind in "OUS":
                    continue
                units = _units_of(var)
                assert units is not None, f"{path.name}: variable {name} has no units"
                ureg.Unit(units)  # one spelling, and one pint reads
            if "x_um" in ds.dims:
                a = (
                    float(read_attrs(path).get("voxel_um", np.nan))
                    if "voxel_um" in read_attrs(path)
                    else None
                )
                step = np.diff(ds.x_um.values)
                assert np.allclose(step, step[0]) and (a is None or np.isclose(step[0], a))
    with open_result(res / "pack" / "packing.h5") as pack:
        assert pack.centres_um.dims == ("sphere", "xyz") and pack.radii_um.attrs["units"] == "µm"
    with open_result(res / "sweep" / "sweep.h5") as sweep:
        for units in sweep.unit.values:
            ureg.Unit(str(units))
