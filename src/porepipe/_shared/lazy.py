"""Lazy package exports (PEP 562), so that reading a stage's settings does not import its heavy dependencies.

Every Snakemake job is a fresh interpreter that builds the scene schema from all stages' ``_settings``; importing a
package must therefore stay cheap. A package lists ``name -> submodule`` and gets ``__getattr__``/``__dir__``.
"""

from __future__ import annotations

import importlib


def lazy_exports(package: str, exports: dict[str, str]):
    """``__getattr__`` and ``__dir__`` for ``package`` that import ``exports[name]`` (a submodule) on first use."""

    def __getattr__(name: str):
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{module}"), name)

    def __dir__():
        return sorted(exports)

    return __getattr__, __dir__
