from porepipe.export._api import export_result, grain_polygons, write_image, write_points, write_polygons

__all__ = ["export_result", "grain_polygons", "write_image", "write_points", "write_polygons"]
