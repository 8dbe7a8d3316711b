"""Type stub of porepipe.lbm: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.lbm._api import (
    DARCY_M2 as DARCY_M2,
    PermeabilityResult as PermeabilityResult,
    kappa_units as kappa_units,
    permeability as permeability,
)
from porepipe.lbm._settings import (
    Axis as Axis,
    Collision as Collision,
    Gradient as Gradient,
    Lateral as Lateral,
    Precision as Precision,
    Settings as Settings,
    Setup as Setup,
    Velocity as Velocity,
)
from porepipe.lbm._solver import (
    StabilityError as StabilityError,
)

__all__ = [
    "Axis",
    "Collision",
    "DARCY_M2",
    "Gradient",
    "Lateral",
    "PermeabilityResult",
    "Precision",
    "Settings",
    "Setup",
    "StabilityError",
    "Velocity",
    "kappa_units",
    "permeability",
]
