"""numba's on-disk cache, kept valid only while a kernel's whole stage package is unchanged.

numba keeps a cached kernel while the file that defines it is unchanged, but a kernel compiles the jitted functions
it calls from other files into itself. After an edit or a ``git pull`` that changes only those, the cached caller
still runs the old code on the new data: the Knudsen surface kernel, which inlines the flight of
``diffusion/_kernels.py``, read the new geometry codes with the old flight and crashed (segmentation fault) until its
cache was deleted. Here the stamp of a porepipe kernel is numba's (the digest of its own file) together with a digest
of every source file of its stage package and of ``_shared``, so any change there recompiles that package's kernels
once. Installed (:func:`install`) by :mod:`porepipe._shared.numba_config`, which the kernel modules import before
they define kernels; numba's locator classes are private API (``numba.core.caching``), as is ``_nrt``. A kernel made
in a function that captures another compiled kernel gets a cache key that holds in every process
(:func:`key_closure_kernels_by_name`; numba's own changes from process to process).
"""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path

from numba.core import caching, serialize
from numba.core.dispatcher import Dispatcher

#: folders whose kernels get the package-wide stamp (the porepipe package; tests add their own)
ROOTS: list[Path] = [Path(__file__).resolve().parent.parent]

#: sub-folder of a root whose sources every stage's kernels depend on
SHARED: str = "_shared"


def package_digest(py_file: str | os.PathLike, root: Path) -> bytes:
    """Digest of the sources ``py_file``'s kernels may compile in, found once per process and package (numba's own
    stamp still follows the kernel's file within a process).

    Parameters
    ----------
    py_file : path-like
        The source file that defines the kernel.
    root : Path
        A folder of :data:`ROOTS` that holds ``py_file``: its first sub-folder on the way to ``py_file`` is the stage
        package (all its ``.py`` files count; for a module at the top, the root's own files), and ``root/_shared``
        counts too.

    Returns
    -------
    bytes
        sha256 over the files' relative paths and contents.
    """
    rel = Path(py_file).resolve().relative_to(root)
    return _stage_digest(root, root / rel.parts[0] if len(rel.parts) > 1 else root)


@functools.cache
def _stage_digest(root: Path, stage: Path) -> bytes:
    files = {*(root / SHARED).rglob("*.py"), *(stage.glob("*.py") if stage == root else stage.rglob("*.py"))}
    h = hashlib.sha256()
    for f in sorted(files):
        h.update(str(f.relative_to(root)).encode())
        h.update(f.read_bytes())
    return h.digest()


def _root_of(py_file: str) -> Path | None:
    path = Path(py_file).resolve()
    return next((root for root in ROOTS if path.is_relative_to(root)), None)


class _PackageStamp:
    """Locator mixin: only for files under :data:`ROOTS`; stamp = numba's and the package digest."""

    def get_source_stamp(self):
        return (super().get_source_stamp(), package_digest(self._py_file, _root_of(self._py_file)))

    @classmethod
    def from_function(cls, py_func, py_file):
        if not os.path.exists(py_file) or _root_of(py_file) is None:
            return None
        return super().from_function(py_func, py_file)


class _UserProvided(_PackageStamp, caching.UserProvidedCacheLocator):
    """``NUMBA_CACHE_DIR`` set: cache there."""


class _InTree(_PackageStamp, caching.InTreeCacheLocator):
    """The source's ``__pycache__`` (a checkout, an editable install)."""


class _UserWide(_PackageStamp, caching.UserWideCacheLocator):
    """The user's cache folder (a read-only install)."""


def key_closure_kernels_by_name(dispatcher: Dispatcher) -> Dispatcher:
    """Let ``dispatcher`` (a cached kernel defined in a function) find its disk cache in every process although its
    closure holds other compiled kernels; returns it.

    numba keys a closure's cache entries by its bytecode and the pickled values of its closure; a captured
    dispatcher pickles with a random id of the process, so such a kernel never found its cache in a new process
    and compiled again: the granular stepper, which captures its contact kernel, 11–20 CPU-s per variant in every
    run and every test process. Here a captured dispatcher counts by its function's module, qualified name and
    bytecode and (recursively) its own closure, every other value as numba pickles it. The package stamp
    (:class:`_PackageStamp`) still drops the whole index when a source of the stage changes.
    """
    py_func = dispatcher.py_func
    hashes = (
        hashlib.sha256(py_func.__code__.co_code).hexdigest(),
        hashlib.sha256(_closure_bytes(py_func)).hexdigest(),  # a closure's values are fixed once it is made
    )

    def index_key(sig, codegen):
        return (sig, codegen.magic_tuple(), hashes)

    dispatcher._cache._index_key = index_key  # private: numba's Cache computes its index key there
    return dispatcher


def _closure_bytes(py_func) -> bytes:
    """The closure of ``py_func`` as bytes that are the same in every process (see
    :func:`key_closure_kernels_by_name`).
    """
    parts = []
    for cell in py_func.__closure__ or ():
        value = cell.cell_contents
        if isinstance(value, Dispatcher):
            inner = value.py_func
            part = repr((inner.__module__, inner.__qualname__)).encode() + inner.__code__.co_code
            part += _closure_bytes(inner)
        else:
            part = serialize.dumps(value)
        parts.append(len(part).to_bytes(8, "little") + part)
    return b"".join(parts)


def install() -> None:
    """Put the package-stamped locators first in numba's list (once); kernels decorated afterwards use them."""
    classes = caching.CacheImpl._locator_classes
    if _UserProvided not in classes:
        classes[0:0] = [_UserProvided, _InTree, _UserWide]
