"""Type stub of porepipe.decorate: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.decorate._api import (
    Decoration as Decoration,
)
from porepipe.decorate._api import (
    build_library as build_library,
)
from porepipe.decorate._api import (
    grain_images as grain_images,
)
from porepipe.decorate._api import (
    iter_grain_slabs as iter_grain_slabs,
)
from porepipe.decorate._api import (
    mean_overlap_volume as mean_overlap_volume,
)
from porepipe.decorate._api import (
    neighbour_pairs as neighbour_pairs,
)
from porepipe.decorate._api import (
    pair_overlap_volume as pair_overlap_volume,
)
from porepipe.decorate._api import (
    points_in_grains as points_in_grains,
)
from porepipe.decorate._api import (
    voxelize_grains as voxelize_grains,
)
from porepipe.decorate._api import (
    world_grains as world_grains,
)
from porepipe.decorate._decorate import (
    decorate as decorate,
)
from porepipe.decorate._decorate import (
    scale_factors as scale_factors,
)
from porepipe.decorate._io import (
    decoration_dataset as decoration_dataset,
)
from porepipe.decorate._io import (
    read_grains as read_grains,
)
from porepipe.decorate._library import (
    GrainType as GrainType,
)
from porepipe.decorate._library import (
    Kind as Kind,
)
from porepipe.decorate._library import (
    polyhedron as polyhedron,
)
from porepipe.decorate._library import (
    quartz_type as quartz_type,
)
from porepipe.decorate._library import (
    random_type as random_type,
)
from porepipe.decorate._library import (
    read_plane_file as read_plane_file,
)
from porepipe.decorate._library import (
    sphere_type as sphere_type,
)
from porepipe.decorate._minimiser import (
    minimise_overlap as minimise_overlap,
)
from porepipe.decorate._minimiser import (
    om_cells as om_cells,
)
from porepipe.decorate._rotation import (
    anisotropic_rotations as anisotropic_rotations,
)
from porepipe.decorate._rotation import (
    uniform_rotations as uniform_rotations,
)
from porepipe.decorate._rotation import (
    von_mises_fisher as von_mises_fisher,
)
from porepipe.decorate._settings import (
    Settings as Settings,
)

__all__ = [
    "Decoration",
    "GrainType",
    "Kind",
    "Settings",
    "anisotropic_rotations",
    "build_library",
    "decorate",
    "decoration_dataset",
    "grain_images",
    "iter_grain_slabs",
    "mean_overlap_volume",
    "minimise_overlap",
    "neighbour_pairs",
    "om_cells",
    "pair_overlap_volume",
    "points_in_grains",
    "polyhedron",
    "quartz_type",
    "random_type",
    "read_grains",
    "read_plane_file",
    "scale_factors",
    "sphere_type",
    "uniform_rotations",
    "von_mises_fisher",
    "voxelize_grains",
    "world_grains",
]
