"""Where a process's start-up ends and its computation begins (light: imported by the command line itself)."""

from __future__ import annotations

import importlib
import importlib.util
import time

#: (perf_counter, process_time, start-up s) when this process's start-up ended (:func:`mark_compute_start`)
COMPUTE_MARK: list[tuple[float, float, float]] = []


def _load_stage(command) -> None:
    """Import the ``_run`` module of the stage whose subcommand ``command`` (a function of its ``_cli``) is."""
    package = getattr(command, "__module__", "").rpartition(".")[0]
    if package.startswith("porepipe.") and importlib.util.find_spec(f"{package}._run") is not None:
        importlib.import_module(f"{package}._run")


def mark_compute_start(command=None) -> float:
    """Mark the end of this process's start-up; the next result's cost is counted from here.

    The ``porepipe`` command calls it once its arguments are parsed, with the subcommand's function: the stage's
    ``_run`` module (and with it NumPy, xarray, numba …) is imported first, as part of the start-up. So a result file's ``wall_s`` and ``cpu_s``
    hold the whole computation (reading inputs, compiling kernels on a first run, computing, writing) even where a
    stage computes before it opens its :class:`porepipe._shared.store.ResultWriter`, and ``startup_s`` holds what came before: interpreter
    start-up and the command's imports (Snakemake's benchmark of the job holds both).

    Parameters
    ----------
    command : callable, optional
        The subcommand's function (``args.func``); None imports nothing.

    Returns
    -------
    float
        Seconds from the creation of this process to now (NaN where the creation time is unknown).
    """
    _load_stage(command)
    try:
        import psutil

        startup = time.time() - psutil.Process().create_time()
    except (ImportError, OSError):
        startup = float("nan")
    COMPUTE_MARK[:] = [(time.perf_counter(), time.process_time(), startup)]
    return startup


#: the checkpoint attributes that record what a resumable computation has spent up to it (:class:`SpentClock`)
SPENT_ATTRS = ("spent_wall_s", "spent_cpu_s")


class SpentClock:
    """What a resumable computation has spent, its earlier processes included: ``carried`` (wall s, CPU s), what the
    checkpoint it resumed from recorded (:func:`carried_by`; NaN where that checkpoint predates the record), plus
    this process's time since the clock was made. A checkpoint stores :meth:`spent` (:meth:`record`); the result's
    writer adds ``carried`` to its ``wall_s``/``cpu_s`` (:attr:`porepipe._shared.store.ResultWriter.carried`).
    """

    def __init__(self, carried: tuple[float, float] = (0.0, 0.0)):
        self.carried = (float(carried[0]), float(carried[1]))
        self._t0, self._c0 = time.perf_counter(), time.process_time()

    def spent(self) -> tuple[float, float]:
        """(wall s, CPU s) spent so far, earlier processes included."""
        wall, cpu = time.perf_counter() - self._t0, time.process_time() - self._c0
        return self.carried[0] + wall, self.carried[1] + cpu

    def record(self, attrs) -> None:
        """Write :meth:`spent` into a checkpoint's ``attrs`` (HDF5 attributes, or a dict of ``np.savez`` arrays)."""
        attrs[SPENT_ATTRS[0]], attrs[SPENT_ATTRS[1]] = self.spent()


def carried_by(attrs) -> tuple[float, float]:
    """(wall s, CPU s) that a checkpoint's ``attrs`` (HDF5 attributes or an ``np.load`` archive) record as spent up
    to it; NaN for a checkpoint written before they were recorded.
    """
    return tuple(float(attrs[k]) if k in attrs else float("nan") for k in SPENT_ATTRS)
