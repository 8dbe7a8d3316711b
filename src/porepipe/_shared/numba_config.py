"""Central numba switches: one fastmath flag for every kernel, the thread count, and kernels compiled per thread count."""

from __future__ import annotations

import os
import types

import numba
import numpy as np

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
