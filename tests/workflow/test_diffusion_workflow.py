"""The diffusion analysis in the workflow: `analyses: [diffusion]` puts one job per resolution and axis in the DAG."""

import re
import subprocess
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "config" / "scenes" / "mini-diffusion.yaml"


def _planned(scene_path, cwd):
    out = subprocess.run(
        [sys.executable, "-m", "porepipe.cli", "run", str(scene_path), "--cores", "1", "-n"],
        cwd=cwd,
        capture_output=True,
        check=False,
        text=True,
    )
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
