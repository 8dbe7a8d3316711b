"""The diffusion analysis in the workflow: `analyses: [diffusion]` puts one job per resolution and axis in the DAG."""

import re
import subprocess
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "config" / "scenes" / "mini-diffusion.yaml"


def _dry_run(scene_path, cwd):
    return subprocess.run(
        [sys.executable, "-m", "porepipe.cli", "run", str(scene_path), "--cores", "1", "-n"],
        cwd=cwd,
        capture_output=True,
        check=False,
        text=True,
    )


def _planned(scene_path, cwd):
    out = _dry_run(scene_path, cwd)
    assert out.returncode == 0, out.stderr + out.stdout
    table = re.findall(r"^(\w+)\s+(\d+)\s*$", out.stdout, flags=re.MULTILINE)
    return {name: int(count) for name, count in table if name != "total"}, out.stdout


def test_dry_run_has_one_diffusion_job_per_resolution_and_axis(tmp_path):
    scene = yaml.safe_load(SCENE.read_text())
    scene["diffusion"]["axes"] = ["x", "z"]
    scene["diffusion"]["resolutions_um"] = [4]
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(scene))
    rules, text = _planned(path, tmp_path)
    assert rules == {"all": 1, "pack": 1, "voxelize": 2, "segment": 2, "diffusion": 2}, rules
    assert "results/mini-diffusion/diffusion/diffusion_a4_x.h5" in text
    assert "results/mini-diffusion/diffusion/diffusion_a4_z.h5" in text


def test_capillary_scene_runs_the_generator_instead_of_packing_and_segment(tmp_path):
    """A scene with diffusion.geometry: one capillary job per resolution feeds diffusion; no pack/voxelize/segment."""
    path = ROOT / "config" / "scenes" / "knudsen-capillary-ci.yaml"
    rules, text = _planned(path, tmp_path)
    assert rules == {"all": 1, "capillary": 2, "diffusion": 2}, rules
    for a in ("1", "0.5"):
        assert f"results/knudsen-capillary-ci/capillary/binary_a{a}.h5" in text
        assert f"results/knudsen-capillary-ci/diffusion/diffusion_a{a}_z.h5" in text


def test_capillary_size_that_is_no_whole_voxel_count_stops_the_dry_run(tmp_path):
    scene = yaml.safe_load((ROOT / "config" / "scenes" / "knudsen-capillary-ci.yaml").read_text())
    scene["diffusion"]["geometry"] = {"kind": "square", "a_um": 1.25, "length": 30}
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(scene))
    out = _dry_run(path, tmp_path)
    assert out.returncode != 0
    assert "diffusion.geometry.a_um = 1.25 is 1.25 voxels" in out.stdout + out.stderr
