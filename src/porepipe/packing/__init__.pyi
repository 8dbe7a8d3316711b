"""Type stub of porepipe.packing: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.packing._api import (
    Packing as Packing,
)
from porepipe.packing._api import (
    pack_spheres as pack_spheres,
)
from porepipe.packing._api import (
    schedule_value as schedule_value,
)
from porepipe.packing._api import (
    sphere_overlaps as sphere_overlaps,
)
from porepipe.packing._io import (
    read_packing as read_packing,
)
from porepipe.packing._io import (
    write_packing as write_packing,
)
from porepipe.packing._io import (
    write_xyzr_file as write_xyzr_file,
)
from porepipe.packing._neighbours import (
    build_neighbours as build_neighbours,
)
from porepipe.packing._settings import (
    Effect as Effect,
)
from porepipe.packing._settings import (
    RadiusDist as RadiusDist,
)
from porepipe.packing._settings import (
    Settings as Settings,
)
from porepipe.packing._setup import (
    sample_radii as sample_radii,
)

__all__ = [
    "Effect",
    "Packing",
    "RadiusDist",
    "Settings",
    "build_neighbours",
    "pack_spheres",
    "read_packing",
    "sample_radii",
    "schedule_value",
    "sphere_overlaps",
    "write_packing",
    "write_xyzr_file",
]
