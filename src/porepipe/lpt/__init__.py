"""Local porosity theory: local porosity and S_V distributions μ(φ, L), local percolation λ_α(φ, L), p_α(L)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "BoxHistogram": "_api",
    "CellGrid": "_api",
    "Connectivity": "_settings",
    "Direction": "_settings",
    "Placement": "_settings",
    "Settings": "_settings",
    "auto_stride": "_api",
    "cell_grid": "_api",
    "cell_sizes": "_api",
    "characteristic_length": "_api",
    "local_porosity_analysis": "_api",
    "local_porosity_analysis_chunked": "_chunked",
    "local_porosity_histogram": "_api",
    "local_surface_histogram": "_api",
    "percolation_bits": "_api",
    "plot_lpt": "_plot",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
