"""Local porosity theory: local porosity and S_V distributions μ(φ, L), local percolation λ_α(φ, L), p_α(L)."""

from porepipe.lpt._api import (
    BoxHistogram,
    CellGrid,
    auto_stride,
    cell_grid,
    cell_sizes,
    characteristic_length,
    local_porosity_analysis,
    local_porosity_histogram,
    local_surface_histogram,
    percolation_bits,
)
from porepipe.lpt._plot import plot_lpt
from porepipe.lpt._settings import Connectivity, Direction, Placement, Settings

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
