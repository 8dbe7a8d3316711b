"""A cached kernel recompiles when a jitted function it calls changes in another file of its package
(``porepipe._shared.numba_cache``): numba alone checks only the kernel's own file, so after such an edit or a
``git pull`` the cached kernel ran the old callee (the Knudsen surface kernel then crashed on new geometry codes)."""

import subprocess
import sys
import textwrap

import pytest

from porepipe._shared import numba_cache

# run in a fresh interpreter each time, so that numba loads the kernel from its on-disk cache
_RUN = """
import sys
from pathlib import Path
root = Path(sys.argv[1])
from porepipe._shared import numba_cache, numba_config  # numba_config installs the locators
if sys.argv[2] == "package":
    numba_cache.ROOTS.append(root)
sys.path.insert(0, str(root.parent))
from fakepkg.stage.caller import twice
print(twice(3))
"""


def _package(tmp_path, callee_body):
    root = tmp_path / "fakepkg"
    for folder in (root, root / "_shared", root / "stage"):
        folder.mkdir(exist_ok=True)
        (folder / "__init__.py").write_text("")
    (root / "stage" / "callee.py").write_text(
        f"from numba import njit\n\n@njit(cache=True)\ndef base(x):\n    return {callee_body}\n"
    )
    (root / "stage" / "caller.py").write_text(
        textwrap.dedent(
            """
            from numba import njit
            from fakepkg.stage.callee import base

            @njit(cache=True)
            def twice(x):
                return 2 * base(x)
            """
        )
    )
    return root


def _twice_of_3(root, stamp):
    out = subprocess.run(
        [sys.executable, "-c", _RUN, str(root), stamp], capture_output=True, text=True, check=True
    ).stdout
    return int(out)


@pytest.mark.parametrize("stamp,after_edit", [("package", 8), ("numba", 6)])
def test_a_callee_edited_in_another_file_recompiles_the_cached_caller(tmp_path, stamp, after_edit):
    root = _package(tmp_path, "x")
    assert _twice_of_3(root, stamp) == 6
    assert _twice_of_3(root, stamp) == 6  # from the cache
    assert list((root / "stage" / "__pycache__").glob("caller.twice-*.nbc"))
    _package(tmp_path, "x + 1")  # the caller's file is untouched
    # with the package stamp the caller recompiles (2 * 4); numba's own stamp keeps the stale 2 * 3
    assert _twice_of_3(root, stamp) == after_edit


def test_the_stamp_follows_the_stage_and_shared_sources_only(tmp_path):
    root = _package(tmp_path, "x")
    (root / "other").mkdir()
    (root / "other" / "mod.py").write_text("A = 1\n")
    caller = root / "stage" / "caller.py"
    digest = numba_cache._stage_digest
    before = numba_cache.package_digest(caller, root)
    (root / "other" / "mod.py").write_text("A = 2\n")
    digest.cache_clear()
    assert numba_cache.package_digest(caller, root) == before
    (root / "_shared" / "__init__.py").write_text("B = 1\n")
    digest.cache_clear()
    shared_changed = numba_cache.package_digest(caller, root)
    assert shared_changed != before
    (root / "stage" / "callee.py").write_text("C = 1\n")
    digest.cache_clear()
    assert numba_cache.package_digest(caller, root) != shared_changed


def test_porepipe_kernels_use_the_package_stamp():
    from porepipe.diffusion import _surface_kernels

    locator = _surface_kernels.surface_kernel._cache._impl.locator
    assert isinstance(locator, numba_cache._PackageStamp)


# a kernel made in a function that captures another such kernel (as the granular stepper captures its contact kernel)
_FACTORY = """
from numba import njit
from porepipe._shared.numba_cache import key_closure_kernels_by_name


def make(flag):
    @njit(cache=True)
    def inner(x):
        return x + (1 if flag else 2)

    @njit(cache=True)
    def outer(x):
        return 10 * inner(x)

    return key_closure_kernels_by_name(outer)
"""

_RUN_FACTORY = """
import sys
from pathlib import Path
root = Path(sys.argv[1])
from porepipe._shared import numba_cache, numba_config  # numba_config installs the locators
numba_cache.ROOTS.append(root)
sys.path.insert(0, str(root.parent))
from fakepkg.stage.factory import make
kernel = make(sys.argv[2] == "1")
print(kernel(1), sum(kernel.stats.cache_hits.values()))
"""


def _factory_run(root, flag):
    """(kernel(1), disk-cache hits of the outer kernel) in a fresh interpreter."""
    out = subprocess.run(
        [sys.executable, "-c", _RUN_FACTORY, str(root), str(int(flag))],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return int(out[0]), int(out[1])


def test_a_kernel_that_captures_a_kernel_loads_from_the_cache_in_a_new_process_and_per_variant(tmp_path):
    root = _package(tmp_path, "x")
    (root / "stage" / "factory.py").write_text(_FACTORY)
    assert _factory_run(root, True) == (20, 0)  # compiled
    assert _factory_run(root, True) == (20, 1)  # another process: from the disk cache
    # the captured kernel's own closure is part of the key: the other variant compiles and computes its own result
    assert _factory_run(root, False) == (30, 0)
    assert _factory_run(root, False) == (30, 1)
    assert _factory_run(root, True) == (20, 1)
