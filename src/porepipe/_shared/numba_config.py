"""Central numba switches: one fastmath flag for every kernel, the thread count, and kernels compiled per thread count."""

from __future__ import annotations

import os
import time
import types

import numba
import numpy as np

from porepipe._shared import numba_cache

# before any kernel is defined: every module with kernels imports this one first
numba_cache.install()

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
    threads = _thread_count(threads)
    numba.set_num_threads(threads)
    return threads


def _thread_count(threads: int | None) -> int:
    """The thread count :func:`set_threads` sets for ``threads`` (without starting numba's thread pool)."""
    if threads is None:
        threads = numba.config.NUMBA_NUM_THREADS
    return max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS))


#: spins a GNU OpenMP thread makes at a barrier before it sleeps, where every thread has an idle core: the granular
#: pile (N = 10^4, 2 threads, idle machine) ran 1.07x faster with it than with passive waiting, and 1.03x faster
#: than with 5000 spins
IDLE_SPINCOUNT: int = 20000

#: seconds over which :func:`openmp_wait_for_idle_cores` counts the machine's idle cores
IDLE_SAMPLE_S: float = 0.2


def idle_cores(sample_s: float = IDLE_SAMPLE_S) -> float | None:
    """Cores the machine left idle over the next ``sample_s`` seconds (from ``/proc/stat``); None where unknown."""
    try:
        before = _cpu_times()
        time.sleep(sample_s)
        after = _cpu_times()
    except (OSError, ValueError, IndexError):
        return None
    total = sum(after) - sum(before)
    idle = (after[3] + after[4]) - (before[3] + before[4])
    return None if total <= 0 else (os.cpu_count() or 1) * idle / total


def _cpu_times() -> list[int]:
    with open("/proc/stat") as stat:
        return [int(x) for x in stat.readline().split()[1:]]


def openmp_wait_for_idle_cores(threads: int | None) -> str:
    """Choose how GNU OpenMP threads wait at barriers for a run on ``threads`` threads (None = all), before numba
    starts its thread pool (:func:`set_threads` starts it); return the choice.

    Spinning briefly (``GOMP_SPINCOUNT`` = :data:`IDLE_SPINCOUNT`) where the machine has an idle core for every
    thread; passive waiting otherwise, because a spinning thread takes the core the thread it waits for needs
    (the granular pile on 2 threads beside one busy process: 0.76-0.85x of passive waiting; GNU OpenMP's default,
    spinning ~3 ms, 0.2x). The choice holds for the whole process. A user's ``OMP_WAIT_POLICY`` or
    ``GOMP_SPINCOUNT`` is kept as it is (``"user"``).
    """
    if "OMP_WAIT_POLICY" in os.environ or "GOMP_SPINCOUNT" in os.environ:
        return "user"
    threads = _thread_count(threads)
    free = idle_cores() if threads > 1 else None
    if free is not None and free >= threads - 0.25:
        os.environ["GOMP_SPINCOUNT"] = str(IDLE_SPINCOUNT)
        return f"spin {IDLE_SPINCOUNT}"
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"
    return "passive"


#: default largest array argument (elements) for which a one-thread call runs the serial variant of a
#: :class:`ByThreads` kernel; above it the parallel variant runs even on one thread (its code can be faster)
SERIAL_MAX_ELEMENTS: int = 2**17


class ByThreads:
    """A ``prange`` kernel compiled from one Python function twice: ``parallel=True``, and serial (``prange`` runs as
    ``range``) for small calls on one thread.

    A serial compile costs about half as much as a parallel one (the mini scene's packing: 9 CPU-s instead of 17),
    but the parallel variant's code can be faster even on one thread (the packing step on 2·10^5 spheres: 2.2x; the
    LBM step on the mini scene's 25³: the same), so the serial one runs only where compiling dominates: one thread
    and no array argument over ``serial_max_elements`` elements. The kernel must give the same result for any thread count (fixed chunks,
    no thread-order sums): then both variants give the same bits. Each variant is compiled (and cached on disk,
    under its own name) on its first call; only calls from Python, not from other jitted code.
    """

    def __init__(self, py_func, serial_max_elements: int = SERIAL_MAX_ELEMENTS, **options):
        self.py_func = py_func
        self.serial_max_elements = serial_max_elements
        self.parallel = numba.njit(parallel=True, **options)(py_func)
        self.serial = numba.njit(parallel=False, **options)(_renamed(py_func, "_serial"))
        self.__doc__ = py_func.__doc__

    def pick(self, *args):
        """The variant a call with ``args`` runs."""
        if numba.get_num_threads() > 1:
            return self.parallel
        largest = max((a.size for a in args if isinstance(a, np.ndarray)), default=0)
        return self.serial if largest <= self.serial_max_elements else self.parallel

    def __call__(self, *args):
        return self.pick(*args)(*args)


def by_threads(serial_max_elements: int = SERIAL_MAX_ELEMENTS, **options):
    """Decorator: :class:`ByThreads` with the ``numba.njit`` ``options`` (less ``parallel``)."""
    return lambda py_func: ByThreads(py_func, serial_max_elements, **options)


def _renamed(py_func, suffix: str):
    """A copy of ``py_func`` whose qualified name ends in ``suffix``: numba's disk cache names its files after the
    qualified name (not after the compile options), so each variant needs its own name to keep its own cache.
    """
    twin = types.FunctionType(
        py_func.__code__,
        py_func.__globals__,
        py_func.__name__ + suffix,
        py_func.__defaults__,
        py_func.__closure__,
    )
    twin.__qualname__ = py_func.__qualname__ + suffix
    twin.__module__ = py_func.__module__
    twin.__doc__ = py_func.__doc__
    return twin
