"""Frictional 2-D DEM of convex polygons with cohesion (gc2d, Schinner 2001)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "AngleMode": "_shapes",
    "Dist": "_shapes",
    "Frame": "_api",
    "Settings": "_settings",
    "Simulation": "_api",
    "check_convex": "_shapes",
    "ellipse_polygon": "_shapes",
    "polygon_overlap": "_api",
    "polygon_properties": "_shapes",
    "read_granular": "_run",
    "rectangle": "_shapes",
    "regular_polygon": "_shapes",
    "run": "_run",
    "time_step_rule": "_api",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
