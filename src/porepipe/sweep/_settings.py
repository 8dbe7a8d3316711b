"""Scene section ``sweep:``: sub-sample sizes of the resolution sweep, the extrapolation fit and the adaptive mode.

Zauner (2020) §4.6.1, §7.4 (Table 7.4: sub-samples cut from the same corner), §6.2 (Table 6.4: linear in 1/L_S),
§7.2 (linear in a), §7.5 (refine until the extrapolation is good enough).
"""

from __future__ import annotations

import enum
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

PositiveUm = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class Exponent(str, enum.Enum):
    """Exponent p of the fit q(a) = q∞ + c·a^p: fitted, or fixed at 1 (linear in a, i.e. in 1/L) or 2."""

    free = "free"
    linear = "linear"
    quadratic = "quadratic"


class Adaptive(BaseModel):
    """§7.5 iterative strategy: add the next finer resolution until the limit's error meets the target or the
    budget is spent.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    quantity: str | None = Field(
        None,
        description="sweep quantity to converge, e.g. 'estimate.phi_mean_grey' or "
        "'permeability_x.kappa_mD'; None: adaptive mode unused",
    )
    target_rel_err: float = Field(0.01, gt=0, lt=1, description="stop when err(q∞)/|q∞| is at or below this")
    budget_s: float | None = Field(None, gt=0, description="wall-seconds budget of all runs of the sweep")
    budget_voxels: int | None = Field(None, ge=1, description="budget in voxels summed over all resolutions")
    refine_factor: int = Field(2, ge=2, description="next resolution = finest / refine_factor")
    max_rounds: int = Field(6, ge=1, description="hard cap on refinement rounds")

    @model_validator(mode="after")
    def _one_budget(self):
        if self.quantity is not None and self.budget_s is None and self.budget_voxels is None:
            raise ValueError("adaptive mode needs a budget: budget_s or budget_voxels")
        return self


#: sub-samples a sweep can cut per size: the origin corner, or a 2³ / 4³ grid of cubes
SUBSAMPLE_COUNTS = (1, 8, 64)


class Settings(BaseModel):
    """Resolution and sample-size sweep gathered into ``sweep.h5``, with extrapolation to a → 0."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    sample_um: list[PositiveUm] = Field(
        default_factory=list,
        description="edges L in µm of cubic sub-samples cut from every "
        "binary volume (binary_a{a}_L{L}.h5); engines that accept them run on each",
    )
    subsamples: Literal[1, 8, 64] = Field(
        1,
        description="sub-samples per edge in sample_um: 1 = the origin corner (Table 7.4), 8 or 64 = a 2³ or 4³ "
        "grid of cubes spread evenly over the volume (Fig. 7.8); sweep.h5 holds their mean and spread (REV error)",
    )
    exponent: Exponent = Field(
        Exponent.free, description="p in q(a) = q∞ + c·a^p: free, linear (1) or quadratic (2)"
    )
    confidence: float = Field(0.95, gt=0.5, lt=1, description="coverage of the stated error bars of q∞")
    adaptive: Adaptive = Field(default_factory=Adaptive, description="adaptive refinement (§7.5)")

    @field_validator("sample_um")
    @classmethod
    def _distinct(cls, values):
        if len(set(values)) != len(values):
            raise ValueError(f"sample_um must be distinct, got {values}")
        return values
