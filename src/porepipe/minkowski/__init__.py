"""Minkowski functionals (φ, S_V, K_V, T_V, χ) of voxel volumes from the 2x2x2 configuration histogram."""

from porepipe.minkowski._api import (
    configuration_histogram,
    configuration_histogram_slabs,
    iter_slabs,
    matrix_histogram,
    minkowski_from_histogram,
    minkowski_functionals,
    minkowski_functions_of_threshold,
    n_cells,
    specific_surface_from_histogram,
    threshold_dataset,
    threshold_histograms,
    threshold_histograms_slabs,
)
from porepipe.minkowski._boolean import boolean_lattice_densities, miles_densities
from porepipe.minkowski._weights import Adjacency

__all__ = [
    "Adjacency",
    "boolean_lattice_densities",
    "configuration_histogram",
    "configuration_histogram_slabs",
    "iter_slabs",
    "matrix_histogram",
    "miles_densities",
    "minkowski_from_histogram",
    "minkowski_functionals",
    "minkowski_functions_of_threshold",
    "n_cells",
    "specific_surface_from_histogram",
    "threshold_dataset",
    "threshold_histograms",
    "threshold_histograms_slabs",
]
