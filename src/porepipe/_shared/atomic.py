"""The one atomic file write: a hidden temporary name beside the target, fsync, then rename.

A reader (Snakemake, :func:`porepipe._shared.store.read_attrs`, a resumed run) sees either the old file or the
complete new one, never a half-written file under the final name: the data are flushed to disk (``fsync``) before the
rename, and the directory entry after it. On an exception the temporary file is removed; a process killed outright
(SIGKILL, power loss) can leave only the hidden ``.<name>.<pid>.tmp``, which no rule takes for a result.
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Iterator
from pathlib import Path

from porepipe._shared.errors import PorepipeError

__all__ = [
    "atomic_path",
    "check_identity",
    "check_output_dir",
    "commit",
    "file_identity",
    "prepare_output",
    "remove_stale_temporaries",
    "temporary_path",
    "write_text_atomic",
]


def temporary_path(path) -> Path:
    """The hidden temporary name beside ``path`` that this process writes before :func:`commit`."""
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's live process
    return True


def remove_stale_temporaries(path) -> list[Path]:
    """Delete the ``.<name>.<pid>.tmp`` files beside ``path`` whose process is gone (a killed job's leftovers).

    A live writer's temporary file (its process still exists) is left alone. Returns the files removed.
    """
    path = Path(path)
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.(\d+)\.tmp$")
    removed = []
    try:
        candidates = list(path.parent.iterdir())
    except OSError:
        return removed
    for candidate in candidates:
        match = pattern.match(candidate.name)
        if match and int(match.group(1)) != os.getpid() and not _alive(int(match.group(1))):
            candidate.unlink(missing_ok=True)
            removed.append(candidate)
    return removed


def prepare_output(path) -> Path:
    """Check an output name before any work is done: create its directory, refuse what cannot be written.

    Refuses (one :class:`PorepipeError` naming the path) an existing directory under the output name, a file in the
    way of the directory, and a directory this process cannot write; removes temporaries of killed earlier runs.
    Called by the CLI for ``-o`` before computing, so a long run never fails at its end for want of a directory.
    """
    path = Path(path)
    if path.is_dir():
        raise PorepipeError(f"output {path} is a directory; give a file name (e.g. {path / 'result.h5'})")
    try:
        prepare_output_dir(path.parent)
    except PorepipeError as err:
        raise PorepipeError(f"output {path}: {err}") from None
    remove_stale_temporaries(path)
    return path


def prepare_output_dir(directory) -> Path:
    """Check an output folder before any work is done: create it, refuse a file in the way or an unwritable folder.

    Parameters
    ----------
    directory : path-like
        The folder results will be written into (e.g. ``permeability --out-dir``).

    Returns
    -------
    Path
        The folder, which exists afterwards.
    """
    directory = Path(directory)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise PorepipeError(
            f"output folder {directory}: a file is in the way ({_first_file(directory)})"
        ) from None
    except OSError as err:
        raise PorepipeError(f"output folder {directory}: cannot create it: {err.strerror}") from None
    if not directory.is_dir():
        raise PorepipeError(f"output folder {directory} is a file, not a directory")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise PorepipeError(f"output folder {directory} is not writable")
    return directory


def check_output_dir(directory) -> None:
    """Check, without creating anything, that ``directory`` can be made or written: no file in its way, and its
    deepest existing folder writable (a read-only mount included).

    Parameters
    ----------
    directory : path-like
        A folder results will be written into, existing or not.

    Raises
    ------
    PorepipeError
        One line naming the file in the way or the folder that cannot be written.
    """
    directory = Path(directory)
    existing = directory
    for parent in [directory, *directory.parents]:
        if os.path.lexists(parent):
            existing = parent
            break
    if not existing.is_dir():
        raise PorepipeError(f"output folder {directory}: a file is in the way ({_first_file(directory)})")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise PorepipeError(f"output folder {directory}: {existing.resolve()} is not writable")


def _first_file(directory: Path) -> Path:
    """The first ancestor of ``directory`` (itself included) that exists but is not a directory."""
    for parent in [directory, *directory.parents]:
        if parent.exists() and not parent.is_dir():
            return parent
    return directory


def _fsync(path: Path, *, directory: bool = False) -> None:
    fd = os.open(path, os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0))
    try:
        os.fsync(fd)
    except OSError:
        if not directory:  # some file systems cannot fsync a directory; the rename is still atomic there
            raise
    finally:
        os.close(fd)


def file_identity(path) -> tuple[int, int]:
    """The (device, inode) of ``path``; a file made again under the name while the first is held open has another."""
    st = os.stat(path)
    return st.st_dev, st.st_ino


def check_identity(tmp, path, identity: tuple[int, int]) -> None:
    """Refuse (one :class:`PorepipeError`) when ``tmp`` is no longer the file this writer made.

    On a file system shared by several nodes, a rerun of the job on another node takes the temporary file of a
    process it cannot see for a killed job's leftover and removes it; the writer must then commit nothing (writing
    on would make a new file holding only what came after the removal).

    Parameters
    ----------
    tmp : path-like
        The writer's temporary file.
    path : path-like
        The result it stands for (named in the message).
    identity : tuple of int
        :func:`file_identity` of ``tmp`` when the writer made it.
    """
    try:
        same = file_identity(tmp) == identity
    except FileNotFoundError:
        same = False
    if not same:
        raise PorepipeError(
            f"output {path}: its temporary file {Path(tmp).name} was removed while it was written (a rerun of the "
            f"job elsewhere?); nothing committed"
        )


def commit(tmp, path, identity: tuple[int, int] | None = None) -> Path:
    """Flush the finished temporary file ``tmp`` to disk and rename it onto ``path`` (then flush the directory).

    Parameters
    ----------
    tmp : path-like
        The finished temporary file.
    path : path-like
        The result's name.
    identity : tuple of int, optional
        :func:`file_identity` of ``tmp`` when it was made: a removed or replaced ``tmp`` is refused
        (:func:`check_identity`).

    Returns
    -------
    Path
        ``path``.
    """
    tmp, path = Path(tmp), Path(path)
    if identity is not None:
        check_identity(tmp, path, identity)
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
    path = prepare_output(path)
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
