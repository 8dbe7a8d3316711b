"""Type stub of porepipe.lpt: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.lpt._api import (
    BoxHistogram as BoxHistogram,
    CellGrid as CellGrid,
    auto_stride as auto_stride,
    cell_grid as cell_grid,
    cell_sizes as cell_sizes,
    characteristic_length as characteristic_length,
    local_porosity_analysis as local_porosity_analysis,
    local_porosity_histogram as local_porosity_histogram,
    local_surface_histogram as local_surface_histogram,
    percolation_bits as percolation_bits,
)
from porepipe.lpt._plot import (
    plot_lpt as plot_lpt,
)
from porepipe.lpt._settings import (
    Connectivity as Connectivity,
    Direction as Direction,
    Placement as Placement,
    Settings as Settings,
)

__all__ = [
    "BoxHistogram",
    "CellGrid",
    "Connectivity",
    "Direction",
    "Placement",
    "Settings",
    "auto_stride",
    "cell_grid",
    "cell_sizes",
    "characteristic_length",
    "local_porosity_analysis",
    "local_porosity_histogram",
    "local_surface_histogram",
    "percolation_bits",
    "plot_lpt",
]
