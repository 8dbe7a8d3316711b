"""Type stub of porepipe.sweep: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.sweep._adaptive import (
    Decision as Decision,
    Outcome as Outcome,
    decide as decide,
    predict_cost as predict_cost,
    run_adaptive as run_adaptive,
)
from porepipe.sweep._api import (
    FORMS as FORMS,
    add_limits as add_limits,
    build_sweep as build_sweep,
    exponent_value as exponent_value,
    limit_from_sweep as limit_from_sweep,
    limit_of as limit_of,
)
from porepipe.sweep._crop import (
    corner_voxels as corner_voxels,
    crop_corner as crop_corner,
)
from porepipe.sweep._fit import (
    Limit as Limit,
    Status as Status,
    fit_inverse_length as fit_inverse_length,
    fit_power as fit_power,
    two_point_limit as two_point_limit,
)
from porepipe.sweep._gather import (
    FULL as FULL,
    file_quantities as file_quantities,
    gather as gather,
    parse_name as parse_name,
    per_a_quantities as per_a_quantities,
    read_benchmarks as read_benchmarks,
)

__all__ = [
    "Decision",
    "FORMS",
    "FULL",
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
