"""Grey-value estimators: porosity bounds, their extrapolation to a → 0, and specific-surface bounds (§7.2–7.3)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "PorosityLimit": "_api",
    "cap_base_area": "_api",
    "corner_cut": "_api",
    "estimate_from_histograms": "_api",
    "porosity_at_threshold": "_api",
    "porosity_bounds": "_api",
    "porosity_mean_grey": "_api",
    "regress_porosity_limit": "_api",
    "richardson_limit": "_api",
    "surface_estimates": "_api",
    "surface_per_grey": "_api",
    "two_point_line": "_api",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
