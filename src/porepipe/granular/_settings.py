"""Scene section ``granular``: a 2-D DEM of convex polygons with friction (gc2d, Schinner 2001).

SI units throughout, named in the keys (``_m``, ``_s``, ``_kg_m2``, ``_N_m``); 2-D: Young's modulus in N/m,
density in kg/m². An optional effect (cohesion, velocity-weakening friction, variable gravity, vibrating walls,
wall surface velocity, drag springs) is compiled into the kernel only when the scene names it, i.e. when its
block or key is present with a non-trivial value.
"""

from __future__ import annotations

import enum
import math
from typing import Annotated

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from porepipe._shared.run_control import RUN_CONTROL
from porepipe.granular._shapes import AngleMode, Dist

PosFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Finite = Annotated[float, Field(allow_inf_nan=False)]
Vec2 = tuple[Finite, Finite]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting


class Integrator(str, enum.Enum):
    gear = "gear"  # 6-value Gear predictor-corrector, one correction (App. F, Tab. F.1 p = 2)
    verlet = "verlet"  # velocity Verlet (forces at the half-step velocity)


class NeighbourSearch(str, enum.Enum):
    sweep = "sweep"  # sort-and-sweep with insertion sort (§2.4.2)
    cells = "cells"  # uniform cell list
    swap = "swap"  # incremental sort-and-sweep with gc2d's swap rules (Tabs. 2.1/2.3), no sweep pass


class ShapeKind(str, enum.Enum):
    ellipse = "ellipse"  # random convex polygon on an ellipse (App. B.1.6)
    rectangle = "rectangle"  # a x b, optionally bevelled (cut) or rounded (App. D)


class Lattice(str, enum.Enum):
    rect = "RECT"
    fcc = "FCC"  # two offset square lattices


class Waveform(str, enum.Enum):
    cosinus = "COSINUS"
    sawtooth = "SAWTOOTH"
    tapping = "TAPPING"
    triangle = "TRIANGLE"


class GravityKind(str, enum.Enum):
    constant = "CONSTANT"
    linear = "LINEAR"
    step = "STEP"
    smooth_step = "SMOOTH_STEP"


class ApplicationPoint(str, enum.Enum):
    midpoint = "midpoint"  # midpoint of the contact line c1c2 (Fig. 2.4, the thesis's choice)
    centroid = "centroid"  # centroid of the overlap polygon: a flat face gets a restoring torque (no creep)


class DropMode(str, enum.Enum):
    abs = "ABS"  # insert at height y
    rel = "REL"  # insert at y above the highest centroid in the window


class Material(_Strict):
    """Contact law parameters (§2.2.2); one material for all particles and walls."""

    young_N_m: PosFloat = Field(1e7, description="E of F_n = E A / l (Eq. 2.20), N/m (2-D)")
    density_kg_m2: PosFloat = Field(5000.0, description="particle density rho, kg/m² (Eq. 2.10)")
    damping: NonNegFloat = Field(0.5, description="gamma of the normal damping (Eq. 2.21); 0 = elastic")
    friction: NonNegFloat = Field(0.6, description="Coulomb mu (Eq. 2.24)")
    tangential_damping: NonNegFloat = Field(1.0, description="factor on D_t = v_t sqrt(2/7 E m_t) (Eq. 2.26)")
    cohesion_N_m: NonNegFloat = Field(0.0, description="k_coh of F = k_coh x contact-line length (Eq. 2.28)")
    velocity_weakening: bool = Field(False, description="F_r = mu (|v_t|/1 m/s)^(-1/10) F_n (Eq. 2.25)")
    weakening_v_min_m_s: PosFloat = Field(
        1e-3, description="|v_t| floor of the weakening law (finite at rest)"
    )
    application_point: ApplicationPoint = Field(
        ApplicationPoint.midpoint,
        description="where the contact force acts: midpoint of c1c2 (thesis) or the overlap's centroid",
    )


class Shape(_Strict):
    """Shapes of generated particles: sizes, corner numbers, orientations (App. B.1.6)."""

    kind: ShapeKind = ShapeKind.ellipse
    size_m: Vec2 = Field(
        (0.005, 0.005), description="semi-axes (a, b) of the ellipse, or edges of a rectangle, m"
    )
    size_spread: NonNegFloat = Field(0.0, lt=1, description="I of Part_Var_Size (relative)")
    size_dist: Dist = Field(Dist.const, description="CONST, EQUAL or GAUSS; a and b are drawn independently")
    corners: int = Field(8, ge=3, description="N_E")
    corners_spread: int = Field(0, ge=0, description="N_I: corner numbers N_E ± N_I")
    corners_dist: Dist = Dist.const
    angle_mode: AngleMode = Field(AngleMode.regular, description="corner placement on the ellipse")
    orientation_rad: Finite = Field(0.0, description="phi_0")
    orientation_dist: Dist = Field(
        Dist.const, description="EQUAL: [0, 2 pi); GAUSS: ]phi_0 - pi/2, phi_0 + pi/2["
    )
    cut: float = Field(0.0, ge=0, lt=0.5, description="rectangle bevel fraction c")
    round_radius_m: NonNegFloat = Field(0.0, description="rectangle corner radius (0 = sharp)")
    round_corners: int = Field(4, ge=2, description="corners per rounded rectangle corner")

    @model_validator(mode="after")
    def _corners_ok(self):
        if self.corners - self.corners_spread < 3:
            raise ValueError(f"corners - corners_spread = {self.corners - self.corners_spread} < 3")
        return self


class Particle(_Strict):
    """One explicitly given particle (PARTICLE object, App. B.1.4)."""

    vertices_m: list[Vec2] | None = Field(None, description="corners (body frame, any origin), CCW or CW")
    shape: Shape | None = Field(None, description="or a generated shape (one draw)")
    position_m: Vec2 = Field((0.0, 0.0), description="centroid position")
    angle_rad: Finite = 0.0
    velocity_m_s: Vec2 = (0.0, 0.0)
    angular_velocity_rad_s: Finite = 0.0

    @model_validator(mode="after")
    def _one_shape(self):
        if (self.vertices_m is None) == (self.shape is None):
            raise ValueError("give exactly one of vertices_m or shape")
        return self


class Block(_Strict):
    """GENERATE_BLOCK: particles on a lattice in a rectangle, with optional jitter (App. B.1.6)."""

    lattice: Lattice = Lattice.rect
    jitter: Dist = Field(
        Dist.const, description="CONST (exact lattice), EQUAL or GAUSS within ±grid/2·jitter_fraction"
    )
    jitter_fraction: NonNegFloat = Field(
        0.0, le=1.0, description="jitter amplitude in units of half the grid"
    )
    lower_m: Vec2 = Field(description="lower-left corner of the block")
    upper_m: Vec2 = Field(description="upper-right corner of the block")
    grid_m: tuple[PosFloat, PosFloat] = Field(description="GRID_DISTANCE (dx, dy)")
    shape: Shape = Shape()
    max_count: int | None = Field(None, ge=1, description="stop after this many particles")


class DropSource(_Strict):
    """DROPSOURCE (App. B.1.7): one particle every ``every_s`` at a uniform x in [x - w/2, x + w/2]."""

    mode: DropMode = DropMode.abs
    x_m: Finite
    y_m: Finite
    width_m: NonNegFloat = 0.0
    every_s: PosFloat = 0.1
    from_s: NonNegFloat = 0.0
    to_s: NonNegFloat = Field(description="last insertion time")
    velocity_m_s: Vec2 = (0.0, 0.0)
    rise_m_s: Finite = Field(
        0.0,
        description="the insertion height y rises at this rate from from_s on (a silo filled from the top: the "
        "source follows the growing fill so grains fall a short, constant height; 0 = fixed)",
    )
    shrink: bool = Field(
        False,
        description="shrinking line source (layered heaps, §4.2.1): the width falls linearly from width_m at "
        "from_s to 0 at to_s",
    )
    shape: Shape = Shape(corners=8, corners_spread=2, corners_dist=Dist.equal, size_m=(0.01, 0.01))


class Vibration(_Strict):
    """Vibrating wall (App. B.1.5.2): offset A(t) along (cos angle, sin angle) during [from_s, to_s]."""

    waveform: Waveform = Waveform.cosinus
    amplitude_m: NonNegFloat = Field(1e-4, description="W")
    frequency_hz: PosFloat = Field(20.0, description="f")
    angle_rad: Finite = Field(1.5707963267948966, description="direction, default pi/2 (up)")
    from_s: NonNegFloat = 0.0
    to_s: PosFloat = 1e30


class Piston(_Strict):
    """Force-controlled piston (App. B.1.5.1): the wall moves along (cos angle, sin angle) under force_N.

    Its motion obeys m s'' = force_N + (contact forces on the wall) . direction, |s'| <= v_max (no gravity on the
    piston: include its weight in force_N). It comes to rest where the grains push back with force_N.
    """

    force_N: Finite = Field(description="PISTON_FORCE: applied force along the direction (2-D: N per depth)")
    angle_rad: Finite = Field(-1.5707963267948966, description="PISTON_ANGLE: direction of motion (down)")
    mass_kg: PosFloat = Field(description="piston mass (2-D: kg per depth)")
    v_max_m_s: PosFloat = Field(1.0, description="PISTON_V_MAX: speed cap")


class SizeChange(_Strict):
    """Global size change s(t) of all particles (Eqs. 2.30-2.32, B.1-B.2; gc2d's USE_HEATING).

    s(t) = 1 + a (1/2 - 1/2 tanh(S cos(2 pi f t))), t clamped to time_s. Corners scale by s about the centroid;
    mass is conserved (areas scale by s², the moment of inertia by s²).
    """

    amplitude: float = Field(0.01, gt=-1, allow_inf_nan=False, description="HEAT_AMPLITUDE a")
    frequency_hz: NonNegFloat = Field(1.0, description="HEAT_FREQUENCE f")
    slope: Finite = Field(1.0, description="HEAT_SLOPE S")
    time_s: tuple[NonNegFloat, NonNegFloat] = Field((0.0, 1e30), description="HEAT_TIME (t1, t2)")


class Wall(_Strict):
    """WALL: an immobile convex polygon (App. B.1.5), optionally vibrating or with a surface velocity."""

    name: str = "wall"
    vertices_m: list[Vec2] = Field(min_length=3, description="corners (world frame before offset/angle)")
    offset_m: Vec2 = (0.0, 0.0)
    angle_rad: Finite = Field(0.0, description="rotation about the origin (CCW)")
    surface_velocity_m_s: Finite = Field(0.0, description="tangential surface speed along the CCW boundary")
    vibration: Vibration | None = None
    piston: Piston | None = Field(None, description="force-controlled piston (effect piston)")

    @model_validator(mode="after")
    def _one_drive(self):
        if self.piston is not None and self.vibration is not None:
            raise ValueError(f"wall {self.name!r}: a wall cannot be a piston and vibrate at the same time")
        return self


class Box(_Strict):
    """Convenience: an open-top (or closed) box of four wall slabs around [x0, x1] x [y0, y1]."""

    lower_m: Vec2
    upper_m: Vec2
    thickness_m: PosFloat = 0.01
    closed_top: bool = False


class SiloShape(str, enum.Enum):
    straight = "straight"  # r = r_m (Janssen, §3.1)
    stepped = "stepped"  # r = r1 above depth h0, r2 below (Eq. 3.14, §3.3)
    hopper = "hopper"  # r = slope z + b (slanted walls, Eq. 3.16, §3.4)
    parabolic = "parabolic"  # r = sqrt((b - z)/a) (Eq. 3.19, §3.5)


class Silo(_Strict):
    """Convenience: side walls and floor of a 2-D silo of half-width r(z) about ``axis_x_m`` (Schinner 2001 ch. 3).

    z is the depth below the silo's top (the thesis's z), the top is ``bottom_m + depth_m`` high and the floor
    closes the silo at z = ``depth_m`` (a hopper or parabola is cut there, as the thesis cut its apex to keep at least
    10 grains across). Straight and slanted walls are one slab per side, a stepped silo three (upper wall, the step's
    ledge, lower wall), a parabola ``segments`` straight slabs per side with their corners on the curve.
    """

    shape: SiloShape = Field(
        description="r(z): straight, stepped (Eq. 3.14), hopper (3.16) or parabolic (3.19)"
    )
    axis_x_m: Finite = Field(0.0, description="x of the silo's axis")
    bottom_m: Finite = Field(0.0, description="y of the floor's top surface")
    depth_m: PosFloat = Field(
        description="height of the side walls above the floor (the floor is at z = depth_m)"
    )
    r_m: PosFloat | None = Field(None, description="straight: half-width")
    r1_m: PosFloat | None = Field(None, description="stepped: half-width above the step")
    r2_m: PosFloat | None = Field(None, description="stepped: half-width below the step (r2 < r1, Eq. 3.15)")
    h0_m: PosFloat | None = Field(None, description="stepped: depth of the step below the top")
    slope: Finite | None = Field(None, description="hopper: a of r = a z + b (a < 0: narrowing downwards)")
    a_per_m: PosFloat | None = Field(None, description="parabolic: a of r = sqrt((b - z)/a), 1/m")
    b_m: PosFloat | None = Field(
        None, description="hopper: half-width b at the top; parabolic: depth b of the vertex"
    )
    segments: int = Field(16, ge=1, description="parabolic: straight wall slabs per side")
    thickness_m: PosFloat = Field(0.005, description="wall and floor thickness")

    @model_validator(mode="after")
    def _keys_of_shape(self):
        need = SILO_KEYS[self.shape]
        missing = [k for k in need if getattr(self, k) is None]
        if missing:
            raise ValueError(f"shape {self.shape.value} needs {', '.join(missing)}")
        extra = [k for k in ALL_SILO_KEYS - set(need) if getattr(self, k) is not None]
        if extra:
            raise ValueError(f"{', '.join(sorted(extra))} is not a key of shape {self.shape.value}")
        d, t = self.depth_m, self.thickness_m
        if self.shape is SiloShape.stepped and not self.r2_m < self.r1_m:
            raise ValueError(
                f"r2_m = {self.r2_m} must be below r1_m = {self.r1_m} (a narrowing step, Eq. 3.15)"
            )
        if self.shape is SiloShape.stepped and not self.h0_m + t < d:
            raise ValueError(
                f"h0_m + thickness_m = {self.h0_m + t:g} m must be above the floor (depth_m {d:g})"
            )
        if self.shape is SiloShape.hopper and not (self.slope < 0 and self.slope * d + self.b_m > 0):
            raise ValueError(
                f"slope = {self.slope} must be negative and the walls must not meet above the floor "
                f"(slope depth_m + b_m = {self.slope * d + self.b_m:.4g} m must be > 0)"
            )
        if self.shape is SiloShape.parabolic and not d < self.b_m:
            raise ValueError(f"depth_m = {d} must be above the vertex at b_m = {self.b_m}")
        return self

    def half_width(self, z) -> np.ndarray:
        """r(z) at depth z below the top (the step of a stepped silo belongs above)."""
        z = np.asarray(z, dtype=np.float64)
        if self.shape is SiloShape.straight:
            return np.full_like(z, self.r_m)
        if self.shape is SiloShape.stepped:
            return np.where(z <= self.h0_m, self.r1_m, self.r2_m)
        if self.shape is SiloShape.hopper:
            return self.slope * z + self.b_m
        return np.sqrt((self.b_m - z) / self.a_per_m)

    def wall_corner_depths(self) -> np.ndarray:
        """Depths of the side walls' corners on r(z): a parabola's ``segments`` chords, else top and floor."""
        n = self.segments if self.shape is SiloShape.parabolic else 1
        return np.linspace(0.0, self.depth_m, n + 1)

    def inner_half_width(self, z) -> np.ndarray:
        """Half-width between the walls as built at depth z (a parabola's chords lie inside its curve)."""
        z = np.asarray(z, dtype=np.float64)
        if self.shape is not SiloShape.parabolic:
            return self.half_width(z)
        zc = self.wall_corner_depths()
        return np.interp(z, zc, self.half_width(zc))


#: the size keys each silo shape needs (and the only ones it accepts)
SILO_KEYS = {
    SiloShape.straight: ("r_m",),
    SiloShape.stepped: ("r1_m", "r2_m", "h0_m"),
    SiloShape.hopper: ("slope", "b_m"),
    SiloShape.parabolic: ("a_per_m", "b_m"),
}
ALL_SILO_KEYS = {k for keys in SILO_KEYS.values() for k in keys}


class Gravity(_Strict):
    """Time-dependent gravity magnitude along the scene's gravity direction (App. B.1.2.2)."""

    kind: GravityKind = GravityKind.constant
    g1_m_s2: NonNegFloat = 9.81
    g2_m_s2: NonNegFloat = 9.81
    time_s: tuple[NonNegFloat, NonNegFloat] = (0.0, 1.0)
    steps: int = Field(1, ge=1, description="p1: number of steps (STEP, SMOOTH_STEP)")
    ramp: float = Field(0.0, ge=0, le=1, description="p2: relative ramp width (SMOOTH_STEP)")


class DragSpring(_Strict):
    """Drag spring on a particle (App. B.1.4.2): free end moves with velocity_m_s during time_s."""

    particle: int = Field(ge=0, description="index of the particle (order: particles, blocks, drop sources)")
    k_N_m: PosFloat = Field(100.0, description="DRAG_K")
    fixing_point_m: Vec2 = Field((0.0, 0.0), description="attachment relative to the centroid (body frame)")
    velocity_m_s: Vec2 = (0.01, 0.0)
    time_s: tuple[NonNegFloat, NonNegFloat] = (0.0, 1e30)


class Guard(_Strict):
    """Stability guard: stop with a message (and the dt to try) instead of writing garbage (Eq. 2.9)."""

    max_overlap: PosFloat = Field(
        0.3, description="overlap area / r_eq² of the smaller particle (r_eq² = area/pi)"
    )
    max_move: PosFloat = Field(
        0.2, description="largest displacement per step, in inscribed radii of the smallest"
    )


class Output(_Strict):
    frames: int = Field(10, ge=1, description="frames of particle state and contacts written (evenly spaced)")
    series_every: int = Field(100, ge=1, description="time-series sample every this many steps")


class Settings(_Strict):
    """The granular DEM run of a scene."""

    dt_s: PosFloat | None = Field(
        None,
        description="time step; default the smallest of 0.5 x (pi/10) sqrt(m_min/E) (Eq. 2.9) and the normal and "
        "tangential damping bounds (dt_damping_s in the results)",
    )
    duration_s: NonNegFloat = Field(0.1, description="simulated time")
    integrator: Integrator = Integrator.gear
    neighbour_search: NeighbourSearch = Field(
        NeighbourSearch.swap,
        description="broad phase; swap (default) builds the list 2-20x faster than sweep or cells at N = 10^4",
    )
    skin_m: PosFloat | None = Field(
        None, description="Verlet skin (default: 0.6 x the smallest circumradius)"
    )
    gravity_m_s2: Vec2 = Field((0.0, -9.81), description="g vector (Eq. 2.13)")
    gravity: Gravity | None = Field(None, description="time-dependent g (effect variable_gravity)")
    material: Material = Material()
    particles: list[Particle] = Field(default_factory=list)
    blocks: list[Block] = Field(default_factory=list)
    drop_sources: list[DropSource] = Field(default_factory=list)
    walls: list[Wall] = Field(default_factory=list)
    box: Box | None = None
    silo: Silo | None = Field(None, description="side walls and floor of a shaped silo (ch. 3)")
    drag_springs: list[DragSpring] = Field(default_factory=list)
    size_change: SizeChange | None = Field(None, description="global particle size s(t) (effect size_change)")
    guard: Guard = Guard()
    output: Output = Output()
    checkpoint_every_steps: int = Field(
        20000, ge=1, json_schema_extra=RUN_CONTROL, description="checkpoint interval of long runs"
    )

    @model_validator(mode="after")
    def _sources_inside_silo(self):
        if self.silo is None:
            return self
        for k, src in enumerate(self.drop_sources):
            problem = _source_outside_silo(src, self.silo)
            if problem:  # located at the source, not at the whole section
                raise ValidationError.from_exception_data(
                    "Settings",
                    [
                        {
                            "type": "value_error",
                            "loc": ("drop_sources", k),
                            "input": src.model_dump(),
                            "ctx": {"error": ValueError(problem)},
                        }
                    ],
                )
        return self


def _grain_reach(shape: Shape) -> float:
    """Largest centroid-to-corner distance a generated grain can have (corners lie on the ellipse or rectangle)."""
    a, b = shape.size_m
    reach = max(a, b) if shape.kind is ShapeKind.ellipse else 0.5 * float(np.hypot(a, b))
    return reach * (1.0 + shape.size_spread)


def _source_outside_silo(src: DropSource, silo: Silo) -> str:
    """Why a grain of the source would start outside the silo's walls ('' if none would).

    An ABS source's insertion point moves on a straight path (y_m rising at rise_m_s from from_s to its last grain);
    along it every grain must fit between the walls (above the top: within the top's width) and above the floor.
    The walls are straight between their corners (and a stepped silo's step), so the path is checked at its ends and
    at those depths, not grain by grain. A REL source's window must lie within the top's width.
    """
    if src.to_s < src.from_s:
        return ""  # inserts nothing
    reach = _grain_reach(src.shape)
    top = silo.bottom_m + silo.depth_m
    with np.errstate(all="ignore"):  # extreme but finite settings overflow to inf, not to a crash
        t, y = _insertion_path(src, silo)
        need = abs(src.x_m - silo.axis_x_m) + 0.5 * src.width_m + reach
        room = silo.inner_half_width(np.clip(top - y, 0.0, silo.depth_m))
        bad = np.flatnonzero((need > room) | (y - reach <= silo.bottom_m))
    if not len(bad):
        return ""
    i = int(bad[0])
    return (
        f"grains would start outside the silo at t = {t[i]:.4g} s, y = {y[i]:.4g} m: |x_m - axis| + width_m/2 + "
        f"grain reach = {need:.4g} m, the walls leave {room[i]:.4g} m (above the floor at {silo.bottom_m:g} m); "
        "start the source later or higher, or move it inwards"
    )


def _insertion_path(src: DropSource, silo: Silo) -> tuple[np.ndarray, np.ndarray]:
    """Times and heights at which the source's path must be checked: its first and last grain and where it
    crosses a wall corner or the step (the room between the walls is linear in between). A REL source: the top.
    """
    top = silo.bottom_m + silo.depth_m
    if src.mode is DropMode.rel:
        return np.array([src.from_s]), np.array([top])
    n = (src.to_s - src.from_s) / src.every_s
    t_last = src.from_s + math.floor(n + 1e-9) * src.every_s if n < 1e15 else src.to_s
    t = np.array([src.from_s, t_last])
    if src.rise_m_s != 0:
        kinks = np.array([*silo.wall_corner_depths(), *_step_depths(silo)])
        t_kinks = src.from_s + (top - kinks - src.y_m) / src.rise_m_s
        t = np.sort(np.concatenate([t, t_kinks[(t_kinks > t[0]) & (t_kinks < t_last)]]))
    return t, src.y_m + src.rise_m_s * (t - src.from_s)


def _step_depths(silo: Silo) -> list[float]:
    """A stepped silo's step: its depth (still the wide part) and the next depth below (the narrow part)."""
    if silo.shape is not SiloShape.stepped:
        return []
    return [silo.h0_m, float(np.nextafter(silo.h0_m, np.inf))]
