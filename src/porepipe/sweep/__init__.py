"""Resolution and sample-size sweeps, extrapolation to a → 0, adaptive refinement (thesis §4.6.1, §6.2, §7.2, §7.5)."""

from porepipe.sweep._adaptive import Decision, Outcome, decide, predict_cost, run_adaptive
from porepipe.sweep._api import FORMS, add_limits, build_sweep, exponent_value, limit_from_sweep, limit_of
from porepipe.sweep._crop import corner_voxels, crop_corner
from porepipe.sweep._fit import Limit, Status, fit_inverse_length, fit_power, two_point_limit
from porepipe.sweep._gather import (
           FULL,
           file_quantities,
           gather,
           parse_name,
           per_a_quantities,
           read_benchmarks,
)

__all__ = [
           "FORMS",
           "FULL",
           "Decision",
           "Limit",
           "Outcome",
           "Status",
           "add_limits",
           "build_sweep",
           "corner_voxels",
           "crop_corner",
           "decide",
           "exponent_value",
           "file_quantities",
           "fit_inverse_length",
           "fit_power",
           "gather",
           "limit_from_sweep",
           "limit_of",
           "parse_name",
           "per_a_quantities",
           "predict_cost",
           "read_benchmarks",
           "run_adaptive",
           "two_point_limit",
]
