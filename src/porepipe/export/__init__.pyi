"""Type stub of porepipe.export: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.export._api import export_result as export_result
from porepipe.export._api import grain_polygons as grain_polygons
from porepipe.export._api import granular_polygons as granular_polygons
from porepipe.export._api import write_granular_series as write_granular_series
from porepipe.export._api import write_image as write_image
from porepipe.export._api import write_points as write_points
from porepipe.export._api import write_polygons as write_polygons

__all__ = [
    "export_result",
    "grain_polygons",
    "granular_polygons",
    "write_granular_series",
    "write_image",
    "write_points",
    "write_polygons",
]
