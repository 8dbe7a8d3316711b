"""Event-driven hard-sphere gas (Mahler 2001 §3.3-3.6): several species in a box or in the voxel pore space.

Units: nm, ps, atomic mass units (1 nm/ps = 1000 m/s). Particles collide with each other as hard spheres of the
thesis's van der Waals radii (Table 3.1) and with walls as points (thesis §2.1.5). The space is a grid of cubic
cells: the voxels of a pore volume split into m³ sub-cells each (m chosen so a cell holds a few particles but is
never smaller than the largest collision diameter), or a box. See :mod:`porepipe.diffusion._edmd_kernels` for the
event calendar.

Definitions (also written into every result)
--------------------------------------------
- Z: pair collisions per particle per time (each collision counted for both partners). Kinetic theory for hard
  spheres: Z = χ·√2·n·π·d²·v̄ with χ = (1 − η/2)/(1 − η)³ the Enskog contact value at packing fraction
  η = (π/6)·n·d³ (χ → 1 in the dilute limit).
- λ_eff = N·v̄·Δt / (2·pair collisions + wall hits) (thesis 3.42 read dimensionally right), next to
  λ_M = 1/(√2·n·π·d²) (3.40).
- D_self: slope/6 of the mean-square unwrapped displacement (periodic box); Chapman-Enskog
  D = 1.019·3/(8·n·d²)·√(kT/(π·m)) / χ (first approximation × the higher-order factor 1.019, Enskog 1/χ).
- Kn = λ_eff-free estimate λ_M over the mean cavity width 4V/S (3.41).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from porepipe._shared.errors import PorepipeError, positive_number
from porepipe._shared.rng import kernel_seed
from porepipe.diffusion import _edmd_kernels as E
from porepipe.diffusion import _kernels as K
from porepipe.diffusion._species import R_GAS, SPECIES

STAGE = "diffusion"
#: 1 m/s in nm/ps
_M_S = 1e-3
_LAW = {
    "specular": K.SPECULAR,
    "lambert": K.LAMBERT,
    "cosine_dtheta": K.COSINE_DTHETA,
    "isotropic": K.ISOTROPIC,
}


def speed_scale(species: str, temperature_K: float) -> float:
    """√(kT/m) in nm/ps (the standard deviation of one velocity component)."""
    return (
        math.sqrt(R_GAS / (SPECIES[species][1] * 1e-3)) * math.sqrt(temperature_K) * _M_S
    )  # no R·T overflow


def mean_speed_nm_ps(species: str, temperature_K: float) -> float:
    """v̄ = √(8kT/(πm)) in nm/ps (thesis 3.1)."""
    return speed_scale(species, temperature_K) * math.sqrt(8.0 / math.pi)


@dataclass
class Gas:
    """State of an event-driven gas: particles, species table and the cell grid they live in."""

    pos: np.ndarray  # (N, 3) nm
    vel: np.ndarray  # (N, 3) nm/ps
    species: np.ndarray  # (N,) int64 index into ``names``
    names: tuple
    temperature_K: float
    cells: np.ndarray  # (n0, n1, n2) uint8, 1 = pore
    cell_nm: float
    periodic: np.ndarray
    img: np.ndarray = None
    time_ps: float = 0.0
    state: int = 0
    tally: np.ndarray = None
    pair_counts: np.ndarray = None
    wall_counts: np.ndarray = None

    def __post_init__(self):
        n, s = self.pos.shape[0], len(self.names)
        self.img = np.zeros((n, 3), np.int64) if self.img is None else self.img
        self.tally = np.zeros(E.N_ETALLY) if self.tally is None else self.tally
        self.pair_counts = np.zeros((s, s), np.int64) if self.pair_counts is None else self.pair_counts
        self.wall_counts = np.zeros(s, np.int64) if self.wall_counts is None else self.wall_counts

    @property
    def radius(self) -> np.ndarray:
        return np.array([SPECIES[s][0] for s in self.names])

    @property
    def mass(self) -> np.ndarray:
        return np.array([SPECIES[s][1] for s in self.names])

    @property
    def vmean(self) -> np.ndarray:
        return np.array([mean_speed_nm_ps(s, self.temperature_K) for s in self.names])

    @property
    def extent(self) -> np.ndarray:
        return np.array(self.cells.shape, float) * self.cell_nm

    @property
    def pore_volume(self) -> float:
        return float(np.count_nonzero(self.cells)) * self.cell_nm**3

    def unwrapped(self) -> np.ndarray:
        return self.pos + self.img * self.extent

    def kinetic_energy(self) -> float:
        """Σ m v²/2 (amu nm²/ps²)."""
        return 0.5 * float(np.sum(self.mass[self.species] * np.sum(self.vel**2, axis=1)))

    def momentum(self) -> np.ndarray:
        return np.sum(self.mass[self.species][:, None] * self.vel, axis=0)


def _species_table(counts: dict) -> tuple[tuple, np.ndarray]:
    if not counts:
        raise PorepipeError("the gas needs at least one species with a particle count")
    for name, n in counts.items():
        if name not in SPECIES:
            raise PorepipeError(f"unknown species {name!r}; allowed: {', '.join(SPECIES)}")
        if not (float(n).is_integer() and n >= 0):
            raise PorepipeError(f"particle count of {name} must be a whole number >= 0, got {n!r}")
    names = tuple(counts)
    return names, np.repeat(np.arange(len(names), dtype=np.int64), [int(counts[s]) for s in names])


def _subdivision(
    voxel_nm: float,
    n_voxels: int,
    n_particles: int,
    diameter: float,
    per_cell: float = 0.7,
    at_least: int = 1,
) -> int:
    """Sub-cells per voxel edge: cells hold about ``per_cell`` particles, never narrower than the largest diameter,
    and at least ``at_least`` (where cells that wide allow it: a periodic axis needs 3 cells across).
    """
    most = max(1, int(math.floor(voxel_nm / diameter * (1 - 1e-12))))
    if n_particles == 0:
        return min(max(1, at_least), most)
    target = (per_cell * n_voxels * voxel_nm**3 / n_particles) ** (1.0 / 3.0)
    m = max(1, int(round(voxel_nm / target)))
    m = min(m, most)
    while m > 1 and n_voxels * m**3 > 5 * 10**7:  # memory guard: 50 M cells
        m -= 1
    return min(max(m, at_least), most)


def make_gas(
    pore,
    voxel_nm: float,
    counts: dict,
    *,
    periodic=(False, False, False),
    temperature_K: float = 298.15,
    speed: str = "maxwell",
    seed: int = 0,
    positions=None,
    velocities=None,
    species=None,
) -> Gas:
    """A gas of ``counts`` (species -> number) in the pore voxels of ``pore`` (1 = pore), or given particles.

    Positions are uniform in the pore space without overlap (random sequential insertion), directions isotropic,
    speeds Maxwell-Boltzmann per species (``speed="maxwell"``) or all at the species' v̄ (``"mean"``, the thesis's
    §3.6.2 start). ``positions`` (N, 3) nm, ``velocities`` (N, 3) nm/ps and ``species`` (N,) names replace the
    random start (then ``counts`` only lists the species).
    """
    pore = np.asarray(pore)
    if pore.ndim != 3 or not pore.any():
        raise PorepipeError(
            f"the pore volume must be 3-D with at least one pore voxel, got shape {pore.shape}"
        )
    if not (voxel_nm > 0 and math.isfinite(voxel_nm)):
        raise PorepipeError(f"voxel_nm must be positive, got {voxel_nm!r}")
    positive_number("temperature_K", temperature_K)
    per = np.array([bool(p) for p in np.broadcast_to(periodic, (3,))])
    names, sp = _species_table(counts)
    if positions is not None:
        lookup = {s: k for k, s in enumerate(names)}
        if species is None or any(s not in lookup for s in species):
            raise PorepipeError(f"given particles need a species each, one of {names}")
        sp = np.array([lookup[s] for s in species], dtype=np.int64)
    radius = np.array([SPECIES[s][0] for s in names])
    diameter = 2.0 * float(radius.max())
    # a periodic axis needs 3 cells across (minimum image); a dilute gas's wide cells had fewer, and a 2-voxel box
    # of 10 nm voxels was refused as 'less than 3 collision diameters' across (it is 50 of them)
    wrap = [-(-3 // pore.shape[d]) for d in range(3) if per[d]]
    m = _subdivision(voxel_nm, int(np.count_nonzero(pore)), sp.size, diameter, at_least=max(wrap, default=1))
    cells = np.repeat(np.repeat(np.repeat((pore > 0).astype(np.uint8), m, 0), m, 1), m, 2)
    h = voxel_nm / m
    if h < diameter:
        raise PorepipeError(
            f"voxel {voxel_nm} nm is smaller than the collision diameter {diameter:.4g} nm; use coarser voxels"
        )
    for d in range(3):
        if per[d] and cells.shape[d] < 3:
            raise PorepipeError(
                f"periodic axis {'xyz'[d]} spans {cells.shape[d] * h:.4g} nm, less than 3 collision diameters "
                f"({diameter:.4g} nm)"
            )
    state = int(kernel_seed(seed, STAGE, 16))
    if positions is None:
        pos = np.empty((sp.size, 3))
        placed, state = E.insert_spheres(
            np.argwhere(cells > 0).astype(np.int64),
            h,
            np.array(cells.shape, np.int64),
            per,
            sp,
            radius,
            pos,
            np.uint64(state),
            1000,
        )
        if placed < sp.size:
            raise PorepipeError(
                f"could not place {sp.size} particles without overlap (placed {placed}); the gas is too dense"
            )
        vel = _velocities(names, sp, temperature_K, speed, seed)
    else:
        pos, vel = np.array(positions, dtype=float), np.array(velocities, dtype=float)
        if pos.shape != vel.shape or pos.shape != (sp.size, 3):
            raise PorepipeError(
                f"positions {pos.shape} and velocities {vel.shape} must both be ({sp.size}, 3), one row a species"
            )
        if not np.all(np.isfinite(vel)):
            raise PorepipeError("particle velocities must be finite")
        pos = _check_positions(pos, cells, h)
    gas = Gas(pos, vel, sp, names, float(temperature_K), cells, h, per, state=int(state))
    _check_overlap(gas)
    return gas


def _velocities(names, sp, temperature_K, speed, seed) -> np.ndarray:
    rng = np.random.default_rng(kernel_seed(seed, STAGE, 17))
    scale = np.array([speed_scale(s, temperature_K) for s in names])[sp]
    vel = rng.standard_normal((sp.size, 3))
    if speed == "maxwell":
        return vel * scale[:, None]
    if speed == "mean":
        vel /= np.linalg.norm(vel, axis=1)[:, None]
        return vel * (scale * math.sqrt(8.0 / math.pi))[:, None]
    raise PorepipeError(f"speed must be 'maxwell' or 'mean', got {speed!r}")


def _check_positions(pos: np.ndarray, cells: np.ndarray, h: float) -> np.ndarray:
    """Every particle in a pore cell; one exactly on a face between its (solid) cell and a pore cell below it is
    moved into that pore cell by keeping the coordinate (the face belongs to both).
    """
    if not np.all(np.isfinite(pos)):
        raise PorepipeError("particle positions must be finite")
    ext = np.array(cells.shape) * h
    if np.any(pos < 0) or np.any(pos > ext):
        bad = int(np.argmax(np.any((pos < 0) | (pos > ext), axis=1)))
        raise PorepipeError(
            f"particle {bad} at {pos[bad].tolist()} nm lies outside the volume {ext.tolist()} nm"
        )
    for i, p in enumerate(pos):
        idx = np.minimum((p / h).astype(np.int64), np.array(cells.shape) - 1)
        if cells[tuple(idx)]:
            continue
        fixed = False
        for d in range(3):
            if p[d] == idx[d] * h and idx[d] > 0:
                alt = idx.copy()
                alt[d] -= 1
                if cells[tuple(alt)]:
                    pos[i, d] = np.nextafter(
                        idx[d] * h, -np.inf
                    )  # inside the pore cell, on the face to round-off
                    fixed = True
                    break
        if not fixed:
            raise PorepipeError(f"particle {i} at {p.tolist()} nm lies in a solid voxel")
    return pos


def _check_overlap(gas: Gas) -> None:
    shape = np.array(gas.cells.shape, np.int64)
    head = np.empty(gas.cells.size, np.int64)
    n = gas.pos.shape[0]
    nxt, prv, cell = (np.empty(n, np.int64) for _ in range(3))
    cidx = np.empty((n, 3), np.int64)
    E.build_cells(gas.pos, gas.cell_nm, shape, head, nxt, prv, cell, cidx)
    i, j = E.first_overlap(
        gas.pos, gas.species, gas.radius, gas.cell_nm, shape, gas.periodic, head, nxt, cidx
    )
    if i >= 0:
        raise PorepipeError(
            f"particles {i} and {j} overlap at the start (distance < r_i + r_j); place them further apart"
        )


@dataclass
class Physics:
    """Which effects the run has: gas-gas collisions, the wall law, reactions at walls."""

    pairs: bool = True
    wall_law: str = "specular"
    accommodation: float = 1.0
    thermal_wall: bool = False
    reactions: dict = field(default_factory=dict)  # species -> (product species, probability per wall hit)


def check_events(gas: Gas, duration_ps: float) -> None:
    """Refuse a run of ``gas`` for ``duration_ps`` whose cell crossings alone (each particle crosses about v̄/cell
    faces per ps; collisions and wall hits come on top) exceed ``_api.MAX_EVENTS``, in one line with the estimate.
    """
    from porepipe.diffusion._api import MAX_EVENTS

    if not 0.0 <= duration_ps < math.inf:
        raise PorepipeError(f"duration_ps must be finite and >= 0, got {duration_ps!r}")
    with np.errstate(over="ignore"):  # inf is refused below
        rate = float(np.sum(gas.vmean[gas.species])) / gas.cell_nm  # crossings per ps, all particles
    if rate * duration_ps > MAX_EVENTS:
        raise PorepipeError(
            f"the gas of {gas.pos.shape[0]} particles at {gas.temperature_K:.4g} K (v̄ up to "
            f"{float(gas.vmean.max()):.3g} nm/ps) would need more than {rate * duration_ps:.3g} events for "
            f"{duration_ps:.4g} ps in cells of {gas.cell_nm:.3g} nm (at most {MAX_EVENTS:.0e}: years at ~1e6 "
            "events/s); shorten duration_ps or use fewer particles"
        )


def advance(gas: Gas, duration_ps: float, physics: Physics | None = None) -> Gas:
    """Run ``gas`` for ``duration_ps`` (in place); the counters in ``gas.tally`` etc. accumulate."""
    check_events(gas, duration_ps)
    physics = physics or Physics()
    if physics.wall_law not in _LAW:
        raise PorepipeError(f"wall_law must be one of {', '.join(_LAW)}, got {physics.wall_law!r}")
    law, mixed, wspeed = K.wall_flags(_LAW[physics.wall_law], physics.accommodation, physics.thermal_wall)
    react_w = np.zeros(len(gas.names))
    react_to = np.arange(len(gas.names), dtype=np.int64)
    for src, (dst, w) in physics.reactions.items():
        if src not in gas.names or dst not in gas.names:
            raise PorepipeError(f"reaction {src} -> {dst}: both species must be in the gas {gas.names}")
        if not 0.0 <= w <= 1.0:
            raise PorepipeError(f"reaction probability of {src} must lie in [0, 1], got {w}")
        react_w[gas.names.index(src)] = w
        react_to[gas.names.index(src)] = gas.names.index(dst)
    gas.state = int(
        E.advance(
            gas.pos,
            gas.vel,
            gas.img,
            gas.species,
            gas.radius,
            gas.mass,
            gas.vmean,
            gas.cells,
            gas.cell_nm,
            gas.periodic,
            gas.time_ps,
            gas.time_ps + duration_ps,
            bool(physics.pairs),
            law,
            mixed,
            wspeed,
            float(physics.accommodation),
            react_w,
            react_to,
            np.uint64(gas.state),
            gas.tally,
            gas.pair_counts,
            gas.wall_counts,
        )
    )
    gas.time_ps += duration_ps
    return gas


# ---------------------------------------------------------------------------------------------------------------------
# kinetic theory
def enskog_chi(n: float, d: float) -> float:
    """Enskog contact value χ = (1 − η/2)/(1 − η)³ (Carnahan-Starling), η = (π/6)·n·d³."""
    eta = math.pi / 6.0 * n * d**3
    return (1.0 - eta / 2.0) / (1.0 - eta) ** 3


def collision_rate(n: float, d: float, vmean: float, chi: bool = True) -> float:
    """Pair collisions per particle per time Z = χ·√2·n·π·d²·v̄ (one species, d = 2r)."""
    return (enskog_chi(n, d) if chi else 1.0) * math.sqrt(2.0) * n * math.pi * d * d * vmean


def maxwell_free_path(n: float, d: float) -> float:
    """λ_M = 1/(√2·n·π·d²) (3.40)."""
    return 1.0 / (math.sqrt(2.0) * n * math.pi * d * d)


def chapman_enskog_d(n: float, d: float, species: str, temperature_K: float, chi: bool = True) -> float:
    """Self-diffusion D = 1.019·3/(8·n·d²)·√(kT/(π·m)) (/χ for Enskog) in nm²/ps (n in nm⁻³, d in nm)."""
    d1 = 3.0 / (8.0 * n * d * d) * speed_scale(species, temperature_K) / math.sqrt(math.pi)
    return 1.019 * d1 / (enskog_chi(n, d) if chi else 1.0)


def orientation_histogram(vel: np.ndarray, axis: int, bins: int) -> np.ndarray:
    """(bins, 2·bins) counts of velocity directions: cos(angle to ``axis``) in [-1, 1] × azimuth about it in
    [-π, π) (measured from the next axis, (axis + 1) % 3). Equal-area cells: an isotropic gas fills them evenly.
    """
    speed = np.linalg.norm(vel, axis=1)
    ok = speed > 0
    v = vel[ok] / speed[ok, None]
    a, b = (axis + 1) % 3, (axis + 2) % 3
    hist, _, _ = np.histogram2d(
        v[:, axis],
        np.arctan2(v[:, b], v[:, a]),
        bins=(bins, 2 * bins),
        range=((-1.0, 1.0), (-math.pi, math.pi)),
    )
    return hist


def measure(
    gas: Gas,
    duration_ps: float,
    samples: int = 20,
    physics: Physics | None = None,
    groups: int = 8,
    orientation_bins: int = 0,
    axis: int = 2,
) -> dict:
    """Run ``gas`` for ``duration_ps`` in ``samples`` steps; collision rate, λ_eff, msd D (periodic axes) with
    batch errors over ``groups`` particle groups (at most one per particle; one group: an infinite error), and the
    event cost. ``orientation_bins`` > 0: the velocity
    orientations of all particles at the sample times (:func:`orientation_histogram` about ``axis``), summed, as
    ``orientation`` (thesis §3.7, Figs. 3.21-3.22).
    """
    import time

    check_events(gas, duration_ps)  # the whole run, before its first sample
    step = float(gas.vmean.min()) * duration_ps / samples
    if gas.periodic.any() and not step >= 1e-12 * float(gas.extent.max()):
        raise PorepipeError(
            f"between two of the {samples} sample times ({duration_ps / samples:.3g} ps) a particle at v̄ moves "
            f"about {step:.3g} nm, below 1e-12 of the {float(gas.extent.max()):.4g} nm box its position resolves: "
            "the msd (D_self) would be round-off (it read 0); lengthen duration_ps or raise the temperature"
        )
    physics = physics or Physics()
    n = gas.pos.shape[0]
    groups = max(1, min(groups, n))  # no empty group: a gas of fewer particles has one per group
    t0 = gas.tally.copy()
    pairs0, walls0 = gas.tally[E.E_PAIRS], gas.tally[E.E_WALLS]
    start = gas.unwrapped().copy()
    times = np.linspace(duration_ps / samples, duration_ps, samples)
    msd = np.zeros((samples, groups, 3))
    group = np.arange(n) % groups
    orient = np.zeros((max(orientation_bins, 1), 2 * max(orientation_bins, 1)))
    wall0 = time.perf_counter()
    done = 0.0
    for k, t in enumerate(times):
        advance(gas, t - done, physics)
        done = t
        disp2 = (gas.unwrapped() - start) ** 2
        for g in range(groups):
            msd[k, g] = disp2[group == g].mean(axis=0)
        if orientation_bins:
            orient = orient + orientation_histogram(gas.vel, axis, orientation_bins)
    wall = time.perf_counter() - wall0
    pairs = gas.tally[E.E_PAIRS] - pairs0
    walls = gas.tally[E.E_WALLS] - walls0
    vbar = float(np.mean(gas.vmean[gas.species]))
    out = {
        "particles": n,
        "duration_ps": duration_ps,
        "pair_collisions": int(pairs),
        "wall_hits": int(walls),
        "events": int(gas.tally[E.E_EVENTS] - t0[E.E_EVENTS]),
        "stale_events": int(gas.tally[E.E_STALE] - t0[E.E_STALE]),
        "collision_rate": 2.0 * pairs / (n * duration_ps),
        # path flown per collision or wall hit; none in the whole run: longer than any path flown (it read as the
        # path of one particle, e.g. 9.5 nm for 20 ps of N2 alone in a 20 nm box)
        "lambda_eff_nm": n * vbar * duration_ps / (2.0 * pairs + walls)
        if 2 * pairs + walls > 0
        else math.inf,
        "wall_s": wall,
        "events_per_s": (gas.tally[E.E_EVENTS] - t0[E.E_EVENTS]) / max(wall, 1e-12),
        "number_density_nm3": n / gas.pore_volume,
    }
    half = slice(samples // 4, None)
    tc = times[half] - times[half].mean()
    scale = np.abs(tc).max()  # tc in units of its largest: tc² of a 1e-300 ps run underflowed to 0 (D = 0/0)
    tc = tc / scale
    slopes = np.einsum("s,sgd->gd", tc, msd[half]) / np.sum(tc * tc) / (2.0 * scale)  # (groups, 3)
    per = gas.periodic
    if per.any():
        dg = slopes[:, per].mean(axis=1)
        out["D_self_nm2_ps"] = float(dg.mean())
        out["D_self_err_nm2_ps"] = float(dg.std(ddof=1) / math.sqrt(groups)) if groups > 1 else math.inf
    out["msd"] = msd.mean(axis=1)
    out["msd_time_ps"] = times
    if orientation_bins:
        out["orientation"] = orient
    return out


# ---------------------------------------------------------------------------------------------------------------------
# wall reactions in the Knudsen regime (thesis §4.1-4.2)
def reactive_pore(
    pore,
    axis: int,
    w: float,
    *,
    w_reverse: float = 0.0,
    w_follow: float = 0.0,
    wall_law: str = "lambert",
    inlet_law: str = "lambert",
    voxel_um=1.0,
    periodic=(False, False, False),
    particles: int = 20000,
    batches: int = 16,
    max_hits: int = 10**7,
    z_bins: int = 0,
    sites=None,
    poisoning: float = 0.0,
    rounds: int = 1,
    adsorption: float = 0.0,
    residence: float = 0.0,
    residence_law: str = "fixed",
    seed: int = 0,
) -> dict:
    """First-order wall reaction A → P (optionally reversible, or consecutive P → S) in a pore fed from its low face
    along ``axis`` and closed by a specular back wall at the high face (thesis §4.1, Fig. 4.1).

    Returns the counts and, with k = w·ν_wall (ν_wall = wall hits per particle per jiffie, measured):
    ``eta`` = product rate/(k·N) = products/(w·wall hits) (4.5; η → 1 as w → 0), ``eta_err`` (batch means),
    ``phi`` by bisection (4.7), ``r_eff`` = products per particle-jiffie, ``k0_max`` = ν_wall (4.4: the w → 0 limit of
    r_eff/w per particle), ``D_R`` (4.12, voxel²/jiffie); with ``z_bins``: ``z_react`` (reactive hits per axial
    bin), ``reactant_profile`` (c_A/c₀ per bin) and ``phi_profile`` (Φ fitted to it by (4.11)).
    ``sites``: an array of the pore's shape (>= 0) that multiplies every reaction probability at a wall hit from
    that pore voxel (active-site distribution); η then still uses the mean w (products/(w·hits)). ``poisoning`` > 0
    runs ``rounds`` rounds of ``particles`` histories and after each multiplies a voxel's site factor by
    exp(−poisoning·reactions there) (quasi-static deactivation); ``r_eff_rounds`` holds each round's rate.
    ``adsorption`` > 0: probability that a wall hit adsorbs the particle for ``residence`` jiffies (``residence_law``
    fixed or exponential); ``adsorbed_fraction`` = residence time over particle time (beyond the thesis, which
    designed but never ran adsorption).
    ``inlet_law``: direction of an entering particle, "lambert" (an equilibrium reservoir's flux) or "isotropic"
    (the thesis's inlet, an isotropic scatterer, §4.1 and §5.2).
    Lengths in units of the smallest voxel edge, times in jiffies (v̄ = 1 voxel/jiffie).
    """
    from porepipe.diffusion._api import _ratio, prepare, require_wall
    from porepipe.diffusion._reactions import diffusion_under_reaction, phi_of_eta, profile_phi

    for name, value in (("w", w), ("w_reverse", w_reverse), ("w_follow", w_follow)):
        if not 0.0 <= value <= 1.0:
            raise PorepipeError(f"reaction probability {name} must lie in [0, 1], got {value!r}")
    if wall_law not in _LAW:
        raise PorepipeError(f"wall_law must be one of {', '.join(_LAW)}, got {wall_law!r}")
    if inlet_law not in ("lambert", "isotropic"):
        raise PorepipeError(f"inlet_law must be lambert or isotropic, got {inlet_law!r}")
    geom = prepare(pore, voxel_um, periodic, axis)
    require_wall(geom)  # no wall: no reaction, η = 0/0
    if not 0.0 <= adsorption <= 1.0 or residence < 0 or residence_law not in ("fixed", "exponential"):
        raise PorepipeError(
            f"adsorption must lie in [0, 1], residence >= 0 and residence_law fixed or exponential; got "
            f"{adsorption!r}, {residence!r}, {residence_law!r}"
        )
    if not 0.0 <= poisoning < math.inf or rounds < 1:
        raise PorepipeError(
            f"poisoning must be finite and >= 0 and rounds >= 1, got {poisoning!r}, {rounds!r}"
        )
    if not isinstance(batches, int | np.integer) or batches < 1:
        raise PorepipeError(f"batches must be a whole number >= 1, got {batches!r}")
    if poisoning > 0 and sites is None:
        sites = np.ones(np.shape(pore))
    if sites is not None:
        sites = np.array(sites, dtype=float)
        if sites.shape != np.shape(pore) or not np.all(np.isfinite(sites)) or np.any(sites < 0):
            raise PorepipeError(f"sites must be finite, >= 0 and of the pore's shape {np.shape(pore)}")
    kernel = E.make_reactive_kernel(
        K.wall_flags(_LAW[wall_law], 1.0, False),
        _LAW[inlet_law],
        K.SPEED_FLUX,
        w_reverse > 0,
        w_follow > 0,
        z_bins > 0,
        sites is not None,
        adsorption > 0,
    )
    per = max(1, particles // batches)
    tally = np.zeros((batches, E.N_RTALLY))
    zhist = np.zeros((batches, 3, max(z_bins, 1)))
    counts = np.zeros((batches, *np.shape(pore)) if poisoning > 0 else (0, 1, 1, 1), np.int64)
    seed_k = kernel_seed(seed, STAGE, 18)
    rates = []
    for k in range(rounds):
        part = np.zeros((batches, E.N_RTALLY))
        counts[:] = 0
        kernel(
            geom.codes,
            geom.h,
            geom.periodic,
            axis,
            geom.cells(0),
            seed_k,
            k * batches * per,
            per,
            max_hits,
            1.0,
            1.0,
            np.array([w, w_reverse, w_follow, adsorption, residence, float(residence_law == "exponential")]),
            sites if sites is not None else np.ones((1, 1, 1)),
            counts,
            part,
            zhist,
        )
        tally += part
        rates.append(part[:, E.R_OUT_P].sum() / max(part[:, E.R_TIME].sum(), 1e-300))
        if poisoning > 0:
            sites *= np.exp(-poisoning * counts.sum(axis=0))
    col = tally.sum(axis=0)
    products = tally[:, E.R_OUT_P]
    out = {
        "particles": int(col[E.R_PARTICLES]),
        "products": int(col[E.R_OUT_P]),
        "byproducts": int(col[E.R_OUT_S]),
        "reflex": int(col[E.R_OUT_A]),
        "truncated": int(col[E.R_TRUNC]),
        "wall_hits": int(col[E.R_HITS]),
        "backwall_hits": int(col[E.R_BACKWALL]),
        "reactions": int(col[E.R_REACT]),
        "particle_time": float(col[E.R_TIME]),
        "length": geom.codes.shape[axis] * float(geom.h[axis]),
        "pore_volume": geom.pore_volume,
        "wall_area": geom.wall_area,
    }
    nu, _ = _ratio(tally[:, E.R_HITS], tally[:, E.R_TIME])
    rate, rate_err = _ratio(products, tally[:, E.R_TIME])
    out.update(k0_max=nu, r_eff=rate, r_eff_err=rate_err, w=w, w_reverse=w_reverse, w_follow=w_follow)
    if rounds > 1:
        out["r_eff_rounds"] = np.array(rates)
    if adsorption > 0:
        out.update(
            adsorptions=int(col[E.R_ADSORB]),
            adsorbed_fraction=float(col[E.R_ADS_TIME] / max(col[E.R_TIME], 1e-300)),
        )
    if poisoning > 0:
        out["sites"] = sites
    if w > 0:
        eta, eta_err = _ratio(products, w * tally[:, E.R_HITS])
        # nothing counted: not η = 0 ± 0 (w = 1e-300 read so), one product more at least
        if col[E.R_OUT_P] == 0:
            eta_err = max(eta_err, 1.0 / (w * col[E.R_HITS])) if w * col[E.R_HITS] > 0 else math.inf
            rate_err = max(rate_err, 1.0 / col[E.R_TIME]) if col[E.R_TIME] > 0 else math.inf
            out["r_eff_err"] = rate_err
        out.update(eta=eta, eta_err=eta_err)
        if 0 < eta <= 1:
            phi = phi_of_eta(eta)
            out.update(phi=phi, D_R=diffusion_under_reaction(phi, out["length"], w * nu))
    if z_bins:
        maps = zhist.sum(axis=0)
        out["z_react"] = maps[0]
        out["z_time_reactant"] = maps[1]
        profile = np.divide(maps[1], maps[2], out=np.zeros(z_bins), where=maps[2] > 0)
        out["reactant_profile"] = profile
        z = (np.arange(z_bins) + 0.5) / z_bins
        out["phi_profile"] = profile_phi(z[maps[2] > 0], profile[maps[2] > 0])
    return out


# ---------------------------------------------------------------------------------------------------------------------
# the stage's modes (setup edmd / reaction)
def edmd_result(pore, settings, voxel_um, periodic, seed: int = 0, axis: int = 2):
    """Setup ``edmd``: the gas of ``settings.gas`` in the pore space, run and measured (a DiffusionResult).

    Values: Z (collision rate, 1/ps) next to Enskog's, λ_eff and λ_M (nm), Kn = λ_M/(4V/S), D_self (nm²/ps and
    m²/s, periodic axes) next to Chapman-Enskog (first species with particles), the final speeds' KS test against
    MB at the temperature of the (conserved) energy, energy drift, events and events/s. Arrays: msd curve, speed
    histogram. Species of count 0 are left out (setup edmd has no reactions to make them).
    """
    from scipy import stats

    from porepipe.diffusion._api import DiffusionResult
    from porepipe.diffusion._geometry import wall_area

    g = settings.gas
    voxel = np.broadcast_to(np.asarray(voxel_um, dtype=float), (3,))
    if not np.allclose(voxel, voxel[0]):
        raise PorepipeError(f"setup edmd needs cubic voxels, got {voxel.tolist()} µm")
    voxel_nm = g.voxel_nm or float(voxel[0]) * 1e3
    gas = make_gas(
        pore,
        voxel_nm,
        {name: n for name, n in g.particles.items() if n > 0},  # an absent species has no speeds to test
        periodic=periodic,
        temperature_K=settings.temperature_K,
        speed=g.initial_speed,
        seed=seed,
    )
    physics = Physics(
        pairs=g.collisions,
        wall_law=settings.wall_law.value,
        accommodation=settings.accommodation,
        thermal_wall=settings.wall_speed.value == "thermal",
    )
    e0 = gas.kinetic_energy()
    m = measure(
        gas, g.duration_ps, samples=g.samples, physics=physics, orientation_bins=g.orientation_bins, axis=axis
    )
    n_part = gas.pos.shape[0]
    first = gas.names[0]
    d = 2.0 * SPECIES[first][0]
    n = n_part / gas.pore_volume
    keep = (np.asarray(pore) > 0).astype(np.uint8)
    area = wall_area(keep, np.full(3, voxel_nm), gas.periodic)
    chord = 4.0 * gas.pore_volume / area if area > 0 else math.inf  # no wall at all: Kn = 0
    mine = gas.species == 0
    speeds = np.linalg.norm(gas.vel[mine], axis=1)
    scale = math.sqrt(np.mean(speeds**2) / 3.0)
    ks = stats.kstest(speeds / scale, stats.maxwell.cdf)
    v = {
        "particles": n_part,
        "number_density_nm3": n,
        "collision_rate": m["collision_rate"],
        "collision_rate_enskog": collision_rate(n, d, float(np.mean(gas.vmean[gas.species]))),
        "lambda_eff_nm": m["lambda_eff_nm"],
        "lambda_M_nm": maxwell_free_path(n, d),
        "mean_chord_nm": chord,
        "Kn": maxwell_free_path(n, d) / chord,
        "pair_collisions": m["pair_collisions"],
        "wall_hits": m["wall_hits"],
        "events": m["events"],
        "stale_events": m["stale_events"],
        "events_per_s": m["events_per_s"],
        "energy_rel_drift": gas.kinetic_energy() / e0 - 1.0,
        "ks_statistic": float(ks.statistic),
        "ks_pvalue": float(ks.pvalue),
        "duration_ps": g.duration_ps,
        "voxel_nm": voxel_nm,
        "cell_nm": gas.cell_nm,
    }
    if "D_self_nm2_ps" in m:
        v["D_self_nm2_ps"] = m["D_self_nm2_ps"]
        v["D_self_err_nm2_ps"] = m["D_self_err_nm2_ps"]
        v["D_self_m2_s"] = m["D_self_nm2_ps"] * 1e-6
        v["D_self_err_m2_s"] = m["D_self_err_nm2_ps"] * 1e-6
        v["D_chapman_enskog_m2_s"] = chapman_enskog_d(n, d, first, settings.temperature_K) * 1e-6
    hist, edges = np.histogram(speeds, bins=g.speed_bins, range=(0.0, 4.0 * scale))
    arrays = {
        "msd_nm2": m["msd"],
        "msd_time_ps": m["msd_time_ps"],
        "speed_histogram": hist.astype(float),
        "speed_bin_edges_nm_ps": edges,
    }
    if "orientation" in m:
        arrays["orientation"] = m["orientation"]
    return DiffusionResult("edmd", "".join("xyz"[k] for k in range(3) if gas.periodic[k]) or "-", v, arrays)


def reaction_result(pore, settings, axis: int, voxel_um, periodic, seed: int = 0):
    """Setup ``reaction``: :func:`reactive_pore` with ``settings.reactions`` along ``axis`` (a DiffusionResult)."""
    from porepipe.diffusion._api import DiffusionResult

    rs = settings.reactions
    out = reactive_pore(
        pore,
        axis,
        rs.w,
        w_reverse=rs.w_reverse,
        w_follow=rs.w_follow,
        wall_law=settings.wall_law.value,
        inlet_law=settings.inlet_law.value,
        voxel_um=voxel_um,
        periodic=periodic,
        particles=rs.particles,
        batches=settings.batches,
        max_hits=settings.max_hits_per_particle,
        z_bins=rs.z_bins,
        poisoning=rs.poisoning,
        rounds=rs.rounds,
        adsorption=rs.adsorption,
        residence=rs.residence_jiffies,
        residence_law=rs.residence_law,
        seed=seed,
    )
    keys = ("z_react", "z_time_reactant", "reactant_profile", "r_eff_rounds", "sites")
    arrays = {k: out.pop(k) for k in keys if k in out}
    return DiffusionResult("reaction", "xyz"[axis], out, arrays)


# ---------------------------------------------------------------------------------------------------------------------
# transition regime: D against particle number (pressure) and the Bosanquet line (3.48-3.50)
def bosanquet_fit(counts, d, d_err) -> dict:
    """Weighted straight line 1/D = a + b·N (3.50) through (N, D ± D_err): intercept a = 1/D_Kn, slope b (the gas
    resistance per particle), their standard errors, and χ²/dof of the fit.
    """
    from porepipe.diffusion._length_series import weighted_line

    fit = weighted_line(
        counts, d, d_err, "the Bosanquet fit"
    )  # exactly rescaled: any finite D > 0 and errors > 0
    return {
        "intercept": fit["c"],
        "intercept_err": fit["c_err"],
        "slope": fit["s"],
        "slope_err": fit["s_err"],
        "chi2_dof": fit["chi2_per_dof"],
    }


def pressure_series(
    pore,
    voxel_nm: float,
    axis: int,
    counts,
    duration_ps: float,
    *,
    species: str = "N2",
    wall_law: str = "lambert",
    temperature_K: float = 298.15,
    samples: int = 16,
    seed: int = 0,
) -> dict:
    """Self-diffusion along ``axis`` of a pore periodic along that axis for each particle number in ``counts``
    (N = 0 entries are not allowed; the Knudsen limit comes from the intercept), then the Bosanquet fit.

    Returns ``counts``, ``D`` and ``D_err`` (nm²/ps, batch means over 8 particle groups), ``Kn`` (λ_M over the mean
    chord 4V/S) and the :func:`bosanquet_fit` entries. Compare the intercept with 1/D of the Knudsen engine and the
    slope with V/(n·D_CE)/V² (the bulk resistance per particle).
    """
    from porepipe.diffusion._geometry import wall_area

    per = [False, False, False]
    per[axis] = True
    keep = (np.asarray(pore) > 0).astype(np.uint8)
    volume = float(keep.sum()) * voxel_nm**3
    chord = 4.0 * volume / wall_area(keep, np.full(3, voxel_nm), np.array(per))
    d_sp = 2.0 * SPECIES[species][0]
    out_d, out_err, kn = [], [], []
    for k, n_part in enumerate(counts):
        if n_part < 8:
            raise PorepipeError(f"each point of the pressure series needs >= 8 particles, got {n_part}")
        gas = make_gas(
            pore, voxel_nm, {species: int(n_part)}, periodic=per, temperature_K=temperature_K, seed=seed + k
        )
        m = measure(gas, duration_ps, samples=samples, physics=Physics(wall_law=wall_law), groups=8)
        out_d.append(m["D_self_nm2_ps"])
        out_err.append(m["D_self_err_nm2_ps"])
        kn.append(maxwell_free_path(n_part / volume, d_sp) / chord)
    fit = bosanquet_fit(counts, out_d, out_err)
    return {
        "counts": np.asarray(counts),
        "D": np.array(out_d),
        "D_err": np.array(out_err),
        "Kn": np.array(kn),
        **fit,
    }
