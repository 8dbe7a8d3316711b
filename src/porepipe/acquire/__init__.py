"""Data acquisition: read µ-CT / SEM images, segment them, measure their statistics, calibrate a model, compare."""

from porepipe.acquire._api import Prepared, acquire, central_window, image_statistics, open_image, prepare, write_binary
from porepipe.acquire._calibrate import RadiusFit, calibrated_scene, fit_radius_distribution, write_scene_yaml
from porepipe.acquire._compare import compare, comparison_markdown, plot_comparison, write_comparison
from porepipe.acquire._io import Image, read_image, require_spacing
from porepipe.acquire._model import match_porosity, model_grey, run_model
from porepipe.acquire._prepare import GreyHistogram, Phases, denoise, grey_histogram, segment_phases
from porepipe.acquire._settings import Settings

__all__ = [
    "GreyHistogram", "Image", "Phases", "Prepared", "RadiusFit", "Settings", "acquire", "calibrated_scene",
    "central_window", "compare", "comparison_markdown", "denoise", "fit_radius_distribution", "grey_histogram",
    "image_statistics", "match_porosity", "model_grey", "open_image", "plot_comparison", "prepare", "read_image",
    "require_spacing", "run_model", "segment_phases", "write_binary", "write_comparison", "write_scene_yaml",
]
