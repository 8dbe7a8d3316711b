"""The workflow on a real Slurm cluster (issue 23): a single node from Debian's packages, started by the fixture.

- The mini scene runs with ``snakemake --executor slurm --profile workflow/profiles/slurm`` (every job through
  ``sbatch``, its status through ``squeue``: no accounting database) and every HDF5 result equals the local run's,
  byte for byte, costs and provenance aside (tests/h5content.py); both runs use the same thread counts.
- A cluster job cancelled (``scancel``) while it writes its result leaves nothing under the result's name, only the
  hidden temporary file, and the next job that writes the result removes it and commits a whole file.

Skipped, with the reason, only where Slurm cannot be installed (no root or no apt-get) or a real Slurm configuration
is already in place; a daemon that fails to start fails the test with its log.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from h5content import differences, h5_results
from slurm_cluster import SlurmCluster, slurm_available

from porepipe._shared.atomic import temporary_path
from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import read_attrs, read_volume

pytestmark = [pytest.mark.slurm, pytest.mark.slow, pytest.mark.serial]

ROOT = Path(__file__).resolve().parents[2]
MINI = ROOT / "config" / "scenes" / "mini.yaml"


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    reason = slurm_available()
    if reason:
        pytest.skip(reason)
    with SlurmCluster(tmp_path_factory.mktemp("slurm")) as running:
        yield running


def _threads(cluster) -> int:
    """Threads of both runs: the local run's --cores, the cluster run's --max-threads (the node has no more)."""
    return min(2, cluster.cpus)


def _run(cmd: list, cwd: Path, timeout_s: float = 900) -> subprocess.CompletedProcess:
    out = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True, timeout=timeout_s)
    assert out.returncode == 0, f"{' '.join(map(str, cmd[:4]))} …: {out.stderr[-4000:]}"
    return out


def _job_states() -> dict[str, str]:
    """Slurm job id -> state of every job (finished ones too: the test cluster keeps them for an hour, MinJobAge)."""
    out = subprocess.run(
        ["squeue", "--states=all", "--noheader", "--format=%i|%T"], capture_output=True, text=True, check=True
    )
    return dict(line.split("|") for line in out.stdout.split())


def test_mini_scene_on_slurm_equals_the_local_run(cluster, tmp_path, mini_local_run):
    slurm = tmp_path / "slurm"
    slurm.mkdir()
    threads = _threads(cluster)
    t0 = time.monotonic()
    local, done, cores = mini_local_run
    if threads == cores:  # the session's local run of the mini scene has the same thread counts
        assert done.returncode == 0, done.stderr[-3000:]
    else:
        local = tmp_path / "local"
        local.mkdir()
        _run([sys.executable, "-m", "porepipe.cli", "run", MINI, "--cores", threads], cwd=local)
    t1 = time.monotonic()
    out = _run(
        [
            sys.executable,
            "-m",
            "snakemake",
            "--snakefile",
            ROOT / "Snakefile",
            "--executor",
            "slurm",
            "--profile",
            ROOT / "workflow" / "profiles" / "slurm",
            "--config",
            f"scene={MINI}",
            "--max-threads",
            threads,
            # no accounting database here: ask squeue (MinJobAge keeps finished jobs), and ask early
            "--slurm-status-command",
            "squeue",
            "--slurm-init-seconds-before-status-checks",
            "2",
            # a one-node test cluster: poll every second, not every 10 s (each of the ~18 jobs waits for a poll)
            "--seconds-between-status-checks",
            "1",
        ],
        cwd=slurm,
    )
    print(f"\nmini scene: local {t1 - t0:.0f} s, Slurm {time.monotonic() - t1:.0f} s ({threads} threads)")

    submitted = re.findall(r"has been submitted with SLURM jobid (\d+)", out.stderr)
    planned = int(re.search(r"^total\s+(\d+)", out.stderr, flags=re.M).group(1))
    assert len(submitted) == planned - 1, out.stderr[-3000:]  # every job but the local target `all`
    states = _job_states()
    assert {states.get(job) for job in submitted} == {"COMPLETED"}, states

    want, got = h5_results(local), h5_results(slurm)
    assert sorted(got) == sorted(want)
    assert len(want) >= 15, sorted(want)  # pack, 3 x (voxelize, segment, minkowski, lpt), estimate, κ, sweep
    changed = {name: differences(want[name], got[name]) for name in want}
    changed = {name: keys for name, keys in changed.items() if keys}
    assert not changed, f"the Slurm run differs from the local run in {changed}"
    assert (slurm / "results" / "mini" / "report" / "index.html").is_file()


WRITER = """
import os, sys, time
import numpy as np
from porepipe._shared.store import ResultWriter
path, marker, pause = sys.argv[1], sys.argv[2], float(sys.argv[3])
with ResultWriter(path, stage="test") as w:
    d = w.create_volume("v", (64, 64, 64), np.uint8, voxel_um=1.0)
    d[:32] = 1
    w.h5.flush()
    open(marker, "w").write(f"{os.getpid()}\\n")
    time.sleep(pause)
    d[32:] = 1
"""


def _sbatch(script: Path, path: Path, marker: Path, pause_s: float) -> str:
    command = shlex.join([sys.executable, str(script), str(path), str(marker), str(pause_s)])
    out = subprocess.run(
        ["sbatch", "--parsable", "--job-name", "porepipe-kill-test", "-n1", "-c1", "--mem=500", "-t", "5"]
        + ["-o", str(path.parent / "job-%j.log"), "-D", str(path.parent), f"--wrap={command}"],
        capture_output=True,
        text=True,
        check=True,
    )
    return out.stdout.strip().split(";")[0]


def _wait_for(condition, what: str, timeout_s: float = 120) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"{what} within {timeout_s:g} s"
        time.sleep(0.2)


def _state(job: str) -> str:
    return _job_states().get(job, "")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_cluster_job_cancelled_mid_write_leaves_no_finished_looking_result(cluster, tmp_path):
    script = tmp_path / "writer.py"
    script.write_text(textwrap.dedent(WRITER))
    out_dir = tmp_path / "results"
    out_dir.mkdir()
    path, marker = out_dir / "r.h5", tmp_path / "writing"

    job = _sbatch(script, path, marker, pause_s=300)
    _wait_for(marker.exists, f"Slurm job {job} did not start writing")
    pid = int(marker.read_text())
    tmp = path.with_name(temporary_path(path).name.replace(f".{os.getpid()}.", f".{pid}."))  # the job's
    assert tmp.exists()  # the job is mid-write: half of the volume is in the hidden temporary file
    subprocess.run(
        ["scancel", job], check=True
    )  # SIGTERM, then SIGKILL after KillWait: what a time limit does
    _wait_for(lambda: _state(job) == "CANCELLED" and not _alive(pid), f"job {job} was not cancelled")

    assert (
        not path.exists()
    )  # nothing under the result's name: no rule, reader or rerun takes it for finished
    with pytest.raises(PorepipeError, match="does not exist"):
        read_attrs(path)
    assert [p.name for p in out_dir.iterdir() if p.suffix != ".log"] == [tmp.name]

    marker.unlink()
    rerun = _sbatch(script, path, marker, pause_s=0)
    _wait_for(lambda: _state(rerun) == "COMPLETED", f"rerun job {rerun} did not complete")
    volume, _ = read_volume(path, "v")
    assert volume.shape == (64, 64, 64) and (volume == 1).all()  # whole
    assert [p.name for p in out_dir.iterdir() if p.suffix != ".log"] == ["r.h5"]  # the leftover is gone
