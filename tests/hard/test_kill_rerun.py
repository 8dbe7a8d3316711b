"""Kill-and-rerun: SIGKILL the whole workflow (its process group) at several points, rerun, and get the same results.

A reduced mini scene (tests/hard/data/tiny: 40 spheres packed for 60 steps with a checkpoint every 15, one
resolution of 4 µm, segment + estimate + minkowski) runs once uninterrupted; a second directory is killed
- while the packing engine runs (as soon as its first checkpoint exists, so the rerun resumes from it),
- just after packing.h5 is committed (voxelize is starting),
- just after the first binary volume is committed (the next jobs are starting),
and rerun after each kill (``porepipe run --unlock``, then ``porepipe run``). Truth: every result array and every
attribute but the timings is bit-identical to the uninterrupted run, and no temporary or checkpoint file is left.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from h5content import differences, h5_results

DATA = Path(__file__).parent / "data" / "tiny"
KILL_POINTS = ("pack checkpoint", "packing.h5 written", "first binary written")


def _scene(tmp_path: Path) -> Path:
    tree = yaml.safe_load((DATA / "tiny.yaml").read_text())
    tree["analyses"] = ["segment", "estimate", "minkowski"]
    tree["resolutions_um"] = [4]
    tree["packing"]["checkpoint_every"] = 15
    for key in ("permeability", "diffusion"):
        tree.pop(key)
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(tree))
    return path


def _env() -> dict:
    env = dict(os.environ)
    env["PATH"] = (
        f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"  # the rules call `porepipe`
    )
    return env


def _porepipe(args: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "porepipe.cli", *args],
        cwd=cwd,
        env=_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group: the kill reaches Snakemake and every job
    )


def _unlock(scene: Path, cwd: Path) -> None:
    subprocess.run(
        [sys.executable, "-m", "porepipe.cli", "run", str(scene), "--unlock"],
        cwd=cwd,
        env=_env(),
        capture_output=True,
        check=True,
    )


def _run(scene: Path, cwd: Path) -> None:
    _unlock(scene, cwd)
    proc = _porepipe(["run", str(scene), "--cores", "1"], cwd)
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err[-3000:]


def _run_until(scene: Path, cwd: Path, ready) -> bool:
    """Start the workflow, SIGKILL its process group once ``ready()`` holds; False if it finished first."""
    _unlock(scene, cwd)
    proc = _porepipe(["run", str(scene), "--cores", "1"], cwd)
    deadline = time.monotonic() + 600
    while proc.poll() is None and time.monotonic() < deadline:
        if ready():
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            return True
        time.sleep(0.01)
    proc.communicate()
    return False


@pytest.mark.slow
def test_killed_workflow_reruns_to_bit_identical_results(tmp_path):
    scene = _scene(tmp_path)
    reference, killed = tmp_path / "reference", tmp_path / "killed"
    reference.mkdir()
    killed.mkdir()
    _run(scene, reference)

    pack_dir = killed / "results" / "tiny" / "pack"
    ready = {
        "pack checkpoint": lambda: (pack_dir / "checkpoint.h5").exists(),
        "packing.h5 written": lambda: (pack_dir / "packing.h5").exists(),
        "first binary written": lambda: any((killed / "results").rglob("binary_a*.h5")),
    }
    killed_at = [point for point in KILL_POINTS if _run_until(scene, killed, ready[point])]
    _run(scene, killed)  # the final rerun completes
    print(f"\nkill-and-rerun: killed at {killed_at} of {list(KILL_POINTS)}")
    assert len(killed_at) >= 2, f"the workflow finished before most kill points: {killed_at}"

    want, got = h5_results(reference), h5_results(killed)
    assert sorted(got) == sorted(want)
    for name in want:
        changed = differences(want[name], got[name])
        assert not changed, f"{name}: {changed} differ from the uninterrupted run"
    leftovers = [
        p
        for p in (killed / "results").rglob("*")
        if p.name.endswith(".tmp") or p.name.startswith("checkpoint")
    ]
    assert not leftovers, leftovers
