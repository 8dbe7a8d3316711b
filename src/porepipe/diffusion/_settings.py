"""Scene section ``diffusion``: Knudsen diffusion in the voxel pore space (Mahler 2001, ch. 2-3)."""

from __future__ import annotations

import enum

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from porepipe._shared.overrides import MERGED_CONTEXT
from porepipe.diffusion._capillary import CapillaryGeometry


def known_species(value: str) -> str:
    """``value`` if it names a species of the built-in table, else a ValueError listing the allowed names."""
    from porepipe.diffusion._species import SPECIES

    if value not in SPECIES:
        raise ValueError(f"unknown species {value!r}; allowed: {', '.join(SPECIES)}")
    return value


class Axis(str, enum.Enum):
    """Transport axis: particles enter at its low face and leave at its high face."""

    x = "x"
    y = "y"
    z = "z"

    @property
    def index(self) -> int:
        return "xyz".index(self.value)


class Setup(str, enum.Enum):
    """What is simulated (thesis §3.6)."""

    transmission = "transmission"  # enter at the inlet face, count outlet vs back at the inlet: W, D = v̄LW/4
    wicke_kallenbach = (
        "wicke_kallenbach"  # two-species counter-diffusion, REFLEX/FLUSS with swap (§3.6.3, 3.45)
    )
    msd = "msd"  # periodic medium, mean-square displacement -> D_eff tensor (xx, yy, zz)
    edmd = (
        "edmd"  # event-driven hard-sphere gas in the pore space (§3.3-3.6): collisions, λ_eff, Kn, D_self, MB
    )
    reaction = (
        "reaction"  # wall reaction A -> P (-> S) in a one-face-fed pore, Knudsen regime (§4.1-4.2): η, Φ
    )
    surface = (
        "surface"  # adsorption, surface hops, Langmuir-Hinshelwood / Eley-Rideal in a closed pore (§4.3-4.4)
    )


class WallLaw(str, enum.Enum):
    """Direction after a wall hit (§3.5.3)."""

    lambert = "lambert"  # cosine per solid angle (Knudsen's law; sin^2 θ uniform) — the default
    cosine_dtheta = "cosine_dtheta"  # the thesis's (3.31) read per dθ: sin θ uniform
    isotropic = "isotropic"  # cos θ uniform: the thesis's production law (GWisotrop)
    specular = "specular"  # angle in = angle out


class InletLaw(str, enum.Enum):
    """Direction of a particle entering through an open face."""

    lambert = "lambert"  # a reservoir's flux crossing a plane (exact for an equilibrium gas)
    isotropic = "isotropic"  # uniform over the inward hemisphere (thesis §5.2)


class WallSpeed(str, enum.Enum):
    """Speed of a particle leaving a wall."""

    kept = "kept"  # |v| unchanged at a wall (thesis)
    thermal = "thermal"  # re-emitted with a speed from the flux-weighted Maxwell-Boltzmann law


class SpeedDist(str, enum.Enum):
    """Speed distribution of particles entering at the inlet (or started in the pore space)."""

    flux = "flux"  # flux-weighted MB, f ~ v^3 exp(-v^2/2s^2): particles crossing a plane (exact for an inlet)
    maxwell = "maxwell"  # MB f ~ v^2 exp(-v^2/2s^2) (thesis 3.2, its choice also for re-injection)
    mean = "mean"  # every particle at v̄


class GasSettings(BaseModel):
    """``diffusion.gas``: the event-driven hard-sphere gas of setup ``edmd`` (Mahler 2001 §3.3-3.6)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    particles: dict[str, int] = Field(
        default_factory=lambda: {"N2": 1000}, description="particles per species (Table 3.1 names)"
    )
    voxel_nm: float = Field(0.0, ge=0, description="voxel edge in nm; 0 = the volume's voxel_um")
    duration_ps: float = Field(200.0, gt=0, description="simulated time in ps")
    samples: int = Field(20, ge=4, description="sample times of the msd curve")
    collisions: bool = Field(True, description="gas-gas collisions (off = Knudsen regime, point particles)")
    initial_speed: str = Field(
        "maxwell", description="maxwell, or mean (all at v̄: the §3.6.2 relaxation test)"
    )
    speed_bins: int = Field(40, ge=1, description="bins of the final speed histogram")
    orientation_bins: int = Field(
        0,
        ge=0,
        description="bins of cos(angle to the axis) of the velocity-orientation histogram over the sample times "
        "(azimuth gets 2x as many; thesis Figs. 3.21-3.22); 0 = off",
    )

    @field_validator("particles")
    @classmethod
    def _species(cls, value):
        from porepipe.diffusion._species import SPECIES

        for name, n in value.items():
            if name not in SPECIES:
                raise ValueError(f"unknown species {name!r}; allowed: {', '.join(SPECIES)}")
            if n < 0:
                raise ValueError(f"particle count of {name} must be >= 0, got {n}")
        if sum(value.values()) < 1:
            raise ValueError("the gas needs at least one particle")
        return value

    @field_validator("initial_speed")
    @classmethod
    def _speed(cls, value):
        if value not in ("maxwell", "mean"):
            raise ValueError(f"initial_speed must be maxwell or mean, got {value!r}")
        return value


class SurfaceSpecies(BaseModel):
    """One species of setup ``surface`` (``diffusion.surface.species``)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=True)  # residence may be .inf

    name: str = Field(description="gas (thesis Table 3.1 name, or 'butene'); sets the mean speed")
    gas: int = Field(0, ge=0, description="particles starting in the gas")
    adsorbed: int = Field(0, ge=0, description="particles starting adsorbed on random active sites")
    adsorption: float = Field(
        0.0, ge=0, le=1, description="probability that a hit on an empty active site adsorbs"
    )
    residence_jiffies: float = Field(
        float("inf"), gt=0, description="mean residence time (.inf: never desorbs)"
    )
    hop_rate: float = Field(0.0, ge=0, allow_inf_nan=False, description="surface hops per jiffie")

    @field_validator("name")
    @classmethod
    def _known(cls, value):
        return known_species(value)


class SurfaceMechanism(BaseModel):
    """A bimolecular surface reaction of setup ``surface``: LH (both adsorbed) or ER (``a`` from the gas)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    kind: str = Field(pattern="^(LH|ER)$", description="LH (Langmuir-Hinshelwood) or ER (Eley-Rideal)")
    a: str = Field(description="first reactant (ER: the gas-phase one)")
    b: str = Field(description="second reactant (adsorbed)")
    product: str = Field(description="product species")
    w: float = Field(ge=0, le=1, description="reaction probability per encounter (LH) or per hit on b (ER)")
    w_reverse: float = Field(
        0.0,
        ge=0,
        le=1,
        description=(
            "ER: product hit on an empty active site → gas a + adsorbed b (4.18); LH: an arriving product tries "
            "each empty active neighbour site → a on its site + b there (§4.3.2; needs replenish: false)"
        ),
    )


class SurfaceSideReaction(BaseModel):
    """A side or consecutive reaction of setup ``surface``: ``reactant`` turns into ``product`` with probability
    ``w`` at a gas wall hit (``phase: gas``, thesis 4.20-4.22) or when it arrives on a site (``phase: adsorbed``,
    by-products of adsorbed species, thesis §4.3.2; the by-product stays on the site).
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    reactant: str = Field(
        description="species hitting the wall or arriving on a site (A, B or the product P)"
    )
    product: str = Field(description="by-product species (S, S', S'')")
    w: float = Field(ge=0, le=1, description="probability per gas wall hit (gas) or per arrival (adsorbed)")
    phase: str = Field(
        "gas",
        pattern="^(gas|adsorbed)$",
        description="gas: at a wall hit of the gas reactant; adsorbed: on arrival (adsorption or hop) on a site",
    )


class SurfaceSettings(BaseModel):
    """``diffusion.surface``: setup ``surface`` (porepipe.diffusion._surface) in the scene's pore space, closed."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    species: list[SurfaceSpecies] = Field(
        default_factory=list, description="species with counts and surface data"
    )
    mechanisms: list[SurfaceMechanism] = Field(
        default_factory=list, description="LH and/or ER (at most one each)"
    )
    side_reactions: list[SurfaceSideReaction] = Field(
        default_factory=list,
        description="side reactions at gas wall hits or on the surface (at most one per reactant and phase)",
    )
    duration_jiffies: float = Field(1000.0, gt=0, description="simulated time")
    warmup_jiffies: float = Field(100.0, ge=0, description="time before the tallies start")
    sites_per_edge: int = Field(
        2, ge=1, description="sites per voxel-face edge (reactive distance = h / this)"
    )
    neighbours: str = Field(
        "face",
        pattern="^(face|surface)$",
        description="hop / LH partner sites: in-face only, or also across voxel edges (surface)",
    )
    active_fraction: float = Field(1.0, gt=0, le=1, description="fraction of active sites (the thesis's a)")
    residence_law: str = Field(
        "exponential", pattern="^(fixed|exponential)$", description="fixed or exponential"
    )
    replenish: bool = Field(False, description="count products and put both reactants back into the gas")
    blocks: int = Field(16, ge=2, description="time blocks for the error bars")
    samples: int = Field(20, ge=0, description="sample times of the gas/adsorbed counts")


class ReactionSet(BaseModel):
    """One run of a reaction study (``diffusion.reactions.series``): A → P with ``w``, P → A with ``w_reverse``,
    P → S with ``w_follow``.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    w: float = Field(gt=0, le=1, description="probability that a wall hit turns A into P")
    w_reverse: float = Field(0.0, ge=0, le=1, description="probability that a wall hit turns P back into A")
    w_follow: float = Field(0.0, ge=0, le=1, description="probability that a wall hit turns P into S")


class ReactionSettings(BaseModel):
    """``diffusion.reactions``: wall reactions of setup ``reaction`` (§4.1-4.2); each effect is compiled in only
    when its probability is > 0.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    w: float = Field(0.01, ge=0, le=1, description="probability that a wall hit turns A into P")
    w_reverse: float = Field(0.0, ge=0, le=1, description="probability that a wall hit turns P back into A")
    w_follow: float = Field(
        0.0, ge=0, le=1, description="probability that a wall hit turns P into S (A -> P -> S)"
    )
    particles: int = Field(20000, ge=2, description="reactant histories (each enters at the inlet face)")
    z_bins: int = Field(32, ge=0, description="axial bins of the reactive-hit map z_R(z) (0 = off)")
    adsorption: float = Field(0.0, ge=0, le=1, description="probability that a wall hit adsorbs the particle")
    residence_jiffies: float = Field(0.0, ge=0, description="mean residence time of an adsorbed particle")
    residence_law: str = Field("fixed", pattern="^(fixed|exponential)$", description="fixed or exponential")
    poisoning: float = Field(
        0.0,
        ge=0,
        description="site activity decays by exp(-poisoning) per reaction at a voxel (between rounds)",
    )
    rounds: int = Field(1, ge=1, description="rounds of `particles` histories (poisoning acts between them)")
    series: list[ReactionSet] = Field(
        default_factory=list,
        description="a study (thesis Tables 4.2-4.4): one run of `particles` histories per set instead of the single "
        "w / w_reverse / w_follow; a set with w_follow > 0 also runs its reference without the follow-up "
        "(selectivity S)",
    )


#: what one run computes: the setup, with a transmission length series and a reaction study apart (they read fewer
#: settings than a single run of their setup) -> how a message names it
MODES = {
    "transmission": "setup transmission",
    "length_series": "a length series (setup transmission with diffusion.lengths)",
    "wicke_kallenbach": "setup wicke_kallenbach",
    "msd": "setup msd",
    "edmd": "setup edmd",
    "reaction": "setup reaction",
    "reaction_study": "a reaction study (setup reaction with diffusion.reactions.series)",
    "surface": "setup surface",
}
_TRANSPORT = ("transmission", "length_series", "wicke_kallenbach", "msd")  # the rounds of batches of flights

#: the one table of setup-specific settings: setting (``section.key`` inside a nested section) -> the modes that read
#: it. A scene that sets one explicitly for a run of any other mode is refused (``porepipe validate``), so is
#: ``Settings(...)`` given one in Python (a ValidationError, a ValueError), and so is the command-line option of a
#: listed setting (``porepipe diffusion``): each would be ignored without a word. A key of a nested section not listed
#: itself is read wherever its section is. Settings every mode reads (setup, axes,
#: resolutions_um, wall_law, geometry) are not listed, nor lengths (checked below: it needs setup transmission). A
#: length series keeps W and D in voxel²/jiffie only (no m²/s: species and temperature have no effect), and its W
#: does not depend on speeds; a reaction study takes w, w_reverse and w_follow from its series and has no z_R(z)
#: map, adsorption or poisoning rounds; setups reaction and surface work in voxels and jiffies (surface's
#: speeds are relative to the fastest species, so the temperature cancels); setup edmd takes its particles, speeds and
#: histogram from diffusion.gas.
USED_BY = {
    "accommodation": (*_TRANSPORT, "edmd"),
    "wall_speed": ("transmission", "wicke_kallenbach", "msd", "edmd"),
    "inlet_law": ("transmission", "length_series", "wicke_kallenbach", "reaction", "reaction_study"),
    "inlet_speed": ("transmission", "wicke_kallenbach"),
    "initial_speed": ("msd",),
    "species": ("transmission", "wicke_kallenbach", "msd"),
    "temperature_K": ("transmission", "wicke_kallenbach", "msd", "edmd"),
    "target_rel_error": _TRANSPORT,
    "max_wall_hits": _TRANSPORT,
    "max_rounds": _TRANSPORT,
    "batches": (*_TRANSPORT, "reaction", "reaction_study"),
    "batch_particles": _TRANSPORT,
    "max_hits_per_particle": (*_TRANSPORT, "reaction", "reaction_study"),
    "profile_bins": ("transmission", "wicke_kallenbach"),
    "hit_map_bins": ("transmission", "wicke_kallenbach"),
    "orientation_bins": ("transmission", "wicke_kallenbach"),
    "wk_time_jiffies": ("wicke_kallenbach",),
    "msd_time_jiffies": ("msd",),
    "msd_samples": ("msd",),
    "gas": ("edmd",),
    "surface": ("surface",),
    "reactions": ("reaction", "reaction_study"),
    "reactions.w": ("reaction",),
    "reactions.w_reverse": ("reaction",),
    "reactions.w_follow": ("reaction",),
    "reactions.z_bins": ("reaction",),
    "reactions.adsorption": ("reaction",),
    "reactions.residence_jiffies": ("reaction",),
    "reactions.residence_law": ("reaction",),
    "reactions.poisoning": ("reaction",),
    "reactions.rounds": ("reaction",),
}


def used_by(setting: str) -> tuple[str, ...] | None:
    """The modes that read ``setting`` (``key`` or ``section.key``; see :data:`USED_BY`); None = every mode."""
    while setting not in USED_BY and "." in setting:
        setting = setting.rpartition(".")[0]
    return USED_BY.get(setting)


def run_mode(settings: Settings) -> str:
    """The key of :data:`MODES` that ``settings`` run: the setup, or a length series / reaction study."""
    if settings.setup is Setup.transmission and settings.lengths:
        return "length_series"
    if settings.setup is Setup.reaction and settings.reactions.series:
        return "reaction_study"
    return settings.setup.value


def readers_text(modes) -> str:
    """The modes ``modes`` as a message names them."""
    return " / ".join(MODES[m] for m in modes)


#: settings a scene (or ``Settings(...)``) may name where its run does not read them: the gas of a length series or
#: a reaction study (W, α, η and Φ are dimensionless, the same for every species) documents the study, and the result
#: records it; only the command line's --species is refused there
SCENE_MAY_NAME = frozenset({"species"})

#: key of the validation context that porepipe.scene sets when it validates a scene file (a refusal then speaks of
#: the scene's setup). Settings given for another setup are refused for a scene and for ``Settings(...)`` alike, but
#: not where merge_settings validates (context MERGED_CONTEXT): the command line lays its options over a scene's
#: whole section, every key of it then reads as given, and porepipe diffusion judges its options itself
SCENE_CONTEXT = "scene_file"


class Settings(BaseModel):
    """Knudsen (free-molecular) diffusion: point particles, exact voxel flights, diffuse or specular walls.

    A setting given explicitly that the chosen setup does not read (:data:`USED_BY`, e.g. ``reactions`` with setup
    transmission) is refused with a ValidationError (a ValueError) naming it and the setup, here as in a scene file.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, use_enum_values=False, allow_inf_nan=False)

    setup: Setup = Field(
        Setup.transmission, description="transmission, wicke_kallenbach, msd, edmd, reaction or surface"
    )
    axes: list[Axis] = Field(
        default_factory=lambda: [Axis.z], description="transport axes (one result file each)"
    )
    resolutions_um: list[float] = Field(
        default_factory=list, description="resolutions to run (subset of the scene's); empty = all"
    )
    wall_law: WallLaw = Field(WallLaw.lambert, description="diffuse law at a wall (or specular)")
    accommodation: float = Field(
        1.0, ge=0.0, le=1.0, description="Maxwell mixture: fraction of diffuse hits (1 = fully diffuse)"
    )
    wall_speed: WallSpeed = Field(WallSpeed.kept, description="speed after a wall hit: kept or thermal")
    inlet_law: InletLaw = Field(InletLaw.lambert, description="direction law of entering particles")
    inlet_speed: SpeedDist = Field(SpeedDist.flux, description="speed law of entering particles")
    initial_speed: SpeedDist = Field(
        SpeedDist.maxwell, description="speed law of particles placed in the pore space (msd)"
    )
    species: str = Field("N2", description="gas (thesis Table 3.1 name, or 'butene' of §4.2.3)")
    temperature_K: float = Field(298.15, gt=0, description="gas and wall temperature in K")
    target_rel_error: float = Field(
        0.01, gt=0, description="stop when the relative 1-σ error of W / D is below this"
    )
    max_wall_hits: int = Field(10**9, ge=1, description="stop after this many wall hits in total")
    max_rounds: int = Field(200, ge=1, description="stop after this many rounds")
    batches: int = Field(32, ge=2, description="independent particle streams (batches) per round")
    batch_particles: int = Field(256, ge=1, description="particles per batch and round")
    max_hits_per_particle: int = Field(
        10**7, ge=1, description="a particle is dropped (counted as truncated) after this many hits"
    )
    wk_time_jiffies: float = Field(
        0.0, ge=0, description="Wicke-Kallenbach lifetime per particle; 0 = 20 L^2 / (v̄ d)"
    )
    msd_time_jiffies: float = Field(0.0, ge=0, description="msd flight time per particle; 0 = 50 box lengths")
    msd_samples: int = Field(20, ge=4, description="sample times of the msd curve")
    profile_bins: int = Field(32, ge=0, description="axial bins of the concentration profile (0 = off)")
    hit_map_bins: int = Field(0, ge=0, description="bins per side of the wall-hit map per face (0 = off)")
    orientation_bins: int = Field(
        0,
        ge=0,
        description="bins of cos(angle to the axis) in the flight-orientation histogram "
        "(azimuth gets 2x as many); 0 = off",
    )
    lengths: list[int] = Field(
        default_factory=list,
        description="length series (setup transmission, thesis §3.6.4): W through the first L voxels along the axis "
        "for each L, and the fit 1/D = 1/D0 + alpha (r/L)/D0 (3.51); empty = off",
    )
    gas: GasSettings = Field(default_factory=GasSettings, description="event-driven gas (setup edmd)")
    surface: SurfaceSettings = Field(
        default_factory=SurfaceSettings, description="adsorbing gas and surface reactions (setup surface)"
    )
    reactions: ReactionSettings = Field(
        default_factory=ReactionSettings, description="wall reactions (setup reaction)"
    )

    geometry: CapillaryGeometry | None = Field(
        None,
        description="a synthetic capillary built per resolution instead of a segmented volume "
        "(kind: square|cylinder|slit|constricted|pocketed|rough, sizes in voxels or *_um)",
    )

    @field_validator("species")
    @classmethod
    def _known(cls, value):
        return known_species(value)

    @field_validator("lengths")
    @classmethod
    def _lengths(cls, value):
        if value and (len(value) < 2 or min(value) < 1 or len(set(value)) != len(value)):
            raise ValueError(f"lengths must be >= 2 distinct whole numbers of voxels >= 1, got {value}")
        return value

    @model_validator(mode="after")
    def _lengths_need_transmission(self):
        if self.lengths and self.setup is not Setup.transmission:
            raise ValueError(
                f"lengths (a length series) needs setup transmission, got setup {self.setup.value}"
            )
        return self

    @model_validator(mode="after")
    def _keys_its_setup_reads(self, info: ValidationInfo):
        """A setting given explicitly (``model_fields_set``, not a default) in a scene file or to ``Settings(...)``
        that this run's mode does not read (:data:`USED_BY`): one error at its key each; it was ignored without a
        word. Settings merged by merge_settings are not judged here (every key of the merged dump reads as given).
        """
        context = info.context or {}
        if context.get(MERGED_CONTEXT):
            return self
        whose = "this scene's setup" if context.get(SCENE_CONTEXT) else "the setup"
        mode = run_mode(self)
        setup = {
            "length_series": "transmission with diffusion.lengths (a length series)",
            "reaction_study": "reaction with diffusion.reactions.series (a reaction study)",
        }.get(mode, mode)
        errors, ignored = [], []
        for setting, modes in USED_BY.items():
            section, _, key = setting.rpartition(".")
            model = getattr(self, section) if section else self
            if (
                mode in modes
                or key not in model.model_fields_set
                or section in ignored
                or setting in SCENE_MAY_NAME
            ):
                continue
            ignored.append(setting)
            message = (
                f"read only by {readers_text(modes)}; {whose} is {setup}, which ignores it (leave it out, "
                "or choose a setup that reads it)"
            )
            errors.append(
                InitErrorDetails(
                    type=PydanticCustomError("ignored_by_setup", message),
                    loc=tuple(setting.split(".")),
                    input=getattr(model, key),
                )
            )
        if errors:
            raise ValidationError.from_exception_data(type(self).__name__, errors)
        return self

    @field_validator("axes")
    @classmethod
    def _some(cls, value):
        if not value or len(set(value)) != len(value):
            raise ValueError(f"axes must be a non-empty list of distinct x/y/z, got {value}")
        return value
