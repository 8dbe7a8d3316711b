"""Every rule carries the resources a cluster job needs, and the Slurm profile plans the mini scene.

A cluster run has no ``--cores``: a rule whose ``threads:`` reads ``workflow.cores`` stops the whole workflow there
("Workflow requires a total number of cores"), which is how the profile failed before it was ever run; rules that
use every core take ``every_core(n)`` (workflow/rules/common.smk). The run itself is tested on a real Slurm in
test_slurm_workflow.py.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RULE_FILES = sorted((ROOT / "workflow" / "rules").glob("*.smk"))


def _rules():
    for path in RULE_FILES:
        for block in re.split(r"(?m)^(?=rule )", path.read_text())[1:]:
            yield re.match(r"rule (\w+):", block).group(1), block


@pytest.mark.parametrize(("name", "block"), list(_rules()), ids=[name for name, _ in _rules()])
def test_rule_declares_threads_cpus_memory_and_runtime(name, block):
    assert re.search(r"(?m)^    threads: ", block), f"rule {name}: no threads:"
    assert "threads: workflow.cores" not in block, f"rule {name}: workflow.cores does not exist on a cluster"
    resources = block.split("    resources:\n", 1)[1] if "    resources:\n" in block else ""
    for key in ("cpus_per_task=", "mem_mb=", "runtime="):
        assert re.search(rf"(?m)^        {key}", resources), f"rule {name}: no resources: {key[:-1]}"


def test_slurm_profile_plans_the_mini_scene_with_every_job_s_resources(tmp_path):
    pytest.importorskip("snakemake_executor_plugin_slurm")
    out = subprocess.run(
        [sys.executable, "-m", "snakemake", "--snakefile", str(ROOT / "Snakefile"), "--executor", "slurm"]
        + ["--profile", str(ROOT / "workflow" / "profiles" / "slurm"), "--dry-run"]
        + ["--config", f"scene={ROOT / 'config' / 'scenes' / 'mini.yaml'}"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    jobs = re.findall(r"(?m)^rule (\w+):\n(?:    .*\n)*?    resources: (.*)$", out.stdout + out.stderr)
    assert {rule for rule, _ in jobs} >= {"pack", "voxelize", "segment", "minkowski", "lpt", "permeability"}
    for rule, resources in jobs:
        if rule == "all":  # the target: no job of its own
            continue
        for key in ("mem_mb=", "runtime=", "cpus_per_task=", "slurm_partition=compute"):
            assert key in resources, f"{rule}: {key} missing from {resources}"
