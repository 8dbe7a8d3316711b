"""Grain decoration: polyhedral grain types on a sphere packing and their grey-value voxelisation (Zauner 2020, §4.7)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "Decoration": "_api",
    "GrainType": "_library",
    "Kind": "_library",
    "Settings": "_settings",
    "anisotropic_rotations": "_rotation",
    "build_library": "_api",
    "decorate": "_decorate",
    "decoration_dataset": "_io",
    "grain_images": "_api",
    "iter_grain_slabs": "_api",
    "mean_overlap_volume": "_api",
    "minimise_overlap": "_minimiser",
    "neighbour_pairs": "_api",
    "om_cells": "_minimiser",
    "pair_overlap_volume": "_api",
    "points_in_grains": "_api",
    "polyhedron": "_library",
    "quartz_type": "_library",
    "random_type": "_library",
    "read_grains": "_io",
    "read_plane_file": "_library",
    "scale_factors": "_decorate",
    "sphere_type": "_library",
    "uniform_rotations": "_rotation",
    "von_mises_fisher": "_rotation",
    "voxelize_grains": "_api",
    "world_grains": "_api",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
