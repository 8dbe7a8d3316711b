"""The accuracy-versus-cost report: HTML + PNG figures and tables of a scene's sweep."""

from porepipe.report._analysis import (
    Reference,
    cost_per_digit,
    error_cost_table,
    pareto_front,
    reference_limit,
    runs_of,
    varying_quantities,
)
from porepipe.report._api import build_report
from porepipe.report._thesis import Table, thesis_tables

__all__ = ["Reference", "Table", "build_report", "cost_per_digit", "error_cost_table", "pareto_front",
           "reference_limit", "runs_of", "thesis_tables", "varying_quantities"]
