"""Type stub of porepipe.estimate: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.estimate._api import (
    PorosityLimit as PorosityLimit,
    cap_base_area as cap_base_area,
    corner_cut as corner_cut,
    estimate_from_histograms as estimate_from_histograms,
    porosity_at_threshold as porosity_at_threshold,
    porosity_bounds as porosity_bounds,
    porosity_mean_grey as porosity_mean_grey,
    regress_porosity_limit as regress_porosity_limit,
    richardson_limit as richardson_limit,
    surface_estimates as surface_estimates,
    surface_per_grey as surface_per_grey,
    two_point_line as two_point_line,
)

__all__ = [
    "PorosityLimit",
    "cap_base_area",
    "corner_cut",
    "estimate_from_histograms",
    "porosity_at_threshold",
    "porosity_bounds",
    "porosity_mean_grey",
    "regress_porosity_limit",
    "richardson_limit",
    "surface_estimates",
    "surface_per_grey",
    "two_point_line",
]
