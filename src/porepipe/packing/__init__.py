"""DEM packing of overlapping spheres (the thesis's PackDEM, Zauner 2020, ch. 5)."""

from porepipe.packing._api import Packing, pack_spheres, schedule_value, sphere_overlaps
from porepipe.packing._io import read_packing, write_packing, write_xyzr_file
from porepipe.packing._neighbours import build_neighbours
from porepipe.packing._settings import Effect, RadiusDist, Settings
from porepipe.packing._setup import sample_radii

__all__ = ["Effect", "Packing", "RadiusDist", "Settings", "build_neighbours", "pack_spheres", "read_packing",
           "sample_radii", "schedule_value", "sphere_overlaps", "write_packing", "write_xyzr_file"]
