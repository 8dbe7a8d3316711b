"""The one atomic file write: a hidden temporary name beside the target, fsync, then rename.

A reader (Snakemake, :func:`porepipe._shared.store.read_attrs`, a resumed run) sees either the old file or the
complete new one, never a half-written file under the final name: the data are flushed to disk (``fsync``) before the
rename, and the directory entry after it. On an exception the temporary file is removed; a process killed outright
(SIGKILL, power loss) can leave only the hidden ``.<name>.<pid>.tmp``, which no rule takes for a result.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "commit", "temporary_path", "write_text_atomic"]


def temporary_path(path) -> Path:
    """The hidden temporary name beside ``path`` that this process writes before :func:`commit`."""
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _fsync(path: Path, *, directory: bool = False) -> None:
    fd = os.open(path, os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0))
    try:
        os.fsync(fd)
    except OSError:
        if not directory:  # some file systems cannot fsync a directory; the rename is still atomic there
            raise
    finally:
        os.close(fd)


def commit(tmp, path) -> Path:
    """Flush the finished temporary file ``tmp`` to disk and rename it onto ``path`` (then flush the directory)."""
    tmp, path = Path(tmp), Path(path)
    _fsync(tmp)
    os.replace(tmp, path)
    _fsync(path.parent, directory=True)
    return path


@contextlib.contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Context manager: yields a temporary path to write ``path``'s content to; commits it when the block succeeds.

    Parameters
    ----------
    path : path-like
        The final file name; its directory is created.

    Yields
    ------
    pathlib.Path
        The hidden temporary name beside ``path``; write and close the file inside the block.

    Examples
    --------
    >>> with atomic_path("table.csv") as tmp:  # doctest: +SKIP
    ...     tmp.write_text(text)
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temporary_path(path)
    try:
        yield tmp
        commit(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_text_atomic(path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding=encoding)
    return Path(path)
