"""Earlier versions of a kernel module, timed beside the current one in the same run (a shared, noisy machine
compares like with like only within one run).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType


def load_module(path: str | Path) -> ModuleType:
    """The module of an earlier kernel file (for instance ``git show main:src/porepipe/voxelize/_kernels.py >
    old_kernels.py``), imported under its file name: numba's on-disk cache refers to it by that name, so give each
    copy its own.
    """
    path = Path(path)
    if not path.is_file():
        raise SystemExit(f"reference kernel file {path} not found")
    name = path.stem
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
