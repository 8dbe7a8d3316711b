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


def test_mesopore_scenes_load_and_plan_capillary_diffusion_and_report(tmp_path):
    """The capillaries A/B/C of Mahler 2001 §4.2.3 (full, CI and thesis size): valid scenes, the thesis's reaction study
    (every set of Tables 4.2-4.4), and a DAG capillary → diffusion → sweep → report; the length-series scenes
    (§3.6.4) run their longest length on the whole capillary."""
    from porepipe.report._reaction_tables import THESIS
    from porepipe.scene import load_scene

    kinds = {"a": "constricted", "b": "pocketed", "c": "rough"}
    for k, kind in kinds.items():
        for suffix in ("", "-ci", "-thesis"):
            scene = load_scene(ROOT / "config" / "scenes" / f"mesopore-{k}{suffix}.yaml")
            assert scene.diffusion.geometry.kind.value == kind
            sets = {(s.w, s.w_reverse, s.w_follow) for s in scene.diffusion.reactions.series}
            assert {key[1:] for key in THESIS} <= sets
    for name in ("knudsen-length-series", "knudsen-length-series-ci"):
        scene = load_scene(ROOT / "config" / "scenes" / f"{name}.yaml")
        assert max(scene.diffusion.lengths) == scene.diffusion.geometry.length
    surface = load_scene(ROOT / "config" / "scenes" / "surface-reactions-ci.yaml").diffusion
    assert surface.setup.value == "surface" and surface.surface.mechanisms[0].kind == "LH"
    rules, _ = _planned(ROOT / "config" / "scenes" / "mesopore-a-ci.yaml", tmp_path)
    assert rules == {"all": 1, "capillary": 1, "diffusion": 1, "sweep": 1, "report": 1}, rules
