"""DEM packing of overlapping spheres (the thesis's PackDEM, Zauner 2020, ch. 5)."""
