"""Scene key permeability.mpi_ranks: the permeability job becomes an MPI job (Snakemake's `tasks`/`mpi` resources)."""

import subprocess
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]


def _dry_run(tmp_path, permeability: dict) -> str:
    scene = yaml.safe_load((ROOT / "config" / "scenes" / "mini.yaml").read_text())
    scene["permeability"].update(permeability)
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(scene))
    out = subprocess.run(
        [sys.executable, "-m", "porepipe.cli", "run", str(path), "--cores", "4", "-n"],
        cwd=tmp_path,
        capture_output=True,
        check=False,
        text=True,
    )
    assert out.returncode == 0, out.stderr + out.stdout
    return " ".join(out.stdout.split())  # the shell command spans lines


def test_mpi_ranks_launch_the_permeability_job_under_mpirun(tmp_path):
    text = _dry_run(tmp_path, {"mpi_ranks": 2, "walls": "halfway"})
    assert "mpirun -n 2 porepipe permeability" in text
    # the mini volume earns one thread (threads_by_volume), but an MPI job takes a core per rank: 2 cores, 1 per rank
    assert "--threads 1 --mpi" in text and "cpus_per_task=1" in text
    assert "tasks=2" in text and "mpi=mpirun" in text  # the resources an executor (slurm: --ntasks) reads


def test_without_mpi_ranks_the_job_runs_in_one_process(tmp_path):
    text = _dry_run(tmp_path, {})
    assert "porepipe permeability" in text and "mpirun" not in text and "--mpi" not in text
