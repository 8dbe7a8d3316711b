"""Scene section ``packing``: sphere types, initial radii, and the staged DEM protocol (Zauner 2020, ch. 5, §9.2.3).

The box comes from the scene's ``domain`` (``size_um``, ``periodic``). Every optional protocol of §5.4 is a block
of a stage; a stage's *effect set* is the set of blocks it has, and only those effects are compiled into its
kernels (see :func:`Stage.effects`).
"""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

from porepipe._shared.run_control import RUN_CONTROL

PosFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting anywhere


class RadiusDist(str, enum.Enum):
    """Initial radius distributions of §5.1."""

    discrete = "discrete"  # radii r_j with probabilities P'(r_j) (inline or a `radii_prob` file)
    uniform = "uniform"  # P(r) = 1/(r_max - r_min) on [r_min, r_max]
    exponential = "exponential"  # P(r) ∝ alpha exp(-alpha r) on [r_min, r_max]


class Effect(str, enum.Enum):
    """Optional protocols of §5.4; each is compiled in only when a stage switches it on."""

    ramps = "ramps"  # time-dependent k and Xi (5.4.1, 5.4.2)
    stochastic_forces = "stochastic_forces"  # random forces on isolated, unconverged spheres (§5.4.2)
    adaptive_radii = "adaptive_radii"  # radius protocol (§5.4.3)
    freezing = "freezing"  # freeze converged spheres after lock_step (§5.4.4)
    frozen_types = "frozen_types"  # whole types held fixed (PackDEM `freezetype`)
    interactions_off = "interactions_off"  # type pairs that do not see each other (PackDEM `gww`)
    deletion = "deletion"  # remove types / unconverged spheres (PackDEM `delete`)
    walls = "walls"  # closed (reflecting) box faces instead of periodic ones


class RadiusSpec(_Strict):
    """Initial radius distribution of one type; ``min_um``/``max_um`` also bound the adaptive-radius protocol."""

    dist: RadiusDist = Field(RadiusDist.uniform, description="distribution family")
    min_um: PosFloat | None = Field(
        None, description="r_min in µm (uniform, exponential; default: min of values)"
    )
    max_um: PosFloat | None = Field(
        None, description="r_max in µm (uniform, exponential; default: max of values)"
    )
    alpha_per_um: NonNegFloat = Field(
        0.0, description="alpha of exp(-alpha r) in 1/µm; 0 gives uniform radii"
    )
    values_um: list[PosFloat] | None = Field(None, description="discrete radii r_j in µm")
    probabilities: list[NonNegFloat] | None = Field(None, description="P'(r_j), summing to 1")
    file: Path | None = Field(None, description="`radii_prob` file: one 'radius probability' pair per line")
    initial_um: PosFloat | None = Field(
        None, description="start every sphere at this radius (e.g. fines at r_max)"
    )

    @model_validator(mode="after")
    def _consistent(self):
        if self.dist is RadiusDist.discrete:
            if (self.values_um is None) == (self.file is None):
                raise ValueError("dist discrete needs exactly one of values_um (+ probabilities) or file")
            if self.values_um is not None:
                probs = self.probabilities
                if probs is None or len(probs) != len(self.values_um):
                    raise ValueError("probabilities must give one P'(r_j) per entry of values_um")
                if abs(sum(probs) - 1.0) > 1e-6:
                    raise ValueError(f"probabilities must sum to 1, they sum to {sum(probs)!r}")
        else:
            if self.min_um is None or self.max_um is None:
                raise ValueError(f"dist {self.dist.value} needs min_um and max_um")
            if self.min_um > self.max_um:
                raise ValueError(f"min_um = {self.min_um} exceeds max_um = {self.max_um}")
        return self


class SphereType(_Strict):
    """One sphere type t (PackDEM `phases`): how many, how large, how much overlap is allowed."""

    name: str = Field(pattern=r"^[A-Za-z][A-Za-z0-9_-]*$", description="type name used by the stages")
    count: int | None = Field(None, ge=0, description="number of spheres N_t")
    number_density_per_um3: NonNegFloat | None = Field(
        None, description="rho_t in spheres per µm³ of the type's region (alternative to count)"
    )
    radius_um: RadiusSpec = Field(description="initial radius distribution")
    max_overlap: float = Field(0.3, gt=0, le=1, description="sigma_max of the type (§5.1)")

    @model_validator(mode="after")
    def _count_or_density(self):
        if (self.count is None) == (self.number_density_per_um3 is None):
            raise ValueError("give exactly one of count or number_density_per_um3")
        if self.radius_um.dist is not RadiusDist.discrete and self.radius_um.min_um is None:
            raise ValueError("radius_um needs min_um and max_um")
        return self


class Regions(_Strict):
    """Sub-regions with their own type (PackDEM `gfile`/`gres`): cubes of side ``cube_um``, x fastest."""

    cube_um: PosFloat = Field(description="region cube edge (gres) in µm; must divide the box")
    types: list[str] | None = Field(None, description="type name per cube, x index fastest, then y, then z")
    file: Path | None = Field(None, description="gfile: whitespace-separated 1-based type numbers per cube")

    @model_validator(mode="after")
    def _one_source(self):
        if (self.types is None) == (self.file is None):
            raise ValueError("give exactly one of types or file")
        return self


class Ramp(_Strict):
    """Linear ramp (5.4.1): ``start`` before ``from_step``, ``end`` from ``to_step`` on, linear in between."""

    start: NonNegFloat
    end: NonNegFloat
    from_step: int = Field(ge=0, description="S^0 (stage-local step)")
    to_step: int = Field(ge=0, description="S^1 (stage-local step)")

    @model_validator(mode="after")
    def _ordered(self):
        if self.to_step < self.from_step:
            raise ValueError(f"to_step = {self.to_step} is before from_step = {self.from_step}")
        return self


Schedule = NonNegFloat | Ramp


class Freezing(_Strict):
    """§5.4.4: from stage step ``lock_step`` on, converged spheres are frozen (and unfrozen when they unconverge)."""

    lock_step: int = Field(10, ge=0, description="s_lock")


class AdaptiveRadii(_Strict):
    """§5.4.3 radius protocol."""

    types: list[str] = Field(description="types whose radii adapt (PackDEM `radiitype`)")
    trigger: float = Field(0.1, description="t_rc: active while (N_c^s - N_c^{s-1}) / N_c^s < t_rc")
    rate: PosFloat = Field(
        0.02, description="delta r: change per step in units of (r_max - r_min) of the type"
    )
    from_step: int = Field(0, ge=0, description="s^0_rchg (exclusive)")
    to_step: int = Field(10**9, ge=0, description="s^1_rchg (exclusive)")
    quiet_steps: int = Field(
        10, ge=0, description="s_nrc: no radius change in the last s_nrc steps of the stage"
    )


class StochasticForces(_Strict):
    """§5.4.2 random forces on spheres that feel no pair force and are not converged."""

    step_size: PosFloat = Field(
        0.1, description="largest random displacement per step and axis, in own radii"
    )
    types: list[str] | None = Field(None, description="affected types (default: all)")


class SphereFormat(str, enum.Enum):
    """File formats of PackDEM's ``input_file`` (§9.2.3)."""

    auto = "auto"  # by suffix: .h5/.hdf5 -> packing, .dat -> dat, anything else -> xyzr
    xyzr = "xyzr"  # ASCII 'x y z r' per line (µm)
    dat = "dat"  # ASCII 'index type x y z r' per line, type = 1-based number of the scene's types
    packing = "packing"  # a porepipe packing.h5 (types by name)


class SphereFile(_Strict):
    """Spheres read from a file (PackDEM ``init = file``): e.g. a primary packing made once, filled many ways."""

    path: Path = Field(description="the file, relative to the scene file")
    format: SphereFormat = Field(SphereFormat.auto, description="file format")
    type: str | None = Field(
        None,
        description="type of every sphere in the file (required for xyzr; for dat and "
        "packing files it overrides the types in the file)",
    )


class Stage(_Strict):
    """One run of the DEM (a `phase` of §5.6): it starts from the previous stage's spheres."""

    name: str = Field("stage", description="label in the history")
    insert: list[str] = Field(
        default_factory=list, description="types placed randomly at the start of this stage"
    )
    insert_file: SphereFile | None = Field(
        None, description="spheres read from a file at the start of this stage (before the random inserts)"
    )
    remove_types: list[str] = Field(
        default_factory=list, description="types deleted at the start of this stage"
    )
    steps: int = Field(1000, ge=1, description="step limit s_max of the stage (PackDEM `Steps`)")
    dt: PosFloat = Field(0.5, description="time step Delta t")
    k: dict[str, Schedule] = Field(
        default_factory=dict, description="interaction constant per type (default 1)"
    )
    damping: dict[str, Schedule] = Field(
        default_factory=dict, description="Xi per type (default 1); Xi <= 2/dt"
    )
    frozen_types: list[str] = Field(
        default_factory=list, description="types held fixed (PackDEM `freezetype`)"
    )
    interactions_off: list[tuple[str, str]] = Field(
        default_factory=list, description="type pairs without interaction (forces and overlaps)"
    )
    freezing: Freezing | None = Field(None, description="freeze converged spheres (§5.4.4)")
    adaptive_radii: AdaptiveRadii | None = Field(None, description="radius protocol (§5.4.3)")
    stochastic_forces: StochasticForces | None = Field(None, description="random forces (§5.4.2)")
    delete_unconverged: list[str] = Field(
        default_factory=list,
        description="types whose unconverged spheres are removed at the end of the stage",
    )

    @model_validator(mode="after")
    def _damping_limit(self):
        limit = 2.0 / self.dt
        for name, sched in self.damping.items():
            for value in (sched.start, sched.end) if isinstance(sched, Ramp) else (sched,):
                if value > limit:
                    raise ValueError(
                        f"damping[{name}] = {value} exceeds 2/dt = {limit}: C- = 1 - dt Xi/2 would be "
                        "negative and reverse the motion; lower the damping or the time step"
                    )
        return self

    def effects(self, periodic: tuple[bool, bool, bool] = (True, True, True)) -> frozenset[Effect]:
        """The set of optional effects this stage switches on (the kernels are built from it)."""
        out = set()
        if any(isinstance(s, Ramp) and s.start != s.end for s in (*self.k.values(), *self.damping.values())):
            out.add(Effect.ramps)
        if self.stochastic_forces is not None:
            out.add(Effect.stochastic_forces)
        if self.adaptive_radii is not None:
            out.add(Effect.adaptive_radii)
        if self.freezing is not None:
            out.add(Effect.freezing)
        if self.frozen_types:
            out.add(Effect.frozen_types)
        if self.interactions_off:
            out.add(Effect.interactions_off)
        if self.delete_unconverged or self.remove_types:
            out.add(Effect.deletion)
        if not all(periodic):
            out.add(Effect.walls)
        return frozenset(out)


class Settings(_Strict):
    """The ``packing`` section of a scene (the thesis's PackDEM, ch. 5)."""

    types: list[SphereType] = Field(default_factory=list, description="sphere types t = 1..N_g")
    regions: Regions | None = Field(None, description="sub-regions with their own type (gfile/gres)")
    stages: list[Stage] = Field(default_factory=list, description="the protocol, one run after the other")
    cutoff: float = Field(1.3, ge=1.0, le=3.0, description="dx_cut: no force beyond cutoff * dx_eq (5.2.4)")
    mass: PosFloat = Field(1.0, description="sphere mass m_i (1 in all thesis runs)")
    initial_velocity: tuple[float, float, float] = Field((0.0, 0.0, 0.0), description="v of every new sphere")
    skin_rel: PosFloat = Field(0.3, description="Verlet skin in units of the smallest radius")
    rebuild_interval: int = Field(
        0,
        ge=0,
        description="0: rebuild neighbour lists by the displacement criterion (exact); n > 0: every n "
        "steps only (the thesis's multiple-time-step approximation s_mts, may miss partners)",
    )
    max_step_fraction: float = Field(
        0.25,
        gt=0,
        le=0.5,
        description="stability guard: a sphere moving more than this fraction of the smallest box "
        "edge in one step stops the run",
    )
    checkpoint_every: int = Field(
        0,
        ge=0,
        json_schema_extra=RUN_CONTROL,
        description="with a checkpoint file: also write it every n steps (0: by wall time only); run control, "
        "the packing does not depend on it",
    )
    checkpoint_every_s: NonNegFloat = Field(
        300.0,
        json_schema_extra=RUN_CONTROL,
        description="with a checkpoint file: write it once this many wall seconds have passed since the last one "
        "(or the start), besides every checkpoint_every steps (0: by steps only); run control",
    )
    parallel_min_spheres: int = Field(
        20000,
        ge=0,
        json_schema_extra=RUN_CONTROL,
        description="stages with fewer spheres run on one thread (thread start-up costs more than it "
        "saves; results are identical for any thread count)",
    )
    progress_every_s: PosFloat = Field(
        10.0, json_schema_extra=RUN_CONTROL, description="seconds between progress lines"
    )

    @model_validator(mode="after")
    def _names(self):
        names = [t.name for t in self.types]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"type names must be unique, repeated: {dup}")
        known = set(names)
        for i, st in enumerate(self.stages):
            refs = {
                "insert": st.insert,
                "remove_types": st.remove_types,
                "k": list(st.k),
                "damping": list(st.damping),
                "frozen_types": st.frozen_types,
                "interactions_off": [n for pair in st.interactions_off for n in pair],
                "delete_unconverged": st.delete_unconverged,
            }
            if st.adaptive_radii is not None:
                refs["adaptive_radii.types"] = st.adaptive_radii.types
            if st.insert_file is not None and st.insert_file.type is not None:
                refs["insert_file.type"] = [st.insert_file.type]
            if st.stochastic_forces is not None and st.stochastic_forces.types is not None:
                refs["stochastic_forces.types"] = st.stochastic_forces.types
            for key, used in refs.items():
                bad = sorted(set(used) - known)
                if bad:
                    raise ValueError(
                        f"stages[{i}].{key} names unknown type(s) {bad}; known types: {sorted(known)}"
                    )
        if self.regions is not None and self.regions.types is not None:
            bad = sorted(set(self.regions.types) - known)
            if bad:
                raise ValueError(f"regions.types names unknown type(s) {bad}; known types: {sorted(known)}")
        return self
