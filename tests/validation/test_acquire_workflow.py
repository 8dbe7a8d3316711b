"""The image-to-model scene plans image -> statistics -> calibrated model -> comparison, and its binary volume comes
from the image (acquire_binary), never from the voxeliser; a model scene keeps `segment` (no ambiguity)."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "config" / "scenes" / "image-to-model.yaml"


def _planned(scene, cwd, *targets):
    cmd = [sys.executable, "-m", "porepipe.cli", "run", str(scene), "--cores", "1", "-n", "--", *targets]
    out = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    rules = {}
    for line in out.stdout.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[1].isdigit() and parts[0] not in ("job", "total"):
            rules[parts[0]] = int(parts[1])
    return rules


def test_image_scene_plans_the_acquisition_chain(tmp_path):
    rules = _planned(SCENE, tmp_path, "all", "results/image-to-model/acquire_compare/comparison.h5")
    assert {"acquire", "acquire_binary", "acquire_calibrate", "acquire_model", "acquire_compare"} <= set(
        rules
    )
    assert "voxelize" not in rules and "segment" not in rules and "pack" not in rules


def test_model_scene_keeps_segment(tmp_path):
    rules = _planned(ROOT / "config" / "scenes" / "mini.yaml", tmp_path)
    assert "segment" in rules and not any(r.startswith("acquire") for r in rules)
