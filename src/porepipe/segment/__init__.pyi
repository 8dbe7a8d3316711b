"""Type stub of porepipe.segment: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.segment._api import (
    Threshold as Threshold,
)
from porepipe.segment._api import (
    choose_threshold as choose_threshold,
)
from porepipe.segment._api import (
    otsu_threshold as otsu_threshold,
)
from porepipe.segment._api import (
    segment as segment,
)

__all__ = [
    "Threshold",
    "choose_threshold",
    "otsu_threshold",
    "segment",
]
