"""A mini-like scene with `report` in its analyses: the workflow's final target is the report page.

One workflow run (module fixture) of a small scene with inline spheres (no packing, no data files) in a temporary
directory; the tests read its output.
"""

import csv
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

ROOT = Path(__file__).resolve().parents[2]
#: CPU-second budget of the report rule on the mini scene (the issue asks for < 15 s; wall time on the shared CI
#: machine varies with load, the job's CPU time does not)
REPORT_CPU_S = 15.0


def _porepipe(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "porepipe.cli", *args], cwd=cwd, capture_output=True, text=True, check=False
    )


def small_scene(analyses):
    """60 random spheres (r 3..5 µm) in a periodic 40 µm box at a = 4, 2, 1 µm."""
    rng = np.random.default_rng(8)
    spheres = np.column_stack([rng.uniform(0, 40, (60, 3)), rng.uniform(3, 5, 60)]).round(3).tolist()
    return {
        "name": "small",
        "seed": 1,
        "domain": {"size_um": [40, 40, 40], "periodic": True},
        "spheres": {"inline": spheres},
        "resolutions_um": [4, 2, 1],
        "analyses": analyses,
    }


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("report-workflow")
    scene = small_scene(["segment", "estimate", "report"])
    path = cwd / "small.yaml"
    path.write_text(yaml.safe_dump(scene))
    out = _porepipe("run", str(path), "--cores", "2", cwd=cwd)
    assert out.returncode == 0, out.stderr[-3000:]
    return cwd / "results" / scene["name"], scene


def test_dry_run_ends_in_the_report(tmp_path):
    scene = small_scene(["estimate", "report"])
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(scene))
    out = _porepipe("run", str(tmp_path / "s.yaml"), "--cores", "1", "-n", cwd=tmp_path)
    assert out.returncode == 0, out.stderr + out.stdout
    rules = dict(re.findall(r"^(\w+)\s+(\d+)\s*$", out.stdout, flags=re.MULTILINE))
    n = str(len(scene["resolutions_um"]))
    # estimate-only scene: no segmentation jobs; one sweep and one report job
    assert rules == {
        "all": "1",
        "voxelize": n,
        "estimate": "1",
        "sweep": "1",
        "report": "1",
        "total": rules["total"],
    }


def test_sweep_holds_every_resolution_with_costs(run):
    res, scene = run
    with xr.open_dataset(res / "sweep" / "sweep.h5", engine="h5netcdf") as ds:
        assert sorted(ds.a_um.values.tolist()) == sorted(scene["resolutions_um"])
        assert "estimate.phi_lower" in ds.quantity.values
        assert (ds.wall_s.values[ds.value.notnull().values] >= 0).all()
        assert ds.upstream_wall_s.notnull().all()  # voxelize + segment cost at every resolution
        assert (ds.bench_s.notnull()).any()  # Snakemake's benchmark records were found
        assert (ds.status == "ok").any()


def test_report_has_the_required_parts(run):
    res, _ = run
    page = (res / "report" / "index.html").read_text()
    for png in ("quantities.png", "error_cost.png", "sections.png"):
        assert f"src='{png}'" in page and (res / "report" / png).stat().st_size > 1000
    assert (
        "<table>" in page
        and "What accuracy costs" in page
        and "not shown, this scene produced no numbers" in page
    )
    assert re.search(r"<td>\S+ ± \S+ \(p = ", page)  # at least one supported limit printed with its error
    assert "porepipe version" in page and "threads of the runs" in page and "host" in page
    links = re.findall(r"(?:src|href)='([^']+)'", page)
    assert all((res / "report" / link).is_file() for link in links) and "http" not in page.lower()


def test_report_rule_is_fast(run):
    res, _ = run
    with open(res / "cost" / "report.tsv", newline="") as fh:
        row = next(csv.DictReader(fh, delimiter="\t"))
    assert float(row["cpu_time"]) < REPORT_CPU_S, row


def test_snakemake_report_holds_the_marked_figures(run):
    res, _ = run
    cwd = res.parent.parent
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "snakemake",
            "--snakefile",
            str(ROOT / "Snakefile"),
            "--directory",
            str(cwd),
            "--cores",
            "1",
            "--config",
            f"scene={cwd / 'small.yaml'}",
            "--report",
            str(cwd / "snakemake_report.html"),
        ],
        cwd=cwd,
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    log = out.stdout + out.stderr
    for name in ("index.html", "error_cost.png", "quantities.png", "limits.csv"):
        assert f"Adding {name}" in log, log[-2000:]
    assert (cwd / "snakemake_report.html").stat().st_size > 100_000


def test_subsample_rule_cuts_the_corner(run):
    res, _ = run
    cwd = res.parent.parent
    target = "results/small/subsample/binary_a2_L20.h5"
    out = _porepipe("run", str(cwd / "small.yaml"), "--cores", "1", "--", target, cwd=cwd)
    assert out.returncode == 0, out.stderr[-3000:]
    from porepipe._shared.store import read_volume

    cube, attrs = read_volume(cwd / target, "pore")
    full, _ = read_volume(res / "segment" / "binary_a2.h5", "pore")
    np.testing.assert_array_equal(cube, full[:10, :10, :10])
    assert attrs["periodic"] == [0, 0, 0]
