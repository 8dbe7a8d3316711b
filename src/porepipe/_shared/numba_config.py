"""Central numba switches: one fastmath flag for every kernel, and the thread count."""

from __future__ import annotations

import os

import numba

#: fastmath for every kernel; off by default so results are bit-reproducible across machines.
FASTMATH: bool = os.environ.get("POREPIPE_FASTMATH", "0") == "1"


def set_threads(threads: int | None) -> int:
    """Set numba's thread count (None = all available) and return the count in force."""
    if threads is None:
        threads = numba.config.NUMBA_NUM_THREADS
    threads = max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS))
    numba.set_num_threads(threads)
    return threads
