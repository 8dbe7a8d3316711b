"""Type stub of porepipe.lbm: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.lbm._api import DARCY_M2 as DARCY_M2
from porepipe.lbm._api import PermeabilityResult as PermeabilityResult
from porepipe.lbm._api import kappa_units as kappa_units
from porepipe.lbm._api import permeability as permeability
from porepipe.lbm._settings import Axis as Axis
from porepipe.lbm._settings import Collision as Collision
from porepipe.lbm._settings import Gradient as Gradient
from porepipe.lbm._settings import Lateral as Lateral
from porepipe.lbm._settings import Precision as Precision
from porepipe.lbm._settings import Settings as Settings
from porepipe.lbm._settings import Setup as Setup
from porepipe.lbm._settings import StopRule as StopRule
from porepipe.lbm._settings import Streaming as Streaming
from porepipe.lbm._settings import Velocity as Velocity
from porepipe.lbm._settings import Walls as Walls
from porepipe.lbm._solver import StabilityError as StabilityError
from porepipe.lbm._walls import GrainWalls as GrainWalls
from porepipe.lbm._walls import GreyWalls as GreyWalls
from porepipe.lbm._walls import SphereWalls as SphereWalls

__all__ = [
    "DARCY_M2",
    "Axis",
    "Collision",
    "Gradient",
    "GrainWalls",
    "GreyWalls",
    "Lateral",
    "PermeabilityResult",
    "Precision",
    "Settings",
    "Setup",
    "SphereWalls",
    "StabilityError",
    "StopRule",
    "Streaming",
    "Velocity",
    "Walls",
    "kappa_units",
    "permeability",
]
