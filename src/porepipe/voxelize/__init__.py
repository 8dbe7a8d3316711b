"""Grey-value voxelisation of sphere packings at several resolutions (Zauner 2020, §4.7.2)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "VoxelizeMethod": "_api",
    "grey_histogram": "_api",
    "grid_shape": "_api",
    "iter_grey_slabs": "_api",
    "read_packing_h5": "_spheres",
    "read_xyzr": "_spheres",
    "sphere_images": "_api",
    "spheres_from_scene": "_spheres",
    "voxelize": "_api",
    "write_xyzr": "_spheres",
}
__all__ = [*_EXPORTS]  # noqa: PLE0604 (built from the lazy export table)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
