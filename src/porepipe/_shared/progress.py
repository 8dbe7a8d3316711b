"""Progress of long jobs: a tqdm bar on a terminal, sparse lines elsewhere, an ETA from the convergence rate.

Where the lines go:

- a terminal (stderr is a TTY, no ``CI`` variable): one tqdm bar per loop, its ETA ours (below), not tqdm's;
- anything else (a log file, CI): one plain line at most every ``every_s`` seconds;
- under ``porepipe run`` the jobs' stderr goes to log files, so ``porepipe run`` names its terminal in
  ``POREPIPE_CONSOLE`` and every job also writes a line there at most every 10 s (jobs run in parallel, so lines,
  not bars), plus the closing line.

The ETA comes from how fast the stop criterion approaches its target, not from the step limit: a residual that
decays exponentially (LBM's κ error, the unconverged spheres of a packing) is extrapolated along the slope of its
logarithm; a statistical error (Monte Carlo) along 1/√n. Kernel compilation (numba, first run only) is announced once
("compiling kernels (first run only)") and its time is kept out of the rate and shown apart in the closing line.
"""

from __future__ import annotations

import math
import os
import sys
import time

#: environment variable: a file (the terminal of ``porepipe run``) that also gets sparse progress lines
CONSOLE_ENV = "POREPIPE_CONSOLE"
#: seconds between two lines on the console of ``porepipe run``
CONSOLE_EVERY_S = 10.0

_compile = {"seconds": 0.0, "depth": 0, "t0": 0.0, "real": False, "announced": False, "kernels": 0}
_watching = False


def compile_seconds() -> float:
    """Wall seconds spent compiling numba kernels in this process so far (cache loads do not count)."""
    return _compile["seconds"]


def compiled_kernels() -> int:
    """How many numba kernels this process compiled (not loaded from the cache)."""
    return _compile["kernels"]


def _say(text: str) -> None:
    for stream in _streams():
        print(text, file=stream, flush=True)


def notice(text: str) -> None:
    """One line about the run's input that is accepted but worth knowing, on stderr (and the console of
    ``porepipe run``), prefixed ``porepipe:``; for a bad input raise a :class:`PorepipeError` instead.
    """
    _say(f"porepipe: {text}")


def watch_compilation() -> None:
    """Announce numba compilation once per process and time it (numba's compile events); idempotent."""
    global _watching
    if _watching:
        return
    from numba.core import event

    class _Compile(event.Listener):
        def on_start(self, ev):
            if _compile["depth"] == 0:
                _compile["t0"], _compile["real"] = time.perf_counter(), False
            _compile["depth"] += 1

        def on_end(self, ev):
            _compile["depth"] -= 1
            if _compile["depth"] == 0 and _compile["real"]:
                _compile["seconds"] += time.perf_counter() - _compile["t0"]
                _compile["kernels"] += 1

    class _Pass(
        event.Listener
    ):  # compiler passes run only when a kernel really compiles (not on a cache hit)
        def on_start(self, ev):
            _compile["real"] = True
            if not _compile["announced"]:
                _compile["announced"] = True
                _say("porepipe: compiling kernels (first run only; later runs load them from the cache) ...")

        def on_end(self, ev):
            pass

    event.register("numba:compile", _Compile())
    event.register("numba:run_pass", _Pass())
    _watching = True


def _interactive(stream) -> bool:
    return not os.environ.get("CI") and hasattr(stream, "isatty") and stream.isatty()


_console_stream = None


def _console():
    """The terminal of ``porepipe run`` when this process is one of its jobs (else None)."""
    global _console_stream
    path = os.environ.get(CONSOLE_ENV)
    if not path or os.environ.get("CI"):
        return None
    if _console_stream is None:
        try:
            _console_stream = open(path, "a", buffering=1)  # noqa: SIM115 - kept open for the process's life
        except OSError:
            return None
    return _console_stream


def _streams() -> list:
    console = _console()
    return [sys.stderr] if console is None else [sys.stderr, console]


def _duration(seconds: float) -> str:
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


class Progress:
    """Progress of one long loop: a tqdm bar on a terminal, else rate-limited lines; a convergence-based ETA.

    Parameters
    ----------
    label : str
        What is being done, e.g. ``"lbm z"``.
    total : int
        Units of work (steps, slabs) at most; 0 if unknown. With ``target`` it is only the limit, not the ETA.
    every_s : float
        Minimum wall seconds between two lines (not on a terminal bar).
    stream : file, optional
        Where the bar or lines go (default stderr).
    target : float, optional
        The value the residual passed to :meth:`update` must reach to stop (e.g. the κ tolerance); enables the ETA
        from the convergence rate.
    convergence : {"exponential", "statistical"}
        How the residual approaches ``target``: geometrically (iterative solvers) or as 1/√n (Monte Carlo).
    """

    def __init__(
        self,
        label: str,
        total: int = 0,
        every_s: float = 5.0,
        stream=None,
        *,
        target: float | None = None,
        convergence: str = "exponential",
    ):
        self.label = label
        self.total = total
        self.every_s = every_s
        self.stream = stream if stream is not None else sys.stderr
        self.target = target
        self.convergence = convergence
        self.t0 = time.perf_counter()
        self._compile0 = compile_seconds()
        self._last = -1e300
        self._last_console = time.perf_counter()
        self._samples: list[tuple[float, float]] = []
        self._done = 0
        self._bar = None
        if _interactive(self.stream) and _console() is None:
            from tqdm import tqdm

            self._bar = tqdm(
                total=total or None,
                desc=label,
                file=self.stream,
                bar_format="{desc}: {n_fmt}/{total_fmt} [{elapsed}] {postfix}",
                mininterval=0.5,
                leave=True,
            )

    def compute_s(self) -> float:
        """Wall seconds since the start, less the time spent compiling kernels meanwhile."""
        return time.perf_counter() - self.t0 - (compile_seconds() - self._compile0)

    def eta_s(self) -> float | None:
        """Seconds until the residual reaches ``target`` at the rate seen so far; None while unknown."""
        if self.target is None:
            if self.total and self._done:
                return self.compute_s() * (self.total - self._done) / self._done
            return None
        good = [(t, r) for t, r in self._samples if math.isfinite(r) and r > 0]
        if not good or self.target <= 0:
            return None
        t_now, r_now = good[-1]
        if r_now <= self.target:
            return 0.0
        if self.convergence == "statistical":
            return t_now * ((r_now / self.target) ** 2 - 1.0)
        recent = good[-8:]
        if len(recent) < 2 or recent[-1][0] <= recent[0][0]:
            return None
        ts = [t for t, _ in recent]
        logs = [math.log(r) for _, r in recent]
        t_mean, l_mean = sum(ts) / len(ts), sum(logs) / len(logs)
        slope = sum((t - t_mean) * (lg - l_mean) for t, lg in zip(ts, logs)) / sum(
            (t - t_mean) ** 2 for t in ts
        )
        if slope >= 0:
            return None  # not converging (yet): no honest ETA
        return (math.log(self.target) - math.log(r_now)) / slope

    def _eta_text(self) -> str:
        eta = self.eta_s()
        if eta is None:
            return ""
        limit = ""
        if self.target is not None and self.total and self._samples:
            rate = self._done / max(self.compute_s(), 1e-9)
            if rate > 0 and self.compute_s() + eta > self.total / rate:
                limit = " (beyond the step limit)"
        return f"eta {_duration(eta)}{limit}"

    def update(
        self, done: int, message: str = "", force: bool = False, residual: float | None = None
    ) -> None:
        """Record ``done`` units (and the stop criterion's ``residual``) and show them when it is time."""
        self._done = done
        if residual is not None:
            self._samples.append((self.compute_s(), float(residual)))
        now = time.perf_counter()
        if self._bar is not None:
            self._bar.n = done
            self._bar.set_postfix_str(" ".join(p for p in (self._eta_text(), message) if p), refresh=False)
            if force:
                self._bar.refresh()
            else:
                self._bar.update(0)
        elif force or now - self._last >= self.every_s:
            self._last = now
            self._line(self.stream, done, message)
        console = _console()
        if console is not None and (force or now - self._last_console >= CONSOLE_EVERY_S):
            self._last_console = now
            self._line(console, done, message)

    def _line(self, stream, done: int, message: str) -> None:
        frac = f"{done}/{self.total}" if self.total else f"{done}"
        parts = [f"{self.compute_s():.1f} s", self._eta_text()]
        print(
            f"[{self.label}] {frac} ({', '.join(p for p in parts if p)}) {message}".rstrip(),
            file=stream,
            flush=True,
        )

    def close(self, summary: str = "") -> None:
        """End the bar and write the closing line: what happened, the time, and the compile time apart."""
        if self._bar is not None:
            self._bar.close()
        compiled = compile_seconds() - self._compile0
        took = f"{_duration(self.compute_s())}" + (
            f" + {_duration(compiled)} compiling kernels" if compiled > 0.5 else ""
        )
        line = f"[{self.label}] done in {took}" + (f": {summary}" if summary else "")
        for stream in {id(s): s for s in (self.stream, _console()) if s is not None}.values():
            print(line, file=stream, flush=True)
