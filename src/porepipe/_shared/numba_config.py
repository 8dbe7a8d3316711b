"""Central numba switches: one fastmath flag for every kernel, and the thread count."""

from __future__ import annotations

import os

import numba

#: fastmath for every kernel; off by default so results are bit-reproducible across machines.
FASTMATH: bool = os.environ.get("POREPIPE_FASTMATH", "0") == "1"

#: compile option for hot helpers that only index arrays their caller owns (no allocation, no array returned, no
#: array views kept): numba's ``_nrt=False`` builds them without reference counting. With it on, every call pays
#: an atomic increment and decrement per array argument (and per array unpacked from a tuple argument), which
#: profiled as a third of the EDMD event loop and shared cache lines between threads in parallel pair loops.
#: The option is numba's own but private (``numba.core.cpu.CPUTargetOptions``); the kernels' tests exercise
#: every helper compiled with it.
NO_REFCOUNT: dict = {"_nrt": False}


def set_threads(threads: int | None) -> int:
    """Set numba's thread count (None = all available) and return the count in force."""
    if threads is None:
        threads = numba.config.NUMBA_NUM_THREADS
    threads = max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS))
    numba.set_num_threads(threads)
    return threads
