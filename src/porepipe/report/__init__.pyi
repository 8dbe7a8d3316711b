"""Type stub of porepipe.report: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.report._analysis import (
    Reference as Reference,
)
from porepipe.report._analysis import (
    cost_per_digit as cost_per_digit,
)
from porepipe.report._analysis import (
    error_cost_table as error_cost_table,
)
from porepipe.report._analysis import (
    pareto_front as pareto_front,
)
from porepipe.report._analysis import (
    reference_limit as reference_limit,
)
from porepipe.report._analysis import (
    runs_of as runs_of,
)
from porepipe.report._analysis import (
    startup_table as startup_table,
)
from porepipe.report._analysis import (
    varying_quantities as varying_quantities,
)
from porepipe.report._api import (
    SECTIONS as SECTIONS,
)
from porepipe.report._api import (
    Context as Context,
)
from porepipe.report._api import (
    build_report as build_report,
)
from porepipe.report._thesis import (
    Table as Table,
)
from porepipe.report._thesis import (
    scene_tables as scene_tables,
)
from porepipe.report._thesis import (
    thesis_tables as thesis_tables,
)

__all__ = [
    "SECTIONS",
    "Context",
    "Reference",
    "Table",
    "build_report",
    "cost_per_digit",
    "error_cost_table",
    "pareto_front",
    "reference_limit",
    "runs_of",
    "scene_tables",
    "startup_table",
    "thesis_tables",
    "varying_quantities",
]
