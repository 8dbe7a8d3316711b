"""Type stub of porepipe.lpt: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.lpt._api import (
    BoxHistogram as BoxHistogram,
)
from porepipe.lpt._api import (
    CellGrid as CellGrid,
)
from porepipe.lpt._api import (
    auto_stride as auto_stride,
)
from porepipe.lpt._api import (
    cell_grid as cell_grid,
)
from porepipe.lpt._api import (
    cell_sizes as cell_sizes,
)
from porepipe.lpt._api import (
    characteristic_length as characteristic_length,
)
from porepipe.lpt._api import (
    local_porosity_analysis as local_porosity_analysis,
)
from porepipe.lpt._api import (
    local_porosity_histogram as local_porosity_histogram,
)
from porepipe.lpt._api import (
    local_surface_histogram as local_surface_histogram,
)
from porepipe.lpt._api import (
    percolation_bits as percolation_bits,
)
from porepipe.lpt._chunked import (
    local_porosity_analysis_chunked as local_porosity_analysis_chunked,
)
from porepipe.lpt._plot import (
    plot_lpt as plot_lpt,
)
from porepipe.lpt._settings import (
    Connectivity as Connectivity,
)
from porepipe.lpt._settings import (
    Direction as Direction,
)
from porepipe.lpt._settings import (
    Placement as Placement,
)
from porepipe.lpt._settings import (
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
    "local_porosity_analysis_chunked",
    "local_porosity_histogram",
    "local_surface_histogram",
    "percolation_bits",
    "plot_lpt",
]
