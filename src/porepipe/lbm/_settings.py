"""Scene section ``permeability``: lattice-Boltzmann permeability (thesis ch. 6)."""

from __future__ import annotations

import enum

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from porepipe._shared.run_control import RUN_CONTROL


class Collision(str, enum.Enum):
    """Collision operator."""

    bgk = "bgk"  # single relaxation time (thesis Eq. 6.1.10); κ drifts with τ, calibrate τ
    trt = "trt"  # Ginzburg two-relaxation-time with magic parameter Λ
    mrt = "mrt"  # d'Humières multiple relaxation time with the thesis's rates (Eq. 6.1.14)


class Walls(str, enum.Enum):
    """Solid walls: halfway bounce-back, or interpolated bounce-back at the sub-voxel wall distance q."""

    halfway = "halfway"  # wall halfway between the nodes (staircase, first order on curved walls)
    cli = "cli"  # Ginzburg's central linear interpolation: one formula for all q, Λ-parametrised with TRT
    bfl = "bfl"  # Bouzidi-Firdaouss-Lallemand linear interpolation (two branches, convex weights)
    mr1 = "mr1"  # Ginzburg's multi-reflection MR1: exact for parabolic profiles, Λ-parametrised (TRT, BGK)


class Streaming(str, enum.Enum):
    """How the step kernel streams the populations (the results are the same bits either way)."""

    #: aa with halfway walls, and with cli/bfl (float64) where the arrays exceed the cache; else pull
    auto = "auto"
    #: in place, one population array (AA pattern): 1.3-2x faster here; not with mr1 or float32 links
    aa = "aa"
    pull = "pull"  # two arrays, pull from the neighbours


class StopRule(str, enum.Enum):
    """Which convergence rule ends the run."""

    kappa = (
        "kappa"  # κ̂ settled: change over a window and the geometric-tail error estimate below tolerance_kappa
    )
    density = "density"  # thesis Eq. 6.1.30: v and ρ changes over a window (and δκ) below their tolerances


class Setup(str, enum.Enum):
    """How the flow is driven."""

    periodic = "periodic"  # body force on every pore node, periodic along the flow (workflow default)
    chambers = "chambers"  # thesis §6.1.4: inlet chamber with force zone, sample, outlet chamber, periodic


class Lateral(str, enum.Enum):
    """Boundary across the flow."""

    periodic = "periodic"
    walls = "walls"  # halfway bounce-back walls just outside the sample's lateral faces


class Precision(str, enum.Enum):
    """Storage type of the populations (the arithmetic is float64 either way)."""

    float64 = "float64"
    float32 = "float32"


class Axis(str, enum.Enum):
    """Flow direction: array axis 0, 1 or 2 of the volume."""

    x = "x"
    y = "y"
    z = "z"

    @property
    def index(self) -> int:
        return "xyz".index(self.value)


class Gradient(str, enum.Enum):
    """Pressure-gradient estimate of the chamber set-up (thesis Table 6.3)."""

    ends = "ends"  # method 3 (Eq. 6.1.39): first and last sample slice; the thesis's choice
    fit = "fit"  # method 1: linear fit over all sample slices
    fit_trimmed = "fit_trimmed"  # method 2: fit without `trim_layers` slices at each end
    outside = "outside"  # method 4: the slices just outside the sample (rejected in the thesis, ~4.6 %)


class Velocity(str, enum.Enum):
    """Which superficial velocity enters Darcy's law."""

    mean = "mean"  # ⟨v⟩ over all sample voxels (solid = 0), thesis Eq. 6.1.35
    flux = "flux"  # mass flux through the cross-sections / (ρ̄ · area), thesis Eq. 6.1.24-25


#: largest relaxation time accepted. Bounce-back walls sit off their nominal place by an error that grows as
#: (τ̂ − ½)² with BGK and MRT, the run needs ~L²/ν̂ steps only while ν̂ = (τ̂ − ½)/3 stays O(1), and the thesis works
#: at τ̂ ≤ 2; τ̂ = inf used to run the whole step limit for nothing.
TAU_MAX = 5.0
#: largest TRT/MRT magic parameter Λ. τ⁻ = ½ + Λ/(τ⁺ − ½) grows with Λ, and with it the wall-slip error of halfway
#: bounce-back (exact only at Λ = 3/16): Λ = 1e9 "converged" to a κ 4× too high. Ginzburg's stable, accurate range
#: is 1/12 … 1/4; 1/2 leaves room for studies of the Λ dependence.
MAGIC_MAX = 0.5
#: smallest τ̂ accepted with ``walls: mr1``: with random q on a one-voxel throat and a perforated plate it diverged
#: at τ̂ = 0.51 and 0.52 (Λ = 3/16: τ⁻ = 19, 10) and converged from 0.55 on (tests/hard/test_lbm_hard.py).
MR1_TAU_MIN = 0.55


class Settings(BaseModel):
    """Lattice-Boltzmann permeability. Lattice units: voxel = Δx, step = Δt, ρ° = 1."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    axes: tuple[Axis, ...] = Field(
        (Axis.z,), min_length=1, description="flow directions; one result file each"
    )
    resolutions_um: list[float] = Field(
        default_factory=list,
        description="run only at these of the scene's resolutions (empty: all); fine lattices cost most",
    )
    whole_volume: bool = Field(
        True,
        description="run on the whole volume; false: only on the sweep's sub-samples (sweep.sample_um), "
        "where the whole lattice would cost too much",
    )
    collision: Collision = Field(
        Collision.trt, description="bgk, trt (default: Λ = magic makes κ̂ τ-independent) or mrt (the thesis's)"
    )
    tau: float = Field(
        0.857,
        gt=0.5,
        description="relaxation time τ̂ of the shear modes; ν̂ = (τ̂ − ½)/3 (0.5 < τ̂ ≤ 5)",
    )
    tau_bulk: float = Field(
        1.0, gt=0.5, description="MRT only: relaxation time of the energy moment (0.5 < τ̂ ≤ 5)"
    )
    magic: float = Field(
        3 / 16,
        gt=0,
        description="TRT magic parameter Λ = (τ⁺ − ½)(τ⁻ − ½); 3/16 = exact walls (0 < Λ ≤ 1/2)",
    )
    mrt_magic: float | None = Field(
        None,
        gt=0,
        description="MRT only: tie the q and m rates to τ by this Λ (None = thesis's fixed 1.2, 1.98)",
    )
    walls: Walls = Field(
        Walls.cli,
        description="halfway bounce-back, or cli/bfl/mr1 interpolated walls at the "
        "sub-voxel distance q (needs a geometry: spheres or grey values; else halfway); mr1: second-order "
        "multi-reflection (trt or bgk)",
    )
    streaming: Streaming = Field(
        Streaming.auto,
        description="auto (in place with halfway walls, and with cli/bfl in float64 where the arrays exceed the "
        "cache), aa (in-place AA pattern; not with walls: mr1 or float32 links) or pull (two arrays); the "
        "populations are the same bits either way",
    )
    setup: Setup = Field(Setup.periodic, description="periodic (body force everywhere) or chambers (thesis)")
    mirror: bool = Field(False, description="periodic set-up: append the sample mirrored along the flow axis")
    lateral: Lateral = Field(Lateral.periodic, description="boundary across the flow: periodic or walls")
    inlet_layers: int = Field(10, ge=2, description="chambers: inlet chamber length L_I in voxels")
    outlet_layers: int = Field(10, ge=1, description="chambers: outlet chamber length L_O in voxels")
    force_layers: int = Field(
        5, ge=1, description="chambers: force zone F = first layers of the inlet chamber"
    )
    body_force: float = Field(1e-6, gt=0, description="acceleration b̂ in lattice units (thesis: 1e-6)")
    sound_speed_m_s: float = Field(
        1.0,
        gt=0,
        allow_inf_nan=False,
        description="c_s of the pseudo-fluid; Δt = Δx/(√3 c_s) turns velocities into µm/s (thesis §6.2: 1 m/s)",
    )
    gradient: Gradient = Field(Gradient.ends, description="chambers: pressure-gradient method (Table 6.3)")
    trim_layers: int = Field(
        10, ge=0, description="chambers, gradient fit_trimmed: slices dropped at each end"
    )
    velocity: Velocity = Field(
        Velocity.mean, description="superficial velocity: mean over sample or flux form"
    )
    precision: Precision = Field(Precision.float64, description="population storage (arithmetic is float64)")
    prune: bool = Field(True, description="drop pore clusters that cannot carry flow before the run")
    tolerance_velocity: float = Field(
        1e-4, gt=0, description="max relative change of v over a window (6.1.30)"
    )
    tolerance_density: float = Field(
        1e-9, gt=0, description="max relative change of ρ over a window (6.1.30)"
    )
    stop: StopRule = Field(
        StopRule.kappa, description="kappa: stop when κ̂ has settled; density: thesis Eq. 6.1.30"
    )
    tolerance_kappa: float = Field(
        1e-5,
        gt=0,
        description="max relative change of κ̂ over a window and max "
        "estimated relative distance to the converged κ̂",
    )
    window_steps: int = Field(500, ge=10, description="steps dt between two convergence checks")
    max_steps: int = Field(200_000, ge=10, description="step limit; an unconverged run is an error")
    accept_unconverged: bool = Field(
        False, description="write a result (flagged) even if the step limit is hit"
    )
    mach_max: float = Field(0.1, gt=0, le=0.3, description="stop if max |v|/c_s exceeds this")
    write_fields: bool = Field(False, description="store velocity and pressure fields in the result")
    write_vti: bool = Field(False, description="also export the fields as VTK ImageData (.vti) for ParaView")
    checkpoint_every_s: float = Field(
        600.0, gt=0, json_schema_extra=RUN_CONTROL, description="wall seconds between checkpoints"
    )
    mpi_ranks: int = Field(
        0,
        ge=0,
        json_schema_extra=RUN_CONTROL,
        description="workflow: run each permeability job as `mpirun -n mpi_ranks porepipe permeability --mpi` "
        "(slabs along the flow; halfway walls; 0 = one process)",
    )

    @field_validator("tau", "tau_bulk")
    @classmethod
    def _tau_bounded(cls, value: float) -> float:
        if value > TAU_MAX:
            raise ValueError(
                f"{value} is above {TAU_MAX}: bounce-back walls drift off their place as (τ̂ − ½)², so κ̂ "
                "would be wrong; allowed: 0.5 < τ̂ ≤ 5 (the thesis uses τ̂ ≤ 2)"
            )
        return value

    @field_validator("magic", "mrt_magic")
    @classmethod
    def _magic_bounded(cls, value: float | None) -> float | None:
        if value is not None and value > MAGIC_MAX:
            raise ValueError(
                f"{value} is above {MAGIC_MAX}: τ⁻ grows with Λ and halfway walls slip (Λ = 1e9 gave κ 4× too "
                "high); allowed: 0 < Λ ≤ 1/2 (3/16 = exact walls, 1/4 = most stable)"
            )
        return value

    @model_validator(mode="after")
    def _mr1_needs_two_rates(self):
        if self.walls is Walls.mr1 and self.collision is Collision.mrt:
            raise ValueError(
                "walls=mr1 needs collision trt or bgk: its correction is built on the odd-moment rate ω⁻ of a "
                "two-relaxation-time operator; use walls=cli with mrt"
            )
        if self.walls is Walls.mr1 and self.tau < MR1_TAU_MIN:
            raise ValueError(
                f"walls=mr1 needs tau ≥ {MR1_TAU_MIN} (got {self.tau}): below it its correction diverged on a "
                "one-voxel throat and a perforated plate; raise `tau` or use walls=cli"
            )
        return self

    @model_validator(mode="after")
    def _aa_needs_linear_float64_walls(self):
        if self.streaming is not Streaming.aa or self.walls is Walls.halfway:
            return self
        if self.walls is Walls.mr1:
            raise ValueError(
                "streaming=aa cannot run walls=mr1: a multi-reflection link reads populations two nodes away from "
                "the previous step, which the in-place array no longer holds; use streaming=auto or pull"
            )
        if self.precision is Precision.float32:
            raise ValueError(
                f"streaming=aa with walls={self.walls.value} needs precision=float64: an interpolated link's value "
                "would be rounded to float32 in place (the pull kernel keeps it in float64); use streaming=auto"
            )
        return self

    @model_validator(mode="after")
    def _force_inside_inlet(self):
        if self.force_layers >= self.inlet_layers:
            raise ValueError(
                f"force_layers={self.force_layers} must be smaller than inlet_layers="
                f"{self.inlet_layers}: the force zone lies inside the inlet chamber"
            )
        return self
