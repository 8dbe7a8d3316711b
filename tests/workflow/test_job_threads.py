"""Jobs on small volumes take one thread, so that on 2 cores two of them run side by side (threads_by_volume in
common.smk); jobs on large volumes still take every core the rule allows. Checked on the planned jobs of a dry run."""

import re
import subprocess
import sys
from pathlib import Path

import yaml

MINI = Path(__file__).resolve().parents[2] / "config" / "scenes" / "mini.yaml"


def _planned_threads(scene_path, cwd, cores):
    out = subprocess.run(
        [sys.executable, "-m", "porepipe.cli", "run", str(scene_path), "--cores", str(cores), "-n"],
        cwd=cwd,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr[-3000:] + out.stdout[-3000:]
    jobs = {}
    for block in re.split(r"(?m)^(?=(?:local)?rule )", out.stdout)[1:]:
        rule = re.match(r"(?:local)?rule (\w+):", block).group(1)
        wildcards = re.search(r"wildcards: .*?a=([0-9.]+)", block)
        threads = re.search(r"threads: (\d+)", block)  # Snakemake prints it only when above 1
        jobs[(rule, wildcards.group(1) if wildcards else "")] = int(threads.group(1)) if threads else 1
    return jobs


def test_small_volumes_get_one_thread_large_ones_every_core(tmp_path):
    scene = yaml.safe_load(MINI.read_text())
    scene["resolutions_um"] = [4, 1, 0.5]  # 25³, 100³ and 200³ voxels
    scene["permeability"]["resolutions_um"] = [4, 0.5]
    path = tmp_path / "mini-fine.yaml"
    path.write_text(yaml.safe_dump(scene))
    jobs = _planned_threads(path, tmp_path, cores=4)
    # voxelize: one thread per 2^20 voxels, at most 4; permeability: one per 2^15, at most every core
    assert jobs[("voxelize", "4")] == 1 and jobs[("voxelize", "1")] == 1 and jobs[("voxelize", "0.5")] == 4
    assert jobs[("permeability", "4")] == 1 and jobs[("permeability", "0.5")] == 4
    assert jobs[("lpt", "4")] == 1 and jobs[("lpt", "0.5")] == 2 and jobs[("segment", "0.5")] == 1
