"""Every benchmark script runs in its small smoke configuration (CI does not time them), and writes its records only
where the rule says: under ``results/benchmarks/`` (git-ignored) or ``--out`` — never into the source tree, and
nothing is left in the working directory."""

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
BENCHMARKS = sorted(
    p for p in (ROOT / "benchmarks").glob("*.py") if not p.name.startswith("_")
)  # _common.py etc. are helpers, not benchmarks
#: folders of the checkout that are not source: run outputs, caches, environments (see .gitignore)
NOT_SOURCE = {"results", "__pycache__", "site", "build", "dist", "_workflow"}


def _source_files() -> set[Path]:
    """Files of the checkout outside the git-ignored output and cache folders (and outside dot-folders)."""
    return {
        p.relative_to(ROOT)
        for p in ROOT.rglob("*")
        if p.is_file()
        and not any(
            part.startswith(".") or part in NOT_SOURCE or part.endswith(".egg-info")
            for part in p.relative_to(ROOT).parts[:-1]
        )
    }


@pytest.mark.parametrize("script", BENCHMARKS, ids=lambda p: p.stem)
def test_benchmark_smoke(script, tmp_path):
    before = _source_files()
    out = subprocess.run(
        [sys.executable, str(script), "--smoke"], cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip(), "a benchmark must print its figures"
    assert "results/benchmarks" in out.stdout, (
        "a benchmark writes its record under results/benchmarks/ (or --out)"
    )
    new = sorted(str(p) for p in _source_files() - before)
    assert not new, f"{script.name} wrote into the source tree: {new}"
    assert not list(tmp_path.iterdir()), f"{script.name} left files in its working directory"
