"""Minkowski functionals (φ, S_V, K_V, T_V, χ) of voxel volumes from the 2x2x2 configuration histogram."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "Adjacency": "_settings",
    "boolean_lattice_densities": "_boolean",
    "configuration_histogram": "_api",
    "configuration_histogram_chunked": "_chunked",
    "configuration_histogram_slabs": "_api",
    "iter_slabs": "_api",
    "matrix_histogram": "_api",
    "miles_densities": "_boolean",
    "minkowski_from_histogram": "_api",
    "minkowski_functionals": "_api",
    "minkowski_functions_of_threshold": "_api",
    "n_cells": "_api",
    "specific_surface_from_histogram": "_api",
    "threshold_dataset": "_api",
    "threshold_histograms": "_api",
    "threshold_histograms_chunked": "_chunked",
    "threshold_histograms_slabs": "_api",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
