"""Type stub of porepipe.minkowski: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.minkowski._api import (
    configuration_histogram as configuration_histogram,
)
from porepipe.minkowski._api import (
    configuration_histogram_slabs as configuration_histogram_slabs,
)
from porepipe.minkowski._api import (
    iter_slabs as iter_slabs,
)
from porepipe.minkowski._api import (
    matrix_histogram as matrix_histogram,
)
from porepipe.minkowski._api import (
    minkowski_from_histogram as minkowski_from_histogram,
)
from porepipe.minkowski._api import (
    minkowski_functionals as minkowski_functionals,
)
from porepipe.minkowski._api import (
    minkowski_functions_of_threshold as minkowski_functions_of_threshold,
)
from porepipe.minkowski._api import (
    n_cells as n_cells,
)
from porepipe.minkowski._api import (
    specific_surface_from_histogram as specific_surface_from_histogram,
)
from porepipe.minkowski._api import (
    threshold_dataset as threshold_dataset,
)
from porepipe.minkowski._api import (
    threshold_histograms as threshold_histograms,
)
from porepipe.minkowski._api import (
    threshold_histograms_slabs as threshold_histograms_slabs,
)
from porepipe.minkowski._boolean import (
    boolean_lattice_densities as boolean_lattice_densities,
)
from porepipe.minkowski._boolean import (
    miles_densities as miles_densities,
)
from porepipe.minkowski._chunked import (
    configuration_histogram_chunked as configuration_histogram_chunked,
)
from porepipe.minkowski._chunked import (
    threshold_histograms_chunked as threshold_histograms_chunked,
)
from porepipe.minkowski._settings import (
    Adjacency as Adjacency,
)

__all__ = [
    "Adjacency",
    "boolean_lattice_densities",
    "configuration_histogram",
    "configuration_histogram_chunked",
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
    "threshold_histograms_chunked",
    "threshold_histograms_slabs",
]
