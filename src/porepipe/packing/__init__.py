"""DEM packing of overlapping spheres (the thesis's PackDEM, Zauner 2020, ch. 5)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "Effect": "_settings",
    "Packing": "_api",
    "RadiusDist": "_settings",
    "Settings": "_settings",
    "build_neighbours": "_neighbours",
    "pack_spheres": "_api",
    "read_packing": "_io",
    "sample_radii": "_setup",
    "schedule_value": "_api",
    "sphere_overlaps": "_api",
    "write_packing": "_io",
    "write_xyzr_file": "_io",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
