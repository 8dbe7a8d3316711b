"""Scene section ``decoration``: grain-type library, assignment of types to spheres, scaling and orientation.

Its presence switches decoration on (Zauner 2020, §4.7.1 step 3; §7.1; §8.2.2). Without it the spheres themselves are
the grains.
"""

from __future__ import annotations

import enum
import math
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from porepipe.voxelize import VoxelizeMethod

PosFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting


class Generator(str, enum.Enum):
    """How the types of a family are made."""

    quartz = "quartz"  # hexagonal prism with two hexagonal pyramidal caps (6 + 2·6 = 18 planes), perturbed
    random = "random"  # random convex polyhedron with a given number of facets and elongation
    file = "file"  # plane sets read from a text file (one type per name)
    sphere = "sphere"  # the sphere itself (an undecorated grain)


class ScaleRule(str, enum.Enum):
    """How a grain is scaled to its sphere of radius r (the grain centre is the sphere centre)."""

    equal_volume = "equal_volume"  # grain volume = 4/3 π r³
    circumscribed = "circumscribed"  # grain inside the sphere: max distance of a vertex from the centre = r
    inscribed = "inscribed"  # grain contains the sphere: min distance of a face plane from the centre = r


class OrientationMode(str, enum.Enum):
    """How grains are rotated."""

    uniform = "uniform"  # uniform (Haar) on SO(3)
    anisotropic = "anisotropic"  # grain z axis von Mises–Fisher about `axis`, uniform spin about it
    overlap_minimizer = "overlap_minimizer"  # uniform start, then the §8.2.2 minimiser of neighbour overlap


class Family(_Strict):
    """A family of grain types from one generator."""

    name: str = Field(pattern=r"^[A-Za-z][A-Za-z0-9_-]*$", description="family name used in `assign`")
    generator: Generator = Field(Generator.quartz, description="quartz, random, file or sphere")
    count: int = Field(1, ge=1, description="number of types to generate (quartz, random)")
    facets: int = Field(18, ge=4, le=400, description="planes per type (random); quartz always has 18")
    elongation: tuple[NonNegFloat, NonNegFloat] = Field(
        (0.0, 0.0),
        description="range [e_min, e_max] of elongation e = 1 − (short/long axis), drawn uniformly; "
        "quartz: extra prism length in units of the prism radius instead",
    )
    perturbation: NonNegFloat = Field(
        0.1, le=0.5, description="relative perturbation of plane normals and offsets"
    )
    file: Path | None = Field(None, description="plane file for generator file: lines 'type nx ny nz d'")

    @model_validator(mode="after")
    def _consistent(self):
        if (self.generator is Generator.file) != (self.file is not None):
            raise ValueError("give `file` exactly when generator is file")
        lo, hi = self.elongation
        if lo > hi:
            raise ValueError(f"elongation range [{lo}, {hi}] is reversed")
        if self.generator is Generator.random and hi >= 0.95:
            raise ValueError(f"elongation {hi} too large; allowed: e < 0.95 (axis ratio above 1/20)")
        return self


class Assignment(_Strict):
    """Which families spheres of one type and size class get, with probabilities."""

    sphere_type: int | None = Field(None, ge=0, description="sphere type index (packing `types`); None = any")
    radius_min_um: NonNegFloat = Field(0.0, description="size class: r >= radius_min_um")
    radius_max_um: float = Field(
        math.inf, gt=0, allow_inf_nan=True, description="size class: r < radius_max_um"
    )
    probabilities: dict[str, NonNegFloat] = Field(description="family name -> probability (sum 1)")

    @field_validator("probabilities")
    @classmethod
    def _sum_one(cls, probs):
        if not probs:
            raise ValueError("give at least one family")
        if abs(sum(probs.values()) - 1.0) > 1e-6:
            raise ValueError(f"probabilities must sum to 1, they sum to {sum(probs.values())!r}")
        return probs


class Orientation(_Strict):
    """Orientation sampling (§4.7.1 step 3) and the overlap minimiser (§8.2.2, Table 8.3)."""

    mode: OrientationMode = Field(
        OrientationMode.uniform, description="uniform, anisotropic or overlap_minimizer"
    )
    axis: tuple[float, float, float] = Field((0.0, 0.0, 1.0), description="preferred axis (anisotropic)")
    concentration: NonNegFloat = Field(0.0, description="von Mises–Fisher κ of the grain axis (0 = uniform)")
    trials_per_grain: int = Field(5, ge=1, description="N_K^OM: orientations tried per grain and pass")
    passes: int = Field(3, ge=1, description="N_Z^OM: passes over all grains")
    points_per_grain: int = Field(
        512, ge=16, description="quadrature points per grain for the overlap volume"
    )
    size_window: float = Field(
        0.0,
        ge=0.0,
        lt=1.0,
        allow_inf_nan=False,
        description="w: the minimiser also tries sizes s_nom·[1 − w, 1 + w] (0 = orientations only)",
    )
    volume_weight: float = Field(
        0.3,
        ge=0.0,
        le=1.0,
        allow_inf_nan=False,
        description="μ: a trial's cost is its overlap − μ·its volume (sizes only; see decorate._minimiser)",
    )
    cell_volume_um3: PosFloat | None = Field(
        None, description="V^OM: cells of the minimiser (None = exact neighbour lists)"
    )

    @field_validator("axis")
    @classmethod
    def _nonzero(cls, axis):
        if not all(math.isfinite(v) for v in axis) or math.hypot(*axis) == 0:
            raise ValueError(f"axis {axis} must be a finite non-zero vector")
        return axis

    @model_validator(mode="after")
    def _minimiser_only(self):
        if self.mode is not OrientationMode.overlap_minimizer:
            given = [k for k in ("size_window", "cell_volume_um3") if k in self.model_fields_set]
            if given:
                raise ValueError(
                    f"{', '.join(given)} need mode overlap_minimizer (mode is {self.mode.value})"
                )
        return self


class Settings(BaseModel):
    """Decoration of a sphere packing with polyhedral grains (section present = decoration on)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    families: list[Family] = Field(
        default_factory=lambda: [Family(name="quartz", generator=Generator.quartz, count=99)],
        min_length=1,
        description="grain-type families; default: 99 quartz types of 18 planes (§7.1)",
    )
    assign: list[Assignment] = Field(
        default_factory=list,
        description="rules, first match wins; spheres no rule matches draw a family uniformly",
    )
    scale: ScaleRule = Field(ScaleRule.equal_volume, description="equal_volume, circumscribed or inscribed")
    orientation: Orientation = Field(default_factory=Orientation, description="orientation sampling")
    method: VoxelizeMethod = Field(
        VoxelizeMethod.boundary, description="voxelisation: boundary (fast) or brute; identical grey values"
    )
    slab_planes: int = Field(32, ge=1, description="voxel planes per slab held in memory at once")

    @model_validator(mode="after")
    def _names(self):
        names = [f.name for f in self.families]
        if len(set(names)) != len(names):
            raise ValueError(f"family names must be distinct, got {names}")
        for i, rule in enumerate(self.assign):
            unknown = sorted(set(rule.probabilities) - set(names))
            if unknown:
                raise ValueError(f"assign[{i}] names unknown families {unknown}; known: {names}")
        return self
