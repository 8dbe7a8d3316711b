"""MPI LBM throughput: MLUPS of ``mpirun -n P`` slabs (P = 1, 2) next to the single-process kernel.

The porous 128³ sample of benchmarks/lbm.py (overlapping spheres, porosity ≈ 0.2, percolating pore nodes only),
TRT in float64, the periodic set-up along x. The single-process rows step the whole lattice with the kernel alone
(1 and 2 numba threads); the MPI rows run P ranks of one numba thread each, every rank stepping its slab (with its
two ghost layers) one step at a time and exchanging the crossing populations after each step, exactly as
``porepipe permeability --mpi`` does. MLUPS counts the owned pore nodes of all ranks per wall second of the slowest
rank, best of the repeats, between two barriers; "per CPU s" divides by the CPU seconds of all ranks together (a
rank waiting for its neighbour spins, and that counts). Ranks are not bound to cores (--bind-to none): on a shared
machine a bound rank cannot move away from a busy core. Ranks beyond the machine's cores only share them.

Usage: python benchmarks/lbm_mpi.py [--size 128] [--steps 20] [--out DIR] [--smoke]
Writes lbm_mpi_benchmark.json into --out (default: results/benchmarks/ of the checkout). Without mpirun or mpi4py
the MPI rows are skipped (said so), the single-process rows still run.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from _common import add_out_argument, write_record
from lbm import porous_sample, time_lattice

from porepipe.lbm import Settings
from porepipe.lbm._domain import periodic_setup

SETTINGS = Settings(collision="trt", precision="float64")


def _prepare(size: int, comm=None):
    build = {"build": comm.build} if comm is not None else {}
    return periodic_setup(
        porous_sample(size), mirror=False, lateral_periodic=True, prune=True, **build
    ).lattice


def worker(size: int, steps: int, repeats: int, row_file: str) -> None:
    """One rank: step its slab ``steps`` times per repeat; rank 0 writes the JSON row into ``row_file``.

    A file, not stdout: mpirun interleaves the ranks' output, and a library may write to stdout as a rank exits
    (numba's error highlighting via colorama writes a terminal reset at exit), which once landed inside the row.
    """
    from mpi4py import MPI

    from porepipe.lbm._mpi import Slabs
    from porepipe.lbm._solver import make_stepper

    comm = Slabs()
    lat = _prepare(size, comm)
    src = np.zeros(19 * lat.n_nodes)
    dst = np.zeros_like(src)
    step = comm.wrap(make_stepper(SETTINGS, lat))
    none = np.zeros((4, 0))
    step(src, dst, none, False, 2)  # compile / warm up
    best = cpu = float("inf")
    for _ in range(repeats):
        comm.comm.Barrier()
        t0, c0 = time.perf_counter(), time.process_time()
        step(src, dst, none, False, steps)
        best = min(best, comm.max(time.perf_counter() - t0))
        cpu = min(cpu, comm.sum(time.process_time() - c0))
    nodes = comm.n_nodes(lat)
    if comm.root:
        row = {"ranks": comm.size, "nodes": nodes, "slabs": comm.bounds.tolist()}
        row.update(mlups=nodes * steps / best / 1e6, mlups_cpu=nodes * steps / cpu / 1e6)
        Path(row_file).write_text(json.dumps(row))
    MPI.COMM_WORLD.Barrier()


def mpi_row(ranks: int, size: int, steps: int, repeats: int) -> dict | None:
    """The row of ``mpirun -n ranks`` (None, with a line saying why, where MPI is missing or the run fails)."""
    if shutil.which("mpirun") is None or importlib.util.find_spec("mpi4py") is None:
        print(
            f"P = {ranks}: skipped (needs mpirun and mpi4py: apt-get install openmpi-bin; pip install '.[mpi]')"
        )
        return None
    root = ["--allow-run-as-root"] if os.geteuid() == 0 else []
    cmd = [
        "mpirun",
        "-n",
        str(ranks),
        "--oversubscribe",
        "--bind-to",
        "none",
        *root,
        sys.executable,
        __file__,
    ]
    cmd += ["--worker", "--size", str(size), "--steps", str(steps), "--repeats", str(repeats)]
    env = dict(
        os.environ, NUMBA_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1"
    )
    with tempfile.TemporaryDirectory() as tmp:
        row_file = Path(tmp) / "row.json"
        cmd += ["--row-file", str(row_file)]
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600, check=False)
        if done.returncode != 0 or not row_file.is_file():
            print(f"P = {ranks}: failed ({done.returncode}): {done.stderr.strip()[-500:]}")
            return None
        return json.loads(row_file.read_text())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--row-file", help=argparse.SUPPRESS)
    add_out_argument(p)
    p.add_argument("--smoke", action="store_true", help="24^3, 2 steps (CI smoke; no figures to quote)")
    args = p.parse_args(argv)
    if args.smoke:
        args.size, args.steps, args.repeats = 24, 2, 1
    if args.worker:
        worker(args.size, args.steps, args.repeats, args.row_file)
        return 0
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores", flush=True)
    lat = _prepare(args.size)
    rows = []
    for threads in range(1, min(2, numba.config.NUMBA_NUM_THREADS) + 1):
        mlups, cpu = time_lattice(lat, "trt", "float64", threads, args.steps, args.repeats)
        rows.append(
            {"kind": "kernel", "threads": threads, "nodes": lat.n_nodes, "mlups": mlups, "mlups_cpu": cpu}
        )
        print(f"single process, kernel only, {threads} thread(s): {mlups:.1f} MLUPS ({cpu:.1f} per CPU s)")
    for ranks in (1, 2):
        row = mpi_row(ranks, args.size, args.steps, args.repeats)
        if row is not None:
            rows.append({"kind": "mpi", "threads": 1, **row})
            print(
                f"mpirun -n {ranks}, 1 thread per rank, slabs {row['slabs']}: {row['mlups']:.1f} MLUPS "
                f"({row['mlups_cpu']:.1f} per CPU s)",
                flush=True,
            )
    record = {"size": args.size, "steps": args.steps, "load": os.getloadavg()[0], "rows": rows}
    write_record(args.out, "lbm_mpi_benchmark.json", record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
