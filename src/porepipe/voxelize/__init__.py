"""Grey-value voxelisation of sphere packings at several resolutions (Zauner 2020, §4.7.2)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "VoxelizeMethod": "_settings",
    "grey_histogram": "_api",
    "grid_shape": "_api",
    "iter_grey_slabs": "_api",
    "read_packing_h5": "porepipe._shared.spheres",
    "read_xyzr": "porepipe._shared.spheres",
    "sphere_images": "_api",
    "spheres_from_scene": "porepipe._shared.spheres",
    "voxelize": "_api",
    "write_xyzr": "porepipe._shared.spheres",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
