"""Resolution and sample-size sweeps, extrapolation to a → 0, adaptive refinement (thesis §4.6.1, §6.2, §7.2, §7.5)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "Decision": "_adaptive",
    "FORMS": "_api",
    "FULL": "_gather",
    "Limit": "_fit",
    "Outcome": "_adaptive",
    "Status": "_fit",
    "add_limits": "_api",
    "build_sweep": "_api",
    "corner_voxels": "_crop",
    "crop_corner": "_crop",
    "decide": "_adaptive",
    "exponent_value": "_api",
    "file_quantities": "_gather",
    "fit_inverse_length": "_fit",
    "fit_power": "_fit",
    "gather": "_gather",
    "limit_from_sweep": "_api",
    "limit_of": "_api",
    "parse_name": "_gather",
    "per_a_quantities": "_gather",
    "predict_cost": "_adaptive",
    "read_benchmarks": "_gather",
    "run_adaptive": "_adaptive",
    "subsample_offsets": "_crop",
    "two_point_limit": "_fit",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
