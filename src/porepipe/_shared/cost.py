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
