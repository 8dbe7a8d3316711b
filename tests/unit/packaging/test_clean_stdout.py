"""A porepipe process writes nothing to its terminal that it did not print: no escape sequence at exit.

numba colours its error texts with colorama where colorama is installed; colorama then writes a terminal reset
(ESC[0m) to stdout when the process exits, if stdout is a terminal. mpirun gives each rank a pseudo-terminal, so
under mpirun that reset once landed inside the JSON row that the MPI benchmark's rank 0 printed (CI failed on it).
Needs colorama, as CI's environment has (the docs extra pulls it in).
"""

import os
import pty
import subprocess
import sys

import pytest

pytest.importorskip("colorama")

#: loads (or compiles) a kernel, which makes numba build its error texts and so start colorama
BODY = """
import numpy as np
from porepipe._shared.clusters import spanning_clusters
keep, n = spanning_clusters(np.ones((4, 4, 4), dtype=bool), 0)
print("spanning", n)
"""


def _terminal_output(args: list[str], env: dict) -> bytes:
    """What ``args`` writes to stdout when stdout is a pseudo-terminal (as under mpirun)."""
    leader, follower = pty.openpty()
    try:
        subprocess.run(args, stdout=follower, stderr=subprocess.DEVNULL, env=env, timeout=300, check=True)
    finally:
        os.close(follower)
    chunks = []
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # EIO: the terminal's other end is closed and everything has been read
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(leader)
    return b"".join(chunks)


def test_no_escape_on_a_terminal_at_exit():
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"}
    assert _terminal_output([sys.executable, "-c", BODY], env) == b"spanning 1\r\n"
