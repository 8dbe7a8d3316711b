"""Type stub of porepipe.acquire: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.acquire._api import (
    Prepared as Prepared,
    acquire as acquire,
    central_window as central_window,
    image_statistics as image_statistics,
    open_image as open_image,
    prepare as prepare,
    write_binary as write_binary,
)
from porepipe.acquire._calibrate import (
    RadiusFit as RadiusFit,
    calibrated_scene as calibrated_scene,
    fit_radius_distribution as fit_radius_distribution,
    write_scene_yaml as write_scene_yaml,
)
from porepipe.acquire._compare import (
    compare as compare,
    comparison_markdown as comparison_markdown,
    plot_comparison as plot_comparison,
    write_comparison as write_comparison,
)
from porepipe.acquire._io import (
    Image as Image,
    read_image as read_image,
    require_spacing as require_spacing,
)
from porepipe.acquire._model import (
    match_porosity as match_porosity,
    model_grey as model_grey,
    run_model as run_model,
)
from porepipe.acquire._prepare import (
    GreyHistogram as GreyHistogram,
    Phases as Phases,
    denoise as denoise,
    grey_histogram as grey_histogram,
    segment_phases as segment_phases,
)
from porepipe.acquire._settings import (
    Settings as Settings,
)

__all__ = [
    "GreyHistogram",
    "Image",
    "Phases",
    "Prepared",
    "RadiusFit",
    "Settings",
    "acquire",
    "calibrated_scene",
    "central_window",
    "compare",
    "comparison_markdown",
    "denoise",
    "fit_radius_distribution",
    "grey_histogram",
    "image_statistics",
    "match_porosity",
    "model_grey",
    "open_image",
    "plot_comparison",
    "prepare",
    "read_image",
    "require_spacing",
    "run_model",
    "segment_phases",
    "write_binary",
    "write_comparison",
    "write_scene_yaml",
]
