"""Progress lines for long loops, written to stderr at most every ``every_s`` seconds."""

from __future__ import annotations

import sys
import time


class Progress:
    """Rate-limited progress reporter.

    Parameters
    ----------
    label : str
        What is being done, e.g. ``"lbm z"``.
    total : int
        Number of units of work (steps, slabs); 0 if unknown.
    every_s : float
        Minimum wall seconds between two lines.
    """

    def __init__(self, label: str, total: int = 0, every_s: float = 5.0, stream=None):
        self.label = label
        self.total = total
        self.every_s = every_s
        self.stream = stream if stream is not None else sys.stderr
        self.t0 = time.perf_counter()
        self._last = -1e300

    def update(self, done: int, message: str = "", force: bool = False) -> None:
        now = time.perf_counter()
        if not force and now - self._last < self.every_s:
            return
        self._last = now
        elapsed = now - self.t0
        frac = f"{done}/{self.total}" if self.total else f"{done}"
        eta = ""
        if self.total and done:
            eta = f", eta {elapsed * (self.total - done) / done:.1f} s"
        print(
            f"[{self.label}] {frac} ({elapsed:.1f} s{eta}) {message}".rstrip(), file=self.stream, flush=True
        )
