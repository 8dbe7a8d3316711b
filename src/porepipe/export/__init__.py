"""ParaView export: volumes as compressed VTI, packings, grains and granular frames as VTP, LBM fields in SI units."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "export_result": "_api",
    "grain_polygons": "_api",
    "granular_polygons": "_api",
    "write_granular_series": "_api",
    "write_image": "_api",
    "write_points": "_api",
    "write_polygons": "_api",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
