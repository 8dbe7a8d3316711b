"""Lazy package exports (PEP 562), so that reading a stage's settings does not import its heavy dependencies.

Every Snakemake job is a fresh interpreter that builds the scene schema from all stages' ``_settings``; importing a
package must therefore stay cheap. A package lists ``name -> submodule`` and gets ``__getattr__``/``__dir__``.
"""

from __future__ import annotations

import importlib


def lazy_exports(package: str, exports: dict[str, str]):
    """``__getattr__`` and ``__dir__`` for ``package`` that import ``exports[name]`` on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : dict of str -> str
        Public name -> the module that defines it: a submodule of ``package`` (``"_api"``) or an absolute module
        name (``"porepipe._shared.x"``) for a name the package re-exports from shared code.

    Returns
    -------
    (callable, callable)
        The module-level ``__getattr__`` and ``__dir__``.
    """

    def __getattr__(name: str):
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        target = module if module.startswith("porepipe.") else f"{package}.{module}"
        return getattr(importlib.import_module(target), name)

    def __dir__():
        return sorted(exports)

    return __getattr__, __dir__
