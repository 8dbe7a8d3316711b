"""Data acquisition: read µ-CT / SEM images, segment them, measure their statistics, calibrate a model, compare."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    **dict.fromkeys(
        [
            "Prepared",
            "acquire",
            "central_window",
            "image_statistics",
            "open_image",
            "prepare",
            "write_binary",
        ],
        "_api",
    ),
    **dict.fromkeys(
        ["RadiusFit", "calibrated_scene", "fit_radius_distribution", "write_scene_yaml"], "_calibrate"
    ),
    **dict.fromkeys(["compare", "comparison_markdown", "plot_comparison", "write_comparison"], "_compare"),
    **dict.fromkeys(["Image", "read_image", "require_spacing"], "_io"),
    **dict.fromkeys(["model_grey", "run_model"], "_model"),
    "match_statistics": "_matching",
    **dict.fromkeys(["GreyHistogram", "Phases", "denoise", "grey_histogram", "segment_phases"], "_prepare"),
    "Settings": "_settings",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
