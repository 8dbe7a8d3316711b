"""Type stub of porepipe.voxelize: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe._shared.spheres import (
    read_packing_h5 as read_packing_h5,
)
from porepipe._shared.spheres import (
    read_xyzr as read_xyzr,
)
from porepipe._shared.spheres import (
    spheres_from_scene as spheres_from_scene,
)
from porepipe._shared.spheres import (
    write_xyzr as write_xyzr,
)
from porepipe.voxelize._api import (
    grey_histogram as grey_histogram,
)
from porepipe.voxelize._api import (
    grid_shape as grid_shape,
)
from porepipe.voxelize._api import (
    iter_grey_slabs as iter_grey_slabs,
)
from porepipe.voxelize._api import (
    sphere_images as sphere_images,
)
from porepipe.voxelize._api import (
    voxelize as voxelize,
)
from porepipe.voxelize._settings import (
    VoxelizeMethod as VoxelizeMethod,
)

__all__ = [
    "VoxelizeMethod",
    "grey_histogram",
    "grid_shape",
    "iter_grey_slabs",
    "read_packing_h5",
    "read_xyzr",
    "sphere_images",
    "spheres_from_scene",
    "voxelize",
    "write_xyzr",
]
