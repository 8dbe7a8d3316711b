"""Type stub of porepipe.estimate: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.estimate._api import (
    PorosityLimit as PorosityLimit,
)
from porepipe.estimate._api import (
    cap_base_area as cap_base_area,
)
from porepipe.estimate._api import (
    corner_cut as corner_cut,
)
from porepipe.estimate._api import (
    estimate_from_histograms as estimate_from_histograms,
)
from porepipe.estimate._api import (
    porosity_at_threshold as porosity_at_threshold,
)
from porepipe.estimate._api import (
    porosity_bounds as porosity_bounds,
)
from porepipe.estimate._api import (
    porosity_mean_grey as porosity_mean_grey,
)
from porepipe.estimate._api import (
    regress_porosity_limit as regress_porosity_limit,
)
from porepipe.estimate._api import (
    richardson_limit as richardson_limit,
)
from porepipe.estimate._api import (
    surface_estimates as surface_estimates,
)
from porepipe.estimate._api import (
    surface_per_grey as surface_per_grey,
)
from porepipe.estimate._api import (
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
