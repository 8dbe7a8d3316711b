"""Type stub of porepipe.granular: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.granular._api import Frame as Frame
from porepipe.granular._api import Simulation as Simulation
from porepipe.granular._api import polygon_overlap as polygon_overlap
from porepipe.granular._api import time_step_rule as time_step_rule
from porepipe.granular._run import read_granular as read_granular
from porepipe.granular._run import run as run
from porepipe.granular._settings import Settings as Settings
from porepipe.granular._shapes import AngleMode as AngleMode
from porepipe.granular._shapes import Dist as Dist
from porepipe.granular._shapes import check_convex as check_convex
from porepipe.granular._shapes import ellipse_polygon as ellipse_polygon
from porepipe.granular._shapes import polygon_properties as polygon_properties
from porepipe.granular._shapes import rectangle as rectangle
from porepipe.granular._shapes import regular_polygon as regular_polygon

__all__ = [
    "AngleMode",
    "Dist",
    "Frame",
    "Settings",
    "Simulation",
    "check_convex",
    "ellipse_polygon",
    "polygon_overlap",
    "polygon_properties",
    "read_granular",
    "rectangle",
    "regular_polygon",
    "run",
    "time_step_rule",
]
