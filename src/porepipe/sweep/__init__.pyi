"""Type stub of porepipe.sweep: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.sweep._adaptive import (
    Decision as Decision,
)
from porepipe.sweep._adaptive import (
    Outcome as Outcome,
)
from porepipe.sweep._adaptive import (
    decide as decide,
)
from porepipe.sweep._adaptive import (
    predict_cost as predict_cost,
)
from porepipe.sweep._adaptive import (
    run_adaptive as run_adaptive,
)
from porepipe.sweep._api import (
    FORMS as FORMS,
)
from porepipe.sweep._api import (
    add_limits as add_limits,
)
from porepipe.sweep._api import (
    build_sweep as build_sweep,
)
from porepipe.sweep._api import (
    exponent_value as exponent_value,
)
from porepipe.sweep._api import (
    limit_from_sweep as limit_from_sweep,
)
from porepipe.sweep._api import (
    limit_of as limit_of,
)
from porepipe.sweep._crop import (
    corner_voxels as corner_voxels,
)
from porepipe.sweep._crop import (
    crop_corner as crop_corner,
)
from porepipe.sweep._crop import (
    subsample_offsets as subsample_offsets,
)
from porepipe.sweep._fit import (
    Limit as Limit,
)
from porepipe.sweep._fit import (
    Status as Status,
)
from porepipe.sweep._fit import (
    fit_inverse_length as fit_inverse_length,
)
from porepipe.sweep._fit import (
    fit_power as fit_power,
)
from porepipe.sweep._fit import (
    two_point_limit as two_point_limit,
)
from porepipe.sweep._gather import (
    FULL as FULL,
)
from porepipe.sweep._gather import (
    file_quantities as file_quantities,
)
from porepipe.sweep._gather import (
    gather as gather,
)
from porepipe.sweep._gather import (
    parse_name as parse_name,
)
from porepipe.sweep._gather import (
    per_a_quantities as per_a_quantities,
)
from porepipe.sweep._gather import (
    read_benchmarks as read_benchmarks,
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
    "subsample_offsets",
    "two_point_limit",
]
