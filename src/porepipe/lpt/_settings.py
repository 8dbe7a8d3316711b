"""Scene section ``lpt:``: settings of the local-porosity-theory analysis (thesis §4.6, §4.6.1, §7.4, §8.3)."""

from __future__ import annotations

import enum
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator


class Placement(str, enum.Enum):
    """Where measurement cells are placed (the thesis leaves this open, §4.6).

    ``auto``: along an axis on which the sample is periodic the cells wrap around (every voxel is a cell origin);
    along the other axes only positions with the cell fully inside the sample are used.
    ``inside``: only positions with the cell fully inside the sample, on every axis, even a periodic one.
    """

    auto = "auto"
    inside = "inside"


class Connectivity(int, enum.Enum):
    """Which pore voxels are neighbours on a percolation path: 6 (shared face) or 26 (shared face, edge or corner)."""

    face = 6
    vertex = 26


class Direction(str, enum.Enum):
    """Direction index α of the local percolation indicator Λ_α (thesis Table 4.1)."""

    x = "x"
    y = "y"
    z = "z"
    all3 = "3"  # percolating in x and y and z
    any = "c"  # percolating in at least one of x, y, z


PositiveUm = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class Settings(BaseModel):
    """Local porosity distribution μ(φ, L), local S_V distribution and local percolation λ_α(φ, L), p_α(L)."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_enum_values=False, allow_inf_nan=False)

    cell_um: list[PositiveUm] = Field(
        default_factory=list,
        description="cell edge lengths L in µm; each is rounded to whole voxels at every resolution "
        "(the voxel value is stated in the output). Empty and no cell_voxels: powers of two 1, 2, 4 ... voxels "
        "up to the smallest sample edge.",
    )
    cell_voxels: list[Annotated[int, Field(ge=1)]] = Field(
        default_factory=list, description="cell edge lengths L in voxels (instead of cell_um, not with it)"
    )
    placement: Placement = Field(
        Placement.auto, description="auto: wrap on periodic axes; inside: never wrap"
    )
    mu_stride: int = Field(
        1, ge=1, description="distance in voxels between cell origins for μ and S_V (1 = all)"
    )
    lambda_stride: int | None = Field(
        None,
        ge=1,
        description="distance in voxels between cell origins for λ; None: the smallest stride that "
        "keeps the cell count at or below lambda_max_cells",
    )
    lambda_max_cells: int = Field(
        100_000, ge=1, description="cap on the percolation cells per L when lambda_stride is None"
    )
    connectivity: Connectivity = Field(Connectivity.face, description="pore-path connectivity: 6 or 26")
    directions: list[Direction] = Field(
        default_factory=lambda: list(Direction),
        description="percolation directions α to evaluate (Table 4.1)",
    )
    max_bins: int = Field(
        1001,
        ge=3,
        description="μ(φ, L) is exact on the porosities k/L³ while L³+1 <= max_bins; above, k = 1..L³-1 "
        "are binned into max_bins-2 bins (φ = 0 and φ = 1 keep their own bins)",
    )
    surface: bool = Field(True, description="also compute the local specific-surface distribution μ(S_V, L)")
    surface_bins: int = Field(
        201, ge=3, description="bins of μ(S_V, L) (S_V = 0 and the maximum keep their own)"
    )
    plots: bool = Field(True, description="write PNG plots of μ(φ,L), λ_α(φ,L), p_α(L) next to the data file")

    @field_validator("directions")
    @classmethod
    def _directions_distinct(cls, values):
        if not values:
            raise ValueError("give at least one direction of x, y, z, 3, c")
        if len(set(values)) != len(values):
            raise ValueError(f"directions must be distinct, got {[v.value for v in values]}")
        return values

    @model_validator(mode="after")
    def _one_kind_of_cell(self):
        if self.cell_um and self.cell_voxels:
            raise ValueError("give cell_um or cell_voxels, not both")
        for name in ("cell_um", "cell_voxels"):
            values = getattr(self, name)
            if len(set(values)) != len(values):
                raise ValueError(f"{name} must be distinct, got {values}")
        return self
