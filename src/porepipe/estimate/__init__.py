"""Grey-value estimators: porosity bounds, their extrapolation to a → 0, and specific-surface bounds (§7.2–7.3)."""

from porepipe.estimate._api import (
    PorosityLimit,
    cap_base_area,
    corner_cut,
    estimate_from_histograms,
    porosity_at_threshold,
    porosity_bounds,
    porosity_mean_grey,
    regress_porosity_limit,
    richardson_limit,
    surface_estimates,
    surface_per_grey,
    two_point_line,
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
