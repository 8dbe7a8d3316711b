"""Fixtures shared by the workflow tests."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MINI = ROOT / "config" / "scenes" / "mini.yaml"
MINI_CORES = 2


@pytest.fixture(scope="session")
def mini_local_run(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess, int]:
    """One local ``porepipe run`` of the mini scene on ``MINI_CORES`` cores, shared by the tests that check a local
    run (the end-to-end test) or compare against one (the Slurm test): (working directory, finished process, cores).
    """
    cwd = tmp_path_factory.mktemp("mini-local")
    out = subprocess.run(
        [sys.executable, "-m", "porepipe.cli", "run", str(MINI), "--cores", str(MINI_CORES)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=900,
    )
    return cwd, out, MINI_CORES
