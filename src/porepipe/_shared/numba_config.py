"""Central numba switches: one fastmath flag for every kernel, the thread count, and kernels compiled per thread count."""

from __future__ import annotations

import os
import types

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


class ByThreads:
    """A ``prange`` kernel compiled from one Python function twice: ``parallel=True`` for calls while numba runs
    more than one thread, serial (``prange`` runs as ``range``) for calls on one thread.

    A serial compile costs about half as much as a parallel one (the mini scene's packing compiles in 9 CPU-s
    instead of 17), and a run on one thread never needs the parallel code. The kernel must give the same result
    for any thread count (fixed chunks, no thread-order sums): then both variants give the same bits. Each variant
    is compiled (and cached on disk, under its own name) on its first call; only calls from Python, not from other
    jitted code.
    """

    def __init__(self, py_func, **options):
        self.py_func = py_func
        self.parallel = numba.njit(parallel=True, **options)(py_func)
        self.serial = numba.njit(parallel=False, **options)(_renamed(py_func, "_serial"))
        self.__doc__ = py_func.__doc__

    def __call__(self, *args):
        return (self.parallel if numba.get_num_threads() > 1 else self.serial)(*args)


def by_threads(**options):
    """Decorator: :class:`ByThreads` with the ``numba.njit`` ``options`` (less ``parallel``)."""
    return lambda py_func: ByThreads(py_func, **options)


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
