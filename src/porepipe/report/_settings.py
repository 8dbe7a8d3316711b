"""Scene section ``report:``: what the accuracy-versus-cost report shows (HTML + PNG)."""

from __future__ import annotations

import enum

from pydantic import BaseModel, ConfigDict, Field


class ThesisTable(str, enum.Enum):
    """Tables of Zauner (2020) the report can put side by side with the scene's numbers."""

    t5_1 = "5.1"
    t5_2 = "5.2"
    t6_2 = "6.2"
    t6_3 = "6.3"
    t6_4 = "6.4"
    t7_2 = "7.2"
    t7_3 = "7.3"


class Clock(str, enum.Enum):
    """The clock a run's cost is read on."""

    cpu = "cpu"  # CPU seconds of the computation (all threads): what it costs, whatever else runs on the machine
    wall = "wall"  # wall seconds of the computation: what a user waits, on this machine at this load


class Settings(BaseModel):
    """Contents of ``results/<scene>/report/index.html``."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    quantities: list[str] = Field(
        default_factory=list,
        description="sweep quantities to plot against resolution; "
        "empty: all that vary with resolution (up to max_quantities)",
    )
    max_quantities: int = Field(
        12, ge=1, description="cap on quantity-versus-resolution figures when `quantities` is empty"
    )
    thesis_tables: list[ThesisTable] = Field(
        default_factory=lambda: [ThesisTable.t5_1, ThesisTable.t5_2, ThesisTable.t7_3],
        description="thesis tables to put beside the scene's values; a table is shown only where this scene produced "
        "numbers for it (5.1 and 5.2 also need `thesis_model`); 6.2, 6.3, 6.4 and 7.2 re-derive the thesis's own "
        "numbers and are checked by the test suite, so the page only lists them",
    )
    thesis_model: str | None = Field(
        None,
        description="row label of the thesis model the scene reproduces "
        "(e.g. 'PP' or 'FP' for Tables 5.1/5.2)",
    )
    thesis_rows_from: dict[str, str] = Field(
        default_factory=dict,
        description="more rows of Tables 5.1/5.2: thesis model -> name of the scene that reproduces it, a scene "
        "file <name>.yaml beside this one (e.g. {PP: thesis-5.6.1-pp} in the FP scene); the workflow runs it first "
        "and the report reads its results/<name>/sweep/sweep.h5",
    )
    slices: bool = Field(
        True, description="cross-sections of grey and binary volumes at each resolution (Fig. 7.3)"
    )
    slice_axis: int = Field(
        2, ge=0, le=2, description="axis normal to the cross-section (0 = x, 1 = y, 2 = z)"
    )
    cost_clock: Clock = Field(
        Clock.cpu,
        description="cost of a run in the accuracy-against-cost plot and headlines: `cpu` (CPU seconds of the "
        "computation, all threads; robust to other load on the machine) or `wall` (wall seconds); both exclude "
        "start-up",
    )
    dpi: int = Field(100, ge=30, le=300, description="PNG resolution")
