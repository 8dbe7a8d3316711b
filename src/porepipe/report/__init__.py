"""The accuracy-versus-cost report: HTML + PNG figures and tables of a scene's sweep."""

import importlib

#: public name -> submodule; loaded on first use, so importing the CLI does not import matplotlib
_PUBLIC = {
    "Reference": "_analysis",
    "cost_per_digit": "_analysis",
    "error_cost_table": "_analysis",
    "pareto_front": "_analysis",
    "reference_limit": "_analysis",
    "runs_of": "_analysis",
    "varying_quantities": "_analysis",
    "build_report": "_api",
    "Table": "_thesis",
    "scene_tables": "_thesis",
    "startup_table": "_analysis",
    "SECTIONS": "_api",
    "Context": "_api",
    "thesis_tables": "_thesis",
}

__all__ = [
    "SECTIONS",
    "Context",
    "Reference",
    "Table",
    "build_report",
    "cost_per_digit",
    "error_cost_table",
    "pareto_front",
    "reference_limit",
    "runs_of",
    "scene_tables",
    "startup_table",
    "thesis_tables",
    "varying_quantities",
]


def __getattr__(name):
    if name not in _PUBLIC:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_PUBLIC[name]}"), name)
