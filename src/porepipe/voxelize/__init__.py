"""Grey-value voxelisation of sphere packings at several resolutions (Zauner 2020, §4.7.2)."""

from porepipe.voxelize._api import (
           VoxelizeMethod,
           grey_histogram,
           grid_shape,
           iter_grey_slabs,
           sphere_images,
           voxelize,
)
from porepipe.voxelize._spheres import read_packing_h5, read_xyzr, spheres_from_scene, write_xyzr

__all__ = ["VoxelizeMethod", "grey_histogram", "grid_shape", "iter_grey_slabs", "read_packing_h5", "read_xyzr",
           "sphere_images", "spheres_from_scene", "voxelize", "write_xyzr"]
