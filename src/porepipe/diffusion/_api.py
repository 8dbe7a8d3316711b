"""Knudsen diffusion in a binary pore volume: transmission W, Wicke-Kallenbach D_eff, periodic-medium D tensor.

Definitions (also written into every result)
--------------------------------------------
- W: probability that a particle entering the inlet face leaves through the outlet face (Clausing).
- D_transmission = v̄·L·W/4: the diffusion coefficient of the channel per open inlet area (thesis §3.6.4); for a
  long tube W -> 8R/(3L) and D -> d·v̄/3 (3.46).
- D_eff: superficial coefficient (flux per total cross-section): D_transmission·A_open/A_total, or ε·D_msd.
- D_ref = v̄·(4V/S)/3: Knudsen coefficient of a straight capillary whose mean chord 4V/S equals that of the pore
  space (= d·v̄/3 for a cylinder); V, S = accessible pore volume and its voxel wall area.
- Ψ = D_eff/D_ref (the thesis's "permeability" Ψ = ε·χ, §1.5.2), labyrinth factor χ = Ψ/ε,
  tortuosity τ = ε/Ψ = 1/χ (so D_eff = ε·D_ref/τ), with ε the accessible porosity.
- Wicke-Kallenbach (3.45): D = (ṅ_1/A)·L/Δc_1 with ṅ_1 the FLUSS rate of species 1, A the open inlet area and
  Δc_1 = 2·N_1/V_P: the concentration difference of a linear profile from 2N_1/V_P at the species-1 face to 0 at the
  other (the thesis's literal Δc_1 = N_1/V_P gives twice this value; reported as ``D_wk_thesis``). With a Lambert
  inlet and flux-weighted speeds this convention equals v̄·L·W/4 exactly. ``D_wk_profile`` divides the flux by the
  gradient of the measured species-1 profile fitted over the middle 60 % of the channel.
- Mean free flight = path length / number of flights ending at a wall; hit rate = wall hits per particle and time.
- Stop (root attributes of a transmission, Wicke-Kallenbach or msd result): ``rel_error`` = the relative 1-σ error that
  the rounds compared with ``target_rel_error`` (of W; WK: of D; msd: the largest of the D_dd; inf before 2 rounds);
  ``target_met`` = 1 if it fell to the target, else 0; ``stopped_by`` = what ended the rounds: target_rel_error, or
  the limit reached first, max_rounds or max_wall_hits (a length series: one per length, comma-separated).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from porepipe._shared.atomic import atomic_path
from porepipe._shared.budget import machine_bytes
from porepipe._shared.cost import SpentClock, carried_by
from porepipe._shared.errors import PorepipeError
from porepipe._shared.progress import Progress
from porepipe._shared.rng import kernel_seed
from porepipe._shared.store import hash_of
from porepipe.diffusion import _kernels as K
from porepipe.diffusion._geometry import accessible_pore, wall_area
from porepipe.diffusion._settings import InletLaw, Settings, Setup, SpeedDist, WallLaw, WallSpeed
from porepipe.diffusion._species import mean_speed

STAGE = "diffusion"
#: events refused in one run of an event loop (setups edmd, surface): ~3 years at the engines' ~10⁶ events per CPU-s
#: (README), and few enough per particle that float time still resolves their spacing (a 1e300 K gas, 1e150
#: crossings per particle, never advanced in time; hops at 1e10 per jiffie ran for ever)
MAX_EVENTS = 1e14
_LAW = {
    WallLaw.specular: K.SPECULAR,
    WallLaw.lambert: K.LAMBERT,
    WallLaw.cosine_dtheta: K.COSINE_DTHETA,
    WallLaw.isotropic: K.ISOTROPIC,
    InletLaw.lambert: K.LAMBERT,
    InletLaw.isotropic: K.ISOTROPIC,
}
_SPEED = {SpeedDist.mean: K.SPEED_MEAN, SpeedDist.maxwell: K.SPEED_MAXWELL, SpeedDist.flux: K.SPEED_FLUX}


@dataclass
class Geometry:
    """A pore volume prepared for flights: 1-byte distance codes of the accessible cluster, internal voxel edges."""

    codes: np.ndarray
    h: np.ndarray
    periodic: np.ndarray
    voxel_um: np.ndarray
    axis: int | None
    total_porosity: float
    accessible_porosity: float
    pore_volume: float
    wall_area: float

    @property
    def length_unit_m(self) -> float:
        return float(self.voxel_um.min()) * 1e-6

    def cells(self, layer: int | None = None) -> np.ndarray:
        """(m, 3) int64 indices of the accessible voxels (of one layer of the axis: 0 or -1)."""
        if layer is None:
            return np.argwhere(self.codes > 0).astype(np.int64)
        n = self.codes.shape[self.axis]
        sl = [slice(None)] * 3
        sl[self.axis] = layer % n
        found = np.argwhere(self.codes[tuple(sl)] > 0).astype(np.int64)
        return np.insert(found, self.axis, layer % n, axis=1)


def prepare(
    pore: np.ndarray,
    voxel_um=1.0,
    periodic=(False, False, False),
    axis: int | None = 2,
    in_place: bool = False,
) -> Geometry:
    """Check a binary volume, keep its accessible cluster and build the distance codes.

    Parameters
    ----------
    pore : (n0, n1, n2) ndarray
        1 (or True) = pore.
    voxel_um : float or (3,) float
        Voxel edges in µm (anisotropic allowed).
    periodic : (3,) bool
        Axes that wrap; the transport axis never does.
    axis : int or None
        Transport axis (0, 1, 2), or None for the periodic medium (largest cluster kept).
    in_place : bool
        Turn ``pore`` (a writeable C-contiguous uint8 array the caller gives up) into the codes: no second volume,
        so a 1000³ image needs about 1 GB in all.
    """
    pore = np.asarray(pore)
    if pore.ndim != 3:
        raise PorepipeError(f"the pore volume must be 3-D, got shape {pore.shape}")
    voxel = _voxel(voxel_um)
    per = np.array([bool(p) for p in np.broadcast_to(periodic, (3,))])
    if axis is not None:
        per[axis] = False
    # memory: the 1-byte work copy of the flood fill becomes the distance codes in place (the raster pass reads each
    # voxel's own 0/1 before writing its code), so beyond ``pore`` only one byte per voxel and the fill's front
    n_total = int(np.count_nonzero(pore))
    codes = accessible_pore(pore, axis, per, in_place=in_place)
    h = voxel / voxel.min()
    n_acc = int(np.count_nonzero(codes))
    with np.errstate(over="ignore"):  # an overflow here is refused by _checked
        area = wall_area(codes, h, per, open_axis=axis)
        volume = n_acc * float(np.prod(h))
    K._box_codes(codes, codes)
    return _checked(
        Geometry(
            codes=codes,
            h=h,
            periodic=per,
            voxel_um=voxel,
            axis=axis,
            total_porosity=n_total / pore.size,
            accessible_porosity=n_acc / pore.size,
            pore_volume=volume,
            wall_area=area,
        )
    )


def require_wall(geom: Geometry) -> None:
    """Refuse a pore space without wall for a run between the faces of its axis (it was a ZeroDivisionError in
    transmission and Wicke-Kallenbach, η = NaN in setup reaction).
    """
    if geom.wall_area == 0:
        raise PorepipeError(
            f"the pore space of shape {geom.codes.shape} has no wall (all pore, every lateral axis periodic): every "
            "particle flies straight through (W = 1), no wall can react, and the Knudsen reference 4V/S is "
            "infinite; give the volume some solid or a closed lateral axis"
        )


def _voxel(voxel_um) -> np.ndarray:
    """The three voxel edges in µm, each positive and finite, else one line."""
    voxel = np.broadcast_to(np.asarray(voxel_um, dtype=float), (3,)).copy()
    if not np.all(np.isfinite(voxel)) or np.any(voxel <= 0):
        raise PorepipeError(f"voxel_um must be positive and finite, got {voxel.tolist()}")
    return voxel


def _checked(geom: Geometry) -> Geometry:
    """``geom``, unless its size in units of the smallest voxel edge overflows (voxel edges 1e-150 and 1e150 µm gave
    an infinite pore volume and wall area, and W = 0 ± 0 with an infinite D_ref, without a word).
    """
    extent = np.array(geom.codes.shape) * geom.h
    if not (
        np.all(np.isfinite(extent)) and math.isfinite(geom.pore_volume) and math.isfinite(geom.wall_area)
    ):
        raise PorepipeError(
            f"voxel edges {geom.voxel_um.tolist()} µm differ too much: the pore volume in units of the smallest "
            f"edge ({geom.pore_volume:.3g}) or its wall area ({geom.wall_area:.3g}) is beyond the float range"
        )
    return geom


# ---------------------------------------------------------------------------------------------------------------------
@dataclass
class Tallies:
    """Per-batch counters of all rounds (rows = batches) and summed histograms."""

    rows: np.ndarray
    profile: np.ndarray
    hitmap: np.ndarray
    orientation: np.ndarray
    msd: np.ndarray
    rounds: int = 0
    round_cpu_s: dict = field(default_factory=dict)  # round -> CPU s of its kernel call (not checkpointed)
    #: (wall s, CPU s) that earlier processes of a resumed run spent up to its checkpoint (NaN: not recorded there)
    carried: tuple[float, float] = (0.0, 0.0)
    #: what ended the rounds (see STOPS) and the relative error then; set by _run_rounds, not checkpointed
    stopped_by: str = ""
    rel_error: float = math.inf

    def add(self, rows, profile, hitmap, orientation, msd):
        self.rows = np.concatenate([self.rows, rows])
        self.profile = self.profile + profile.sum(axis=0)
        self.hitmap = self.hitmap + hitmap.sum(axis=0)
        self.orientation = self.orientation + orientation.sum(axis=0)
        self.msd = np.concatenate([self.msd, msd]) if msd.size else self.msd
        self.rounds += 1


def _save_checkpoint(path: Path, key: str, tallies: Tallies, clock: SpentClock) -> None:
    """The tallies so far, and what the run has spent up to now (``clock``)."""
    spent: dict = {}
    clock.record(spent)
    with (
        atomic_path(path) as tmp,
        open(tmp, "wb") as f,
    ):  # fsync, then rename: a kill leaves the old checkpoint
        np.savez(
            f,
            **spent,
            key=np.array(key),
            rows=tallies.rows,
            profile=tallies.profile,
            hitmap=tallies.hitmap,
            orientation=tallies.orientation,
            msd=tallies.msd,
            rounds=np.array(tallies.rounds),
        )


def _load_checkpoint(path: Path, key: str) -> Tallies | None:
    """The saved tallies if ``path`` exists and was written for ``key``; a mismatching checkpoint is discarded."""
    if not path.is_file():
        return None
    try:
        with np.load(path) as z:
            if str(z["key"]) != key:
                print(f"[diffusion] checkpoint {path} is for another input; discarded", flush=True)
                return None
            tallies = Tallies(
                z["rows"], z["profile"], z["hitmap"], z["orientation"], z["msd"], int(z["rounds"])
            )
            tallies.carried = carried_by(z)
            return tallies
    except (OSError, ValueError, KeyError, EOFError):
        print(f"[diffusion] checkpoint {path} is unreadable; discarded", flush=True)
        return None


def _batch_mean(values: np.ndarray) -> tuple[float, float]:
    """Mean and its batch-means standard error (values: one per independent batch)."""
    values = np.asarray(values, dtype=float)
    if values.size < 2:
        return float(values.mean()), math.inf
    return float(values.mean()), float(values.std(ddof=1) / math.sqrt(values.size))


def _ratio(num: np.ndarray, den: np.ndarray) -> tuple[float, float]:
    """Ratio of sums and its delta-method standard error from per-batch sums."""
    num, den = np.asarray(num, float), np.asarray(den, float)
    # nothing to divide by (no wall hit: the mean flight is longer than all flown): unknown
    if den.sum() == 0:
        return (math.inf if num.sum() > 0 else math.nan), math.inf
    r = num.sum() / den.sum()
    n = num.size
    if n < 2:
        return float(r), math.inf
    resid = num - r * den
    err = math.sqrt(n / (n - 1) * np.sum(resid**2)) / den.sum()
    return float(r), float(err)


@dataclass
class DiffusionResult:
    """Everything one run measured; see the module docstring for the definitions."""

    setup: str
    axis: str
    values: dict = field(default_factory=dict)
    arrays: dict = field(default_factory=dict)
    tallies: Tallies | None = None
    #: root attributes of the result file beyond those every run writes (the stop of a run of rounds)
    attrs: dict = field(default_factory=dict)


def _wall(settings: Settings) -> tuple:
    return K.wall_flags(
        _LAW[settings.wall_law], settings.accommodation, settings.wall_speed is WallSpeed.thermal
    )


def _rel(err: float, value: float) -> float:
    """Relative error err/|value|: 0 when err is 0 and the value is not (specular walls: W = 1 exactly), inf when the
    value is 0 (nothing counted yet: a run with 0 ± 0 has not met any target; it had read as 'relative error 0').
    """
    if value == 0:
        return float("inf")
    return 0.0 if err == 0 else float(err / abs(value))


def _run_rounds(settings, key, checkpoint, label, run_round, rel_error, shapes) -> Tallies:
    """Run rounds of ``settings.batches`` batches until ``rel_error(tallies)`` meets the target or a limit stops
    them; checkpoint after each.
    """
    checkpoint = Path(checkpoint) if checkpoint else None
    tallies = _load_checkpoint(checkpoint, key) if checkpoint else None
    if tallies is None:
        tallies = Tallies(
            np.zeros((0, K.N_TALLY)), *(np.zeros(s) for s in shapes[:3]), np.zeros((0, *shapes[3])), 0
        )
    progress = Progress(label, 0, target=settings.target_rel_error, convergence="statistical")
    clock = SpentClock(tallies.carried)
    while tallies.rounds < settings.max_rounds:
        if tallies.rounds >= 2 and rel_error(tallies) <= settings.target_rel_error:
            break
        if tallies.rows[:, K.T_HITS].sum() >= settings.max_wall_hits:
            break
        cpu0 = time.process_time()
        run_round(tallies)
        tallies.round_cpu_s[tallies.rounds - 1] = time.process_time() - cpu0
        if checkpoint:
            _save_checkpoint(checkpoint, key, tallies, clock)
        rel = rel_error(tallies) if tallies.rounds >= 2 else None
        progress.update(
            tallies.rounds,
            f"{int(tallies.rows[:, K.T_PARTICLES].sum())} particles, "
            f"{tallies.rows[:, K.T_HITS].sum():.3g} wall hits"
            + (
                f", relative error {rel:.2g} (target {settings.target_rel_error:g})"
                if rel is not None
                else ""
            ),
            residual=rel,
        )
    rel = rel_error(tallies) if tallies.rounds >= 2 else float("inf")
    if rel <= settings.target_rel_error:
        tallies.stopped_by = "target_rel_error"
    elif tallies.rows[:, K.T_HITS].sum() >= settings.max_wall_hits:
        tallies.stopped_by = "max_wall_hits"
    else:
        tallies.stopped_by = "max_rounds"
    tallies.rel_error = float(rel)
    progress.close(
        f"{tallies.rounds} rounds, {tallies.rows[:, K.T_HITS].sum():.3g} wall hits, relative error {rel:.2g} "
        + (
            "(target met)"
            if tallies.stopped_by == "target_rel_error"
            else f"(stopped by a limit before the target: {tallies.stopped_by})"
        )
    )
    return tallies


#: what can end the rounds of a transmission, Wicke-Kallenbach or msd run (result attribute ``stopped_by``)
STOPS = ("target_rel_error", "max_rounds", "max_wall_hits")


def stop_attrs(tallies: list[Tallies]) -> dict:
    """The result attributes that say whether the rounds met ``target_rel_error`` and what stopped them (see the
    definitions): of one run, or of a length series' runs (one entry per length in ``stopped_by``).
    """
    return {
        "target_met": int(all(t.stopped_by == "target_rel_error" for t in tallies)),
        "stopped_by": ",".join(t.stopped_by for t in tallies),
        "rel_error": max(t.rel_error for t in tallies),
    }


def _check_tally_memory(settings: Settings, msd: bool = False) -> None:
    """Refuse tallies that cannot fit in memory (per batch: the counters, the axial profile, six hit maps, the
    orientation histogram, the msd samples), one line naming the settings; numpy's allocation error before.
    """
    b = settings.batches
    nb, mb, ob = (
        max(v, 1) for v in (settings.profile_bins, settings.hit_map_bins, settings.orientation_bins)
    )
    per_batch = K.N_TALLY + (3 * settings.msd_samples if msd else nb + 6 * mb * mb + 2 * ob * ob)
    need, memory = 8 * b * per_batch, machine_bytes()
    if need > memory // 2:
        raise PorepipeError(
            f"diffusion tallies of {b} batches (profile_bins {settings.profile_bins}, hit_map_bins "
            f"{settings.hit_map_bins}, orientation_bins {settings.orientation_bins}"
            f"{f', msd_samples {settings.msd_samples}' if msd else ''}) need {need / 1e9:.3g} GB, more than half "
            f"this machine's {memory / 1e9:.3g} GB; use fewer batches or bins"
        )


def _buffers(settings, geom, b):
    nb = max(settings.profile_bins, 1)
    mb = max(settings.hit_map_bins, 1)
    ob = max(settings.orientation_bins, 1)
    return (
        np.zeros((b, K.N_TALLY)),
        np.zeros((b, nb)),
        np.zeros((b, 6, mb, mb), dtype=np.int64),
        np.zeros((b, ob, 2 * ob), dtype=np.int64),
    )


def transport(
    pore: np.ndarray,
    axis: int,
    settings: Settings | None = None,
    voxel_um=1.0,
    periodic=(False, False, False),
    seed: int = 0,
    checkpoint=None,
) -> DiffusionResult:
    """Transmission probability W (``settings.setup = transmission``) or Wicke-Kallenbach D (``wicke_kallenbach``).

    Parameters
    ----------
    pore : (n0, n1, n2) ndarray or Geometry
        1 = pore; particles enter/leave through the faces normal to ``axis``; the lateral outside is solid unless
        ``periodic``. A :class:`Geometry` prepared for ``axis`` by :func:`prepare` is used as it is.
    axis : int
        Transport axis.
    settings : Settings
        The scene's ``diffusion`` section.
    voxel_um : float or (3,) float
        Voxel edges in µm.
    seed : int
        Scene seed; each particle's random stream derives from it and its index only.
    checkpoint : path, optional
        File to save/resume the tallies after each round.

    Returns
    -------
    DiffusionResult
        ``values``: W, W_err, D_transmission (voxel²/jiffie and m²/s), ..., see the module docstring.
    """
    settings = settings or Settings()
    _check_tally_memory(settings)
    geom = (
        pore if isinstance(pore, Geometry) and pore.axis == axis else prepare(pore, voxel_um, periodic, axis)
    )
    wk = settings.setup is Setup.wicke_kallenbach
    kernel = K.make_transport_kernel(
        _wall(settings),
        _LAW[settings.inlet_law],
        _SPEED[settings.inlet_speed],
        wk,
        settings.profile_bins > 0,
        settings.hit_map_bins > 0,
        settings.orientation_bins > 0,
    )
    require_wall(geom)
    inlet, outlet = geom.cells(0), geom.cells(-1)
    if outlet.shape[0] == 0:
        outlet = (
            inlet  # unreachable after accessible_pore (a spanning cluster touches both faces); keeps types
        )
    vmean = 1.0
    length = geom.codes.shape[axis] * geom.h[axis]
    a_open = inlet.shape[0] * float(np.prod(np.delete(geom.h, axis)))
    d_ref = 4.0 * geom.pore_volume / geom.wall_area
    t_end = settings.wk_time_jiffies or 20.0 * length**2 / (vmean * d_ref)
    seed_k = kernel_seed(seed, STAGE, 1 if wk else 0, axis)
    map_bin = np.array(geom.codes.shape, float) * geom.h / max(settings.hit_map_bins, 1)
    b = settings.batches
    per = settings.batch_particles
    key = hash_of(
        {
            "pore": _pore_hash(geom.codes),
            "h": geom.h.tolist(),
            "axis": axis,
            "seed": seed,
            "settings": settings.model_dump(mode="json"),
        }
    )

    def run_round(tallies):
        rows, prof, hmap, orient = _buffers(settings, geom, b)
        first = tallies.rounds * b * per
        kernel(
            geom.codes,
            geom.h,
            geom.periodic,
            axis,
            inlet,
            outlet,
            seed_k,
            first,
            per,
            settings.max_hits_per_particle,
            t_end,
            vmean,
            settings.accommodation,
            rows,
            prof,
            hmap,
            orient,
            map_bin,
        )
        tallies.add(rows, prof, hmap, orient, np.zeros(0))

    def rel_error(tallies):
        w, err = _estimate(tallies.rows, wk)
        return _rel(err, w)

    tallies = _run_rounds(
        settings,
        key,
        checkpoint,
        f"diffusion {'xyz'[axis]}",
        run_round,
        rel_error,
        [
            (max(settings.profile_bins, 1),),
            (6, max(settings.hit_map_bins, 1), max(settings.hit_map_bins, 1)),
            (max(settings.orientation_bins, 1), 2 * max(settings.orientation_bins, 1)),
            (0,),
        ],
    )
    res = DiffusionResult(settings.setup.value, "xyz"[axis], tallies=tallies, attrs=stop_attrs([tallies]))
    v = res.values
    rows = tallies.rows
    _common_values(v, geom, settings, rows)
    if not wk:
        w, w_err = _estimate(rows, False)
        v.update(W=w, W_err=w_err, truncated=int(rows[:, K.T_TRUNC].sum()))
        d = vmean * length * w / 4.0
        d_err = vmean * length * w_err / 4.0
    else:
        d, d_err = _estimate(rows, True)
        d *= length * geom.pore_volume / (2.0 * a_open)
        d_err *= length * geom.pore_volume / (2.0 * a_open)
        v.update(D_wk_thesis=2.0 * d, wk_time_jiffies=t_end)
        v["D_wk_profile"] = _profile_d(tallies, rows, length, a_open, geom)
    v.update(D=d, D_err=d_err, length=length, open_area=a_open, D_ref=vmean * d_ref / 3.0)
    area_total = float(np.prod(np.delete(np.array(geom.codes.shape) * geom.h, axis)))
    v["D_eff"] = d * a_open / area_total
    v["D_eff_err"] = d_err * a_open / area_total
    _derived(v, geom, settings)
    res.arrays = _arrays(tallies, settings, geom, axis)
    # D_eff = factor x (W, or the WK FLUSS rate per particle time), as above
    factor = (
        (vmean * length / 4.0 if not wk else length * geom.pore_volume / (2.0 * a_open)) * a_open / area_total
    )
    res.arrays["history"] = _history(tallies, b, lambda part: tuple(factor * x for x in _estimate(part, wk)))
    return res


def _history(tallies: Tallies, batches: int, estimate) -> np.ndarray:
    """(rounds, 7): after each round, the cumulative particles, flights, wall hits, voxel crossings, the headline
    D_eff with its batch-means error from the batches run so far (``estimate(rows) -> (D_eff, err)``), and the
    round's own kernel CPU seconds (NaN for rounds loaded from a checkpoint; the first includes the compilation).

    The cost of each further digit of D_eff: the error falls as (particles x flights)^-1/2 once the batches are many.
    """
    rows = tallies.rows
    rounds = rows.shape[0] // batches
    out = np.zeros((rounds, len(HISTORY_FIELDS)))
    for r in range(rounds):
        part = rows[: (r + 1) * batches]
        out[r, :4] = part[:, [K.T_PARTICLES, K.T_FLIGHTS, K.T_HITS, K.T_CROSS]].sum(axis=0)
        out[r, 4:6] = estimate(part)
        out[r, 6] = tallies.round_cpu_s.get(r, math.nan)
    return out


#: columns of the ``history`` array (one row per round)
HISTORY_FIELDS = ("particles", "flights", "wall_hits", "voxel_crossings", "D_eff", "D_eff_err", "round_cpu_s")


def _pore_hash(codes: np.ndarray) -> str:
    import hashlib

    digest = hashlib.sha256()
    for layer in codes:  # the bytes of (codes > 0) layer by layer: no full-size temporary
        digest.update(np.ascontiguousarray(layer > 0).tobytes())
    return digest.hexdigest()[:16] + str(codes.shape)


def _estimate(rows: np.ndarray, wk: bool) -> tuple[float, float]:
    """Transmission: W = transmitted / particles. WK: FLUSS count of species 1 per unit species-1 residence.

    Nothing counted is 0 ± (one count more), not 0 ± 0: every batch's 0 has no spread, and W = 0 ± 0 of two
    particles read as exact (the pore spans the sample, so W > 0).
    """
    if not wk:
        num, den = rows[:, K.T_OUT_HIGH], rows[:, K.T_PARTICLES]
    else:
        # species-1 time (profile total) is not per batch; use the symmetric estimate: FLUSS of both species over
        # the total particle time, with N_1 = N/2 by symmetry (the measured split is reported separately)
        num, den = rows[:, K.T_OUT_HIGH] + rows[:, K.T_OUT_LOW], rows[:, K.T_TIME]
    value, err = _ratio(num, den)
    if num.sum() == 0 and den.sum() > 0:
        err = max(err, 1.0 / float(den.sum()))
    return value, err


def _bin_volumes(geom: Geometry, nb: int) -> np.ndarray:
    """Accessible pore volume in each of ``nb`` equal axial bins (layers split by overlap)."""
    ax = geom.axis
    layer = np.count_nonzero(geom.codes > 0, axis=tuple(d for d in range(3) if d != ax)) * float(
        np.prod(geom.h)
    )
    n = layer.size
    edges = np.linspace(0.0, n, nb + 1)  # in layers
    out = np.zeros(nb)
    for b in range(nb):
        lo, hi = edges[b], edges[b + 1]
        j = np.arange(int(np.floor(lo)), min(int(np.ceil(hi)), n))
        overlap = np.minimum(j + 1, hi) - np.maximum(j, lo)
        out[b] = np.sum(layer[j] * np.clip(overlap, 0.0, 1.0))
    return out


def _profile_d(tallies, rows, length, a_open, geom) -> float:
    """FLUSS flux of species 1 over the fitted gradient of its time-averaged concentration (middle 60 %)."""
    prof = tallies.profile
    nb = prof.size
    lifetime = rows[:, K.T_TIME].sum() / max(rows[:, K.T_PARTICLES].sum(), 1)
    vol = _bin_volumes(geom, nb)
    conc = np.divide(prof, lifetime * vol, out=np.zeros(nb), where=vol > 0)
    z = (np.arange(nb) + 0.5) * length / nb
    mid = (z > 0.2 * length) & (z < 0.8 * length) & (vol > 0)
    if mid.sum() < 2:
        return 0.0
    slope = np.polyfit(z[mid], conc[mid], 1)[0]
    flux = rows[:, K.T_OUT_HIGH].sum() / lifetime / a_open
    return float(-flux / slope) if slope < 0 else 0.0


def _common_values(v, geom, settings, rows):
    hits = rows[:, K.T_HITS].sum()
    flights = rows[:, K.T_FLIGHTS].sum()
    v.update(
        particles=int(rows[:, K.T_PARTICLES].sum()),
        wall_hits=int(hits),
        voxel_crossings=int(rows[:, K.T_CROSS].sum()),
        flights=int(flights),
        total_porosity=geom.total_porosity,
        accessible_porosity=geom.accessible_porosity,
        pore_volume=geom.pore_volume,
        wall_area=geom.wall_area,
        four_v_over_s=4 * geom.pore_volume / geom.wall_area,
        mean_free_flight=float(rows[:, K.T_PATH].sum() / max(hits, 1)),
        hit_rate=float(hits / max(rows[:, K.T_TIME].sum(), 1e-300)),
        batches=int(rows.shape[0]),
    )


def _derived(v, geom, settings):
    """SI conversion, Ψ, χ, τ."""
    vbar = mean_speed(settings.species, settings.temperature_K)
    unit = geom.length_unit_m * vbar  # (voxel²/jiffie) -> m²/s
    for k in ("D", "D_err", "D_eff", "D_eff_err", "D_ref", "D_wk_thesis", "D_wk_profile"):
        if k in v:
            v[f"{k}_m2_s"] = v[k] * unit
    v["mean_speed_m_s"] = vbar
    v["jiffie_s"] = geom.length_unit_m / vbar
    eps = geom.accessible_porosity
    psi = v["D_eff"] / v["D_ref"]
    v.update(psi=psi, labyrinth_factor=psi / eps, tortuosity=eps / psi if psi > 0 else float("inf"))
    # V and S are exact counts, so Ψ and χ carry the statistical error of D_eff, and τ = ε/Ψ its relative error (to
    # first order); Ψ's as D_eff_err / D_ref, which stays finite where nothing was transmitted (Ψ = 0, τ = inf)
    psi_err = v["D_eff_err"] / v["D_ref"]
    v.update(
        psi_err=psi_err,
        labyrinth_factor_err=psi_err / eps,
        tortuosity_err=v["tortuosity"] * psi_err / psi if psi > 0 else float("inf"),
    )


def _arrays(tallies, settings, geom, axis):
    """Profiles and maps. ``concentration``: time-averaged particles per voxel volume per simulated particle
    (transmission: per injected particle, in jiffies/voxel³; WK: species 1 per particle alive).
    """
    out = {}
    rows = tallies.rows
    if settings.profile_bins:
        out["profile"] = tallies.profile
        vol = _bin_volumes(geom, tallies.profile.size)
        norm = rows[:, K.T_PARTICLES].sum()
        if settings.setup is Setup.wicke_kallenbach:
            norm *= rows[:, K.T_TIME].sum() / max(rows[:, K.T_PARTICLES].sum(), 1)
        out["concentration"] = np.divide(
            tallies.profile, vol * max(norm, 1e-300), out=np.zeros_like(vol), where=vol > 0
        )
    if settings.hit_map_bins:
        out["hit_map"] = tallies.hitmap
    if settings.orientation_bins:
        out["orientation"] = tallies.orientation
    return out


# ---------------------------------------------------------------------------------------------------------------------
def equilibrium(
    pore: np.ndarray,
    settings: Settings | None = None,
    voxel_um=1.0,
    periodic=(False, False, False),
    seed: int = 0,
    checkpoint=None,
    t_end: float | None = None,
) -> DiffusionResult:
    """Particles in equilibrium in the pore space: wall-hit statistics, and the msd D tensor along periodic axes.

    Closed pores (no periodic axis): mean flight between wall hits and hit rate; for diffuse Lambert walls the
    exact values are 4V/S and v̄S/(4V) (V, S = pore volume and voxel wall area). Periodic axes: D_dd = slope of
    <Δx_d²>/2 against time over the last 3/4 of the samples (intrinsic, per pore volume); D_eff = ε·D_dd.

    Parameters
    ----------
    pore : (n0, n1, n2) ndarray
        1 = pore; all clusters stay (closed pores are allowed) unless an axis is periodic, then the largest
        (wrapped) cluster.
    t_end : float, optional
        Flight time per particle in jiffies (default ``settings.msd_time_jiffies`` or 50 box lengths).
    """
    settings = settings or Settings()
    per = np.array([bool(p) for p in np.broadcast_to(periodic, (3,))])
    _check_tally_memory(settings, msd=True)
    if per.any():
        geom = prepare(pore, voxel_um, per, None)
    else:
        geom = _closed_geometry(pore, voxel_um)
    if per.all() and geom.wall_area == 0:
        raise PorepipeError(
            f"the pore volume of shape {geom.codes.shape} has no wall and every axis is periodic: a flight would "
            "never end (make an axis non-periodic or give the volume some solid)"
        )
    msd = bool(per.any())
    kernel = K.make_equilibrium_kernel(_wall(settings), _SPEED[settings.initial_speed], msd)
    ext = np.array(geom.codes.shape) * geom.h
    t_end = t_end or settings.msd_time_jiffies or 50.0 * float(ext.max())
    t_samples = np.linspace(t_end / settings.msd_samples, t_end, settings.msd_samples)
    if msd and not t_end / settings.msd_samples >= 1e-12 * float(ext.max()):
        raise PorepipeError(
            f"msd flight time {t_end:.3g} jiffies: between two of its {settings.msd_samples} samples a particle "
            f"moves about {t_end / settings.msd_samples:.3g} voxels, below 1e-12 of the {float(ext.max()):.4g}-voxel "
            "box its position resolves; the msd slope would be round-off (it gave D of either sign up to 1e252)"
        )
    cells = np.zeros(
        (0, 3), dtype=np.int64
    )  # start points by rejection over the codes: no 24-byte list per voxel
    b, per_b = settings.batches, settings.batch_particles
    seed_k = kernel_seed(seed, STAGE, 2)
    key = hash_of(
        {
            "pore": _pore_hash(geom.codes),
            "h": geom.h.tolist(),
            "per": per.tolist(),
            "seed": seed,
            "t": t_end,
            "settings": settings.model_dump(mode="json"),
        }
    )

    def run_round(tallies):
        rows = np.zeros((b, K.N_TALLY))
        msd_b = np.zeros((b, settings.msd_samples, 3))
        first = tallies.rounds * b * per_b
        kernel(
            geom.codes,
            geom.h,
            geom.periodic,
            cells,
            seed_k,
            first,
            per_b,
            settings.max_hits_per_particle,
            t_end,
            t_samples,
            1.0,
            settings.accommodation,
            rows,
            msd_b,
        )
        tallies.add(
            rows, np.zeros((b, 1)), np.zeros((b, 6, 1, 1), np.int64), np.zeros((b, 1, 2), np.int64), msd_b
        )

    def rel_error(tallies):
        if msd:
            d, err = _msd_fit(tallies, t_samples)
            return max((_rel(e, v) for e, v in zip(err[per], d[per])), default=0.0)
        f, err = _ratio(tallies.rows[:, K.T_PATH], tallies.rows[:, K.T_HITS])
        return _rel(err, f)

    tallies = _run_rounds(
        settings,
        key,
        checkpoint,
        "diffusion equilibrium",
        run_round,
        rel_error,
        [(1,), (6, 1, 1), (1, 2), (settings.msd_samples, 3)],
    )
    res = DiffusionResult(
        "msd" if msd else "closed",
        "".join("xyz"[d] for d in range(3) if per[d]) or "-",
        tallies=tallies,
        attrs=stop_attrs([tallies]),
    )
    v = res.values
    _common_values(v, geom, settings, tallies.rows)
    flight, flight_err = _ratio(tallies.rows[:, K.T_PATH], tallies.rows[:, K.T_HITS])
    v.update(mean_free_flight=flight, mean_free_flight_err=flight_err, t_end=t_end)
    if msd:
        d, err = _msd_fit(tallies, t_samples)
        for k, name in enumerate("xyz"):
            if per[k]:
                v[f"D_{name}{name}"] = float(d[k])
                v[f"D_{name}{name}_err"] = float(err[k])
        res.arrays["msd"] = tallies.msd.sum(axis=0) / max(tallies.rows[:, K.T_PARTICLES].sum(), 1)
        res.arrays["msd_time"] = t_samples
        dmean = float(np.mean(d[per]))
        v.update(
            D=dmean,
            D_err=float(np.sqrt(np.sum(err[per] ** 2)) / per.sum()),
            D_ref=4.0 * geom.pore_volume / geom.wall_area / 3.0,
        )
        v["D_eff"] = geom.accessible_porosity * dmean
        v["D_eff_err"] = geom.accessible_porosity * v["D_err"]
        _derived(v, geom, settings)

        def d_eff(part):
            rounds = part.shape[0] // b
            d_p, err_p = _msd_fit(Tallies(part, None, None, None, tallies.msd[: rounds * b]), t_samples)
            eps = geom.accessible_porosity
            return eps * float(np.mean(d_p[per])), eps * float(np.sqrt(np.sum(err_p[per] ** 2)) / per.sum())

        res.arrays["history"] = _history(tallies, b, d_eff)
    return res


def _closed_geometry(pore, voxel_um) -> Geometry:
    pore = np.asarray(pore)
    if pore.ndim != 3:
        raise PorepipeError(f"the pore volume must be 3-D, got shape {pore.shape}")
    if not pore.any():
        raise PorepipeError(f"the pore volume of shape {pore.shape} is all solid (no voxel is 1 = pore)")
    voxel = _voxel(voxel_um)  # closed pores checked the voxel edges as prepare does (0 or NaN: NaN results)
    keep = (pore > 0).astype(np.uint8)
    codes = np.empty(keep.shape, dtype=np.uint8)
    K._box_codes(keep, codes)
    h = voxel / voxel.min()
    n = int(keep.sum())
    per = np.zeros(3, dtype=bool)
    with np.errstate(over="ignore"):  # an overflow here is refused by _checked
        volume, area = n * float(np.prod(h)), wall_area(keep, h, per, None)
    return _checked(Geometry(codes, h, per, voxel, None, n / pore.size, n / pore.size, volume, area))


def _msd_fit(tallies, t_samples):
    """D per axis = slope/2 of the batch msd curves over the last 3/4 of the samples; batch-means error."""
    rows = tallies.rows
    npart = rows[:, K.T_PARTICLES]
    curves = tallies.msd / npart[:, None, None]  # (batches, samples, 3)
    half = slice(len(t_samples) // 4, None)
    t = t_samples[half]
    tc = t - t.mean()
    scale = np.abs(
        tc
    ).max()  # tc in units of its largest: tc² of a 1e-300 jiffie run underflowed to 0 (D = 0/0)
    tc = tc / scale
    slopes = np.einsum("s,bsd->bd", tc, curves[:, half, :]) / np.sum(tc * tc) / (2.0 * scale)
    d = slopes.mean(axis=0)
    err = slopes.std(axis=0, ddof=1) / math.sqrt(slopes.shape[0])
    return d, err
