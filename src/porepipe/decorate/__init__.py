"""Grain decoration: polyhedral grain types on a sphere packing and their grey-value voxelisation (Zauner 2020, §4.7)."""

from porepipe.decorate._api import (
    Decoration,
    build_library,
    decorate,
    grain_images,
    iter_grain_slabs,
    mean_overlap_volume,
    minimise_overlap,
    neighbour_pairs,
    pair_overlap_volume,
    points_in_grains,
    scale_factors,
    voxelize_grains,
    world_grains,
)
from porepipe.decorate._io import decoration_dataset, read_grains
from porepipe.decorate._library import (
    GrainType,
    Kind,
    polyhedron,
    quartz_type,
    random_type,
    read_plane_file,
    sphere_type,
)
from porepipe.decorate._rotation import anisotropic_rotations, uniform_rotations, von_mises_fisher

__all__ = [
    "Decoration",
    "GrainType",
    "Kind",
    "anisotropic_rotations",
    "build_library",
    "decorate",
    "decoration_dataset",
    "grain_images",
    "iter_grain_slabs",
    "mean_overlap_volume",
    "minimise_overlap",
    "neighbour_pairs",
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
