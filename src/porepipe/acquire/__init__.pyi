"""Type stub of porepipe.acquire: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.acquire._api import (
    Prepared as Prepared,
)
from porepipe.acquire._api import (
    acquire as acquire,
)
from porepipe.acquire._api import (
    central_window as central_window,
)
from porepipe.acquire._api import (
    image_statistics as image_statistics,
)
from porepipe.acquire._api import (
    open_image as open_image,
)
from porepipe.acquire._api import (
    prepare as prepare,
)
from porepipe.acquire._api import (
    write_binary as write_binary,
)
from porepipe.acquire._calibrate import (
    RadiusFit as RadiusFit,
)
from porepipe.acquire._calibrate import (
    calibrated_scene as calibrated_scene,
)
from porepipe.acquire._calibrate import (
    fit_radius_distribution as fit_radius_distribution,
)
from porepipe.acquire._calibrate import (
    write_scene_yaml as write_scene_yaml,
)
from porepipe.acquire._compare import (
    compare as compare,
)
from porepipe.acquire._compare import (
    comparison_markdown as comparison_markdown,
)
from porepipe.acquire._compare import (
    plot_comparison as plot_comparison,
)
from porepipe.acquire._compare import (
    write_comparison as write_comparison,
)
from porepipe.acquire._io import (
    Image as Image,
)
from porepipe.acquire._io import (
    read_image as read_image,
)
from porepipe.acquire._io import (
    require_spacing as require_spacing,
)
from porepipe.acquire._matching import (
    match_statistics as match_statistics,
)
from porepipe.acquire._model import (
    model_grey as model_grey,
)
from porepipe.acquire._model import (
    run_model as run_model,
)
from porepipe.acquire._prepare import (
    GreyHistogram as GreyHistogram,
)
from porepipe.acquire._prepare import (
    Phases as Phases,
)
from porepipe.acquire._prepare import (
    denoise as denoise,
)
from porepipe.acquire._prepare import (
    grey_histogram as grey_histogram,
)
from porepipe.acquire._prepare import (
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
    "match_statistics",
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
