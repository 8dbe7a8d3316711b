"""The workflow's warm jobs (workflow/rules/warm.smk): planned on a local run of two or more cores while the numba
cache lacks a stage's kernels for the scene, one per stage, each before its stage's jobs; none once warm, none on
one core; one per stage for scenes with the same twins. The pack job of a small packing takes one thread, so that
the first warm job runs beside it. Checked on the planned jobs of dry runs.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

from porepipe.warm import STAGES, marker_path, twin_key

SCENES = Path(__file__).resolve().parents[2] / "config" / "scenes"
MINI = SCENES / "mini.yaml"


def _planned(cwd, cores, cache, scene=MINI):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    out = subprocess.run(
        [sys.executable, "-m", "porepipe.cli", "run", str(scene), "--cores", str(cores), "-n"],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr[-3000:] + out.stdout[-3000:]
    return re.split(r"(?m)^(?=(?:local)?rule )", out.stdout)[1:]


def _jobs(blocks, rule):
    return [b for b in blocks if re.match(rf"(?:local)?rule {rule}:", b)]


def _markers(scene=MINI):
    """Each stage's warm marker in the workflow, as its jobs name it."""
    return {stage: f"results/_warm/{twin_key(scene, stage)}/{stage}.done" for stage in STAGES}


def test_a_cold_cache_plans_one_warm_job_per_stage_before_the_stages_jobs(tmp_path):
    blocks = _planned(tmp_path, 2, tmp_path / "cache")
    warm = {re.search(r"stage=(\w+)", b).group(1): b for b in _jobs(blocks, "warm")}
    markers = _markers()
    assert sorted(warm) == sorted(STAGES)
    assert markers["voxelize"] not in warm["voxelize"].split("output:")[0]
    for stage in ("permeability", "minkowski", "lpt"):  # their twins voxelise: after voxelize's warm-up
        assert markers["voxelize"] in warm[stage].split("output:")[0]
        assert markers[stage] in warm[stage].split("output:")[1]
    for stage in STAGES:  # each stage's rule has the stage's name
        jobs = _jobs(blocks, stage)
        assert jobs and all(markers[stage] in job.split("output:")[0] for job in jobs), stage
    (pack,) = _jobs(blocks, "pack")
    assert "threads:" not in pack  # Snakemake prints threads only above 1


def test_a_warm_cache_or_one_core_plans_no_warm_job(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    assert not _jobs(_planned(tmp_path, 1, cache), "warm")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache))
    cache.mkdir()
    for stage in STAGES:  # what a finished warm-up leaves
        marker_path(MINI, stage).touch()
    blocks = _planned(tmp_path, 2, cache)
    assert not _jobs(blocks, "warm")
    assert all("_warm/" not in job for job in blocks)


def test_scenes_with_the_same_twins_share_their_warm_jobs(tmp_path):
    # thesis-5.6.1-ci reads thesis-5.6.1-pp-ci's rows: two scenes, one run, the same twins (they differ only in the
    # packing), so one warm job per stage, whose marker both scenes' jobs wait for
    fp, pp = SCENES / "thesis-5.6.1-ci.yaml", SCENES / "thesis-5.6.1-pp-ci.yaml"
    blocks = _planned(tmp_path, 2, tmp_path / "cache", scene=fp)
    assert _markers(fp) == _markers(pp)
    assert sorted(re.search(r"stage=(\w+)", b).group(1) for b in _jobs(blocks, "warm")) == sorted(STAGES)
    markers = _markers(fp)
    for name in ("thesis-5.6.1-ci", "thesis-5.6.1-pp-ci"):
        lpt = [b for b in _jobs(blocks, "lpt") if f"results/{name}/" in b.split("output:")[1]]
        assert lpt and all(markers["lpt"] in job.split("output:")[0] for job in lpt), name
