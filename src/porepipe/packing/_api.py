"""The DEM packing engine (the thesis's PackDEM, Zauner 2020, ch. 5): public API.

Decisions the thesis leaves open (documented here once, used everywhere):

- **Boundary:** every axis is periodic by default (the scene's ``domain.periodic``); a closed axis has reflecting
  walls that keep the sphere *centres* in [0, L] (spheres may protrude, as centres define Ω in §5.1).
- **sigma_max of an unlike pair:** the pair law uses sigma* = min(sigma_max,t_i, sigma_max,t_j) in dx_min and
  dx_eq. The printed sigma_max,t_i makes f_ij != -f_ji; the minimum keeps Newton's third law and puts the
  equilibrium overlap sigma*/2 inside the admissible window of *both* spheres. Convergence of sphere i still uses
  its own sigma_max,t_i (§5.1).
- **Force law (§5.2, printed formulas garbled):** V = V^H for dx <= dx_eq, V^LJ beyond, with
  V^H = (1 - V_min) sqrt(k)/2 (1 - dx/dx_eq)^2 + V_min, V^LJ = k [(b/dx)^16 - (b/dx)^8], b = 2^(-1/8) dx_eq,
  V_min = -k/4; f = -dV/dx; no force beyond cutoff * dx_eq. k_ij = (k_t_i + k_t_j)/2.
- **Integrator (§5.3):** v^s = C-/C+ v^{s-1} + (f^{s-1} + f^s) dt / (2 m C+), x^s = x^{s-1} + C- v^s dt +
  f^s dt^2/(2m) with C± = 1 ± dt Xi/2 (the printed extra dt on v^{s-1} dropped); f^s is evaluated at x^{s-1}.
  Xi > 2/dt is refused.
- **Stochastic forces (§5.4.2):** uniform in the *symmetric* cube [-f_max, f_max]^3 (the printed [0, f_max]^3
  would drift and contradict the isotropy claimed), with f_max = 2 m step_size r_i / dt^2 so that the direct
  displacement per step and axis is at most step_size * r_i.
- **Adaptive radii (§5.4.3):** active while (N_c^s - N_c^{s-1}) / N_c^s < t_rc, i.e. while fewer than a fraction
  t_rc of the converged spheres are new (§5.6.2's paraphrase; the printed numerator has the opposite sign).
  Radii stay within [r_min, r_max] of their type.
- **Overlap bookkeeping:** sigma_ij is evaluated for every partner in the neighbour list (which contains all
  pairs with dx <= cutoff (r_i + r_j)); switched-off type pairs (``interactions_off``) neither push nor count.
  A sphere with no partner in reach has max sigma = -inf.
- **Converged output:** the step that finds every sphere converged does not move them: the packing written is
  exactly the configuration that was tested.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numba
import numpy as np

from porepipe._shared import rng
from porepipe._shared.cost import SpentClock
from porepipe._shared.errors import PorepipeError, UnstableRunError
from porepipe._shared.progress import Progress
from porepipe._shared.run_control import without_run_control
from porepipe._shared.spheres import check_spheres
from porepipe._shared.store import hash_of
from porepipe.packing import _kernels as K
from porepipe.packing._io import load_checkpoint, read_checkpoint_key, save_checkpoint
from porepipe.packing._neighbours import build_neighbours, check_box
from porepipe.packing._settings import Effect, Ramp, Settings, Stage
from porepipe.packing._setup import place_type, radius_bounds, read_sphere_file
from porepipe.packing._types import _HISTORY_INT, EFFECT_BITS, HISTORY_KEYS, HISTORY_TIMING, Packing, State

__all__ = [
    "EFFECT_BITS",
    "HISTORY_KEYS",
    "HISTORY_TIMING",
    "Packing",
    "State",
    "check_damping",
    "pack_spheres",
    "pair_tables",
    "schedule_value",
    "sphere_overlaps",
]


def schedule_value(sched, step: int, default: float) -> float:
    """Value of a constant or a linear ramp (5.4.1) at stage step ``step``.

    k^s = k^0 for s < S^0; k^{s-1} + dk for S^0 <= s < S^1, i.e. k^0 + (s - S^0 + 1) dk; k^1 for s >= S^1.
    """
    if sched is None:
        return default
    if not isinstance(sched, Ramp):
        return float(sched)
    if step < sched.from_step:
        return sched.start
    if step >= sched.to_step:
        return sched.end
    dk = (sched.end - sched.start) / (sched.to_step - sched.from_step)
    return sched.start + (step - sched.from_step + 1) * dk


def check_damping(damping: np.ndarray, dt: float, where: str) -> None:
    """Refuse Xi > 2/dt: C- would turn negative and the damping would reverse the motion (§5.3)."""
    bad = np.flatnonzero(damping > 2.0 / dt * (1.0 + 1e-12))
    if bad.size:
        raise PorepipeError(
            f"{where}: damping Xi = {damping[bad[0]]} of type {int(bad[0])} exceeds 2/dt = {2.0 / dt}"
            "; lower the damping or the time step"
        )


class _Tables:
    """Per-type constants of one stage."""

    def __init__(self, settings: Settings, stage: Stage, base_dir: Path):
        names = [t.name for t in settings.types]
        nt = len(names)
        self.names = names
        self.sig = np.array([t.max_overlap for t in settings.types], dtype=np.float64)
        bounds = [radius_bounds(t.radius_um, base_dir) for t in settings.types]
        self.rmin = np.array([b[0] for b in bounds])
        self.rmax = np.array([b[1] for b in bounds])
        self.type_frozen = np.array([n in stage.frozen_types for n in names], dtype=np.uint8)
        self.pair_on = np.ones((nt, nt), dtype=np.uint8)
        for a, b in stage.interactions_off:
            self.pair_on[names.index(a), names.index(b)] = 0
            self.pair_on[names.index(b), names.index(a)] = 0
        self.fmax = np.zeros(nt)
        if stage.stochastic_forces is not None:
            sf = stage.stochastic_forces
            chosen = names if sf.types is None else sf.types
            for n in chosen:
                self.fmax[names.index(n)] = 2.0 * settings.mass * sf.step_size / stage.dt**2
        self.adapt = np.zeros(nt, dtype=np.uint8)
        self.dr = np.zeros(nt)
        if stage.adaptive_radii is not None:
            for n in stage.adaptive_radii.types:
                t = names.index(n)
                self.adapt[t] = 1
                self.dr[t] = (self.rmax[t] - self.rmin[t]) * stage.adaptive_radii.rate

    def k_and_damping(self, stage: Stage, step: int) -> tuple[np.ndarray, np.ndarray]:
        k = np.array([schedule_value(stage.k.get(n), step, 1.0) for n in self.names])
        xi = np.array([schedule_value(stage.damping.get(n), step, 1.0) for n in self.names])
        return k, xi


def pair_tables(k_t: np.ndarray, sig_t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per type pair: k_ij = (k_i + k_j)/2, the harmonic coefficient sqrt(k_ij) (1 + k_ij/4), and
    sigma* = min(sigma_max,i, sigma_max,j) (the step kernel reads these instead of recomputing them per pair).
    """
    k = 0.5 * (k_t[:, None] + k_t[None, :])
    return k, np.sqrt(k) * (1.0 + 0.25 * k), np.minimum(sig_t[:, None], sig_t[None, :])


#: sub-streams of the stage's random stream (porepipe._shared.rng, stage name "packing"): placement and radii of a
#: type inserted in a protocol stage (keys: stage, type), and the counter seed of the stochastic forces (key: stage)
_STREAM_PLACEMENT, _STREAM_FORCES = 0, 1


def _seed_stream(seed: int, stage: int, type_index: int) -> np.random.Generator:
    return rng.stream(seed, "packing", _STREAM_PLACEMENT, stage, type_index)


def _counter_seed(seed: int, stage: int) -> int:
    return rng.kernel_seed(seed, "packing", _STREAM_FORCES, stage)


_PER_SPHERE = ("x", "v", "f", "r", "types", "frozen", "x_build", "r_build", "ids")


def _keep(state: State, mask: np.ndarray) -> None:
    """Keep the spheres selected by ``mask`` (a boolean mask or a permutation)."""
    for name in _PER_SPHERE:
        setattr(state, name, getattr(state, name)[mask])
    state.need_rebuild = True


def _id_order(state: State) -> np.ndarray:
    """Permutation that puts the state's spheres back in insertion order (the order of every output)."""
    return np.argsort(state.ids, kind="stable")


def _append(state: State, centres: np.ndarray, radii: np.ndarray, types: np.ndarray, velocity) -> None:
    """Append spheres moving at ``velocity``; they get the next insertion numbers."""
    n = radii.size
    state.x = np.concatenate([state.x, centres])
    state.v = np.concatenate([state.v, np.tile(np.asarray(velocity, float), (n, 1))])
    state.f = np.concatenate([state.f, np.zeros((n, 3))])
    state.r = np.concatenate([state.r, radii])
    state.types = np.concatenate([state.types, types])
    state.frozen = np.concatenate([state.frozen, np.zeros(n, dtype=np.uint8)])
    state.x_build = np.concatenate([state.x_build, centres])
    state.r_build = np.concatenate([state.r_build, radii])
    state.ids = np.concatenate([state.ids, np.arange(state.next_id, state.next_id + n, dtype=np.int64)])
    state.next_id += n


def _start_stage(
    state: State,
    settings: Settings,
    stage: Stage,
    box: np.ndarray,
    periodic: np.ndarray,
    seed: int,
    base_dir: Path,
) -> None:
    """Remove and insert types at the start of a stage."""
    names = [t.name for t in settings.types]
    if stage.remove_types:
        gone = np.isin(state.types, [names.index(n) for n in stage.remove_types])
        _keep(state, ~gone)
    if stage.insert_file is not None:
        _append(
            state,
            *read_sphere_file(stage.insert_file, settings, box, periodic, base_dir),
            settings.initial_velocity,
        )
    for name in stage.insert:
        t = names.index(name)
        centres, radii = place_type(
            t, settings.types[t], settings, box, _seed_stream(seed, state.stage, t), base_dir
        )
        _append(state, centres, radii, np.full(radii.size, t, dtype=np.int64), settings.initial_velocity)
    state.need_rebuild = True
    state.nconv_prev = 0
    state.since_build = 0


def _record(state: State, **row) -> None:
    for key in HISTORY_KEYS:
        state.history[key].append(row[key])


def _guard(
    stats, state: State, tables: _Tables, stage: Stage, stage_idx: int, step: int, box, settings
) -> None:
    """Stop a run that has gone unstable, naming the step, the sphere and the likely parameter at fault."""
    nconv, ke, smax, ssum, scnt, dmax, darg, stale, bad = stats
    where = f"packing stage {stage_idx} ({stage.name!r}) step {step}"
    if bad >= 0 or not np.isfinite(ke):
        i = int(bad if bad >= 0 else darg)
        t = tables.names[int(state.types[i])] if i >= 0 else "?"
        raise UnstableRunError(
            f"{where}: non-finite position or velocity of sphere {_sphere_no(state, i)} (type {t!r}); "
            f"the time step dt = {stage.dt} is too large for the interaction constant k[{t}] or the "
            "damping"
        )
    limit = settings.max_step_fraction * float(box.min())
    if dmax > limit:
        i = int(darg)
        t = tables.names[int(state.types[i])]
        raise UnstableRunError(
            f"{where}: runaway sphere {_sphere_no(state, i)} (type {t!r}, r = {state.r[i]:.4g} µm) moved {dmax:.4g} µm "
            "in one step "
            f"(limit max_step_fraction * box = {limit:.4g} µm, kinetic energy {ke:.4g}); likely cause: dt = {stage.dt} "
            f"too large for k[{t}] = {stage.k.get(t, 1.0)} (or a too-strong stochastic force / overlap at start)"
        )


def _sphere_no(state: State, i: int) -> int:
    """The user-facing number of the sphere at position i (its insertion number; -1 if none)."""
    return int(state.ids[i]) if 0 <= i < state.ids.size else -1


def _effect_bits(effects, adapting: bool, locking: bool) -> int:
    bits = 0
    for e in effects:
        if e is Effect.adaptive_radii and not adapting:
            continue
        if e is Effect.freezing and not locking:
            continue
        bits |= EFFECT_BITS[e]
    return bits


def _finish_stage(state: State, stage: Stage, tables: _Tables, box, periodic, conv: np.ndarray) -> None:
    """Delete unconverged spheres of the chosen types, then evaluate the overlaps of the configuration kept.

    Deletion is repeated until no deletable sphere is unconverged, since removing a sphere can leave a former
    partner isolated.
    """
    sig, conv = sphere_overlaps(state.x, state.r, state.types, box, periodic, tables.sig, tables.pair_on)
    if stage.delete_unconverged:
        deletable = np.array([n in stage.delete_unconverged for n in tables.names])
        while True:
            doomed = deletable[state.types] & (conv == 0)
            if not doomed.any():
                break
            _keep(state, ~doomed)
            sig, conv = sphere_overlaps(
                state.x, state.r, state.types, box, periodic, tables.sig, tables.pair_on
            )
    order = _id_order(state)
    state.stage_converged.append(bool(conv.all()))
    state.stage_steps.append(state.step)
    state.snapshots.append(
        {
            "name": stage.name,
            "centres_um": state.x[order],
            "radii_um": state.r[order],
            "types": state.types[order].astype(np.int32),
            "max_overlap": sig[order],
            "converged": conv[order],
        }
    )
    state.stage += 1
    state.step = 0
    state.need_rebuild = True


def _run_stage(
    state: State,
    settings: Settings,
    stage: Stage,
    box: np.ndarray,
    periodic: np.ndarray,
    seed: int,
    base_dir: Path,
    checkpoint,
    progress: bool,
) -> None:
    """Run one stage from ``state.step`` until convergence or the step limit."""
    stage_idx = state.stage
    tables = _Tables(settings, stage, base_dir)
    effects = stage.effects(tuple(bool(p) for p in periodic))
    freeze = bool(effects & {Effect.freezing, Effect.frozen_types})
    kernel = K.make_step_kernel(freeze, Effect.stochastic_forces in effects, Effect.walls in effects)
    for s in (0, stage.steps):
        check_damping(
            tables.k_and_damping(stage, s)[1], stage.dt, f"packing stage {stage_idx} ({stage.name!r})"
        )
    if state.step == 0:
        _start_stage(state, settings, stage, box, periodic, seed, base_dir)
        state.frozen[:] = tables.type_frozen[state.types]
    n = state.r.size
    threads = numba.get_num_threads()
    if n < settings.parallel_min_spheres:
        numba.set_num_threads(1)
    try:
        _integrate(
            state, settings, stage, tables, effects, freeze, kernel, box, periodic, seed, checkpoint, progress
        )
    finally:
        numba.set_num_threads(threads)


def _integrate(
    state, settings, stage, tables, effects, freeze, kernel, box, periodic, seed, checkpoint, progress
):
    """The step loop of one stage."""
    stage_idx = state.stage
    n = state.r.size
    if n and not np.isfinite(state.x).all():
        raise PorepipeError(
            f"packing stage {stage_idx} ({stage.name!r}): non-finite sphere centres at the start"
        )
    cseed = _counter_seed(seed, stage_idx)
    x_new = np.empty_like(state.x)
    f_new = np.empty_like(state.f)
    sig = np.full(n, -np.inf)
    conv = np.zeros(n, dtype=np.uint8)
    aux = np.zeros((n, 3))
    work = K.work_array(n)  # the step kernel's work array (allocated once: see make_step_kernel)
    nbr = None
    prog = (
        Progress(f"pack {stage.name}", stage.steps, every_s=settings.progress_every_s, target=0.5)
        if progress
        else None
    )
    converged = n == 0
    while not converged and state.step < stage.steps:
        s = state.step + 1
        t_step = time.perf_counter()
        if nbr is None or state.need_rebuild:
            if state.need_rebuild:
                state.x_build = state.x.copy()
                state.r_build = state.r.copy()
                state.since_build = 0
            skin = settings.skin_rel * float(state.r_build.min())
            check_box(state.r_build, box, periodic, settings.cutoff, skin)
            *nbr, order = build_neighbours(
                state.x_build,
                state.r_build,
                state.types,
                box,
                periodic,
                tables.pair_on,
                settings.cutoff,
                skin,
                reorder=True,
                half=True,
            )
            rebuilt = int(state.need_rebuild)
            _keep(state, order)
            state.need_rebuild = False
        else:
            rebuilt = 0
        k_t, xi_t = tables.k_and_damping(stage, s)
        cm = 1.0 - 0.5 * stage.dt * xi_t
        cp = 1.0 + 0.5 * stage.dt * xi_t
        kernel(
            state.x,
            x_new,
            state.v,
            state.f,
            f_new,
            state.r,
            state.types,
            state.ids,
            state.frozen,
            *nbr,
            box,
            periodic,
            *pair_tables(k_t, tables.sig),
            tables.sig,
            cm,
            cp,
            tables.fmax,
            settings.cutoff,
            stage.dt,
            settings.mass,
            cseed,
            s,
            state.x_build,
            state.r_build,
            sig,
            conv,
            aux,
            work,
        )
        stats = _step_stats(sig, conv, aux)
        nconv, ke, smax, ssum, scnt, dmax, darg, stale, bad = stats
        _guard(stats, state, tables, stage, stage_idx, s, box, settings)
        converged = nconv == n
        adapting = False
        # §5.4.4: "for s > s_lock, converged spheres are frozen" — frozen during step s are the spheres converged
        # after step s - 1, so the set decided here applies from step s_lock + 1 on (not one step later)
        locking = freeze and stage.freezing is not None and s > stage.freezing.lock_step
        if not converged:
            state.x, x_new = x_new, state.x
            state.f, f_new = f_new, state.f
            if stage.adaptive_radii is not None:
                ar = stage.adaptive_radii
                growth = (nconv - state.nconv_prev) / max(nconv, 1)
                adapting = (
                    ar.from_step < s < ar.to_step and s < stage.steps - ar.quiet_steps and growth < ar.trigger
                )
                if adapting:
                    _adapt_radii(state.r, state.types, sig, tables)
            if freeze:
                lock_next = stage.freezing is not None and s + 1 > stage.freezing.lock_step
                state.frozen[:] = tables.type_frozen[state.types] | (conv if lock_next else 0)
            state.since_build += 1
            if settings.rebuild_interval > 0:
                state.need_rebuild = state.since_build >= settings.rebuild_interval
            else:
                stale_now = stale if not adapting else _staleness(state, box, periodic, settings.cutoff)
                state.need_rebuild = stale_now > 0.5 * settings.skin_rel * float(state.r_build.min())
        state.nconv_prev = int(nconv)
        state.step = s
        _record(
            state,
            stage=stage_idx,
            step=s,
            n_spheres=n,
            converged=int(nconv),
            max_overlap=float(smax),
            mean_overlap=float(ssum / scnt) if scnt else float("nan"),
            kinetic_energy=float(ke),
            max_displacement_um=float(dmax) if not converged else 0.0,
            effects=_effect_bits(effects, adapting, locking),
            rebuilt=rebuilt,
            wall_s=time.perf_counter() - t_step,
        )
        if prog is not None:
            prog.update(
                s,
                f"converged {nconv}/{n}, max sigma {smax:.4g}, E_kin {ke:.4g}",
                force=converged,
                residual=n - nconv,  # unconverged spheres: the run stops when none is left
            )
        # not at the step that found convergence: a resume from it would run one step more than this run does
        if checkpoint is not None and not converged and checkpoint.due(s):
            checkpoint.write(state)
    n_before = len(state.r)
    _finish_stage(state, stage, tables, box, periodic, conv)
    if prog is not None:
        deleted = n_before - len(state.r)
        prog.close(
            f"{'converged' if state.stage_converged[-1] else 'NOT converged'} after {state.stage_steps[-1]} steps, "
            f"{len(state.r)} spheres" + (f", {deleted} unconverged deleted" if deleted else "")
        )


def _step_stats(sig: np.ndarray, conv: np.ndarray, aux: np.ndarray) -> tuple:
    """Reductions of one step: (converged count, kinetic energy, max sigma, sum and count of finite sigma,
    largest step displacement and its sphere, list staleness, first non-finite sphere or -1).

    One numba pass over fixed chunks: the same values for any thread count.
    """
    if sig.size == 0:
        return 0, 0.0, -np.inf, 0.0, 0, 0.0, -1, 0.0, -1
    return K._step_reductions(sig, conv, aux)


def _adapt_radii(r: np.ndarray, types: np.ndarray, sig: np.ndarray, tables) -> None:
    """§5.4.3: grow isolated spheres (max sigma < 0), shrink over-overlapping ones (max sigma > sigma_max)."""
    on = tables.adapt[types].astype(bool)
    grow = on & (sig < 0.0)
    shrink = on & (sig > tables.sig[types])
    r[grow] = np.minimum(r[grow] + tables.dr[types[grow]], tables.rmax[types[grow]])
    r[shrink] = np.maximum(r[shrink] - tables.dr[types[shrink]], tables.rmin[types[shrink]])


def _staleness(state: State, box, periodic, cutoff) -> float:
    d = state.x - state.x_build
    per = np.asarray(periodic, bool)
    d[:, per] -= box[per] * np.floor(d[:, per] / box[per] + 0.5)
    return float(
        np.max(np.sqrt((d * d).sum(1)) + cutoff * np.maximum(0.0, state.r - state.r_build), initial=0.0)
    )


def sphere_overlaps(centres_um, radii_um, types, box_um, periodic, max_overlap_t, pair_on=None, cutoff=1.0):
    """Per-sphere max_j sigma_ij and the convergence flag 0 < max sigma <= sigma_max,t (§5.1), via the cell lists.

    Parameters
    ----------
    centres_um : (N, 3) float64
    radii_um : (N,) float64
    types : (N,) int
    box_um : (3,) float64
    periodic : (3,) bool
    max_overlap_t : (T,) float64
        sigma_max per type.
    pair_on : (T, T) uint8, optional
        Type pairs that interact (default: all).
    """
    x = np.ascontiguousarray(centres_um, dtype=np.float64)
    r = np.ascontiguousarray(radii_um, dtype=np.float64)
    types = np.ascontiguousarray(types, dtype=np.int64)
    sig_t = np.asarray(max_overlap_t, dtype=np.float64)
    nt = sig_t.size
    if sig_t.shape != (nt,) or nt == 0 or not np.all(np.isfinite(sig_t)):
        raise PorepipeError(
            f"sphere_overlaps: max_overlap_t needs one finite value per type, got {max_overlap_t!r}"
        )
    pair_on = np.ones((nt, nt), dtype=np.uint8) if pair_on is None else pair_on
    if np.shape(pair_on) != (nt, nt):
        raise PorepipeError(
            f"sphere_overlaps: pair_on needs shape ({nt}, {nt}) for {nt} type(s), got {np.shape(pair_on)}"
        )
    n = r.size
    sig = np.full(n, -np.inf)
    conv = np.zeros(n, dtype=np.uint8)
    if n == 0:
        return sig, conv
    box, per = _as_box(box_um, periodic)  # a writable `per`: a read-only one would compile every kernel again
    check_spheres(x, r, "sphere_overlaps")  # before the wrap below, which would turn a NaN into a crash
    check_box(r, box, per, 1.0, 0.0)  # a sphere reaching its own periodic image: the minimum image breaks
    x = x.copy()
    x[:, per] = np.mod(x[:, per], box[per])  # the kernels assume periodic coordinates in [0, L)
    lists = build_neighbours(x, r, types, box, per, pair_on, 1.0, 0.0, half=True)
    # every sphere frozen: the step only evaluates overlaps, and the stochastic branch never runs. The variant with
    # freezing and stochastic forces is the one the thesis protocol's stages use, so a packing run compiles one
    # step kernel less (cold start of the mini scene)
    kernel = K.make_step_kernel(True, True, not per.all())
    frozen = np.ones(n, dtype=np.uint8)
    zeros = np.zeros((n, 3))
    ones = np.ones(nt)
    kernel(
        x,
        np.empty_like(x),
        zeros.copy(),
        zeros.copy(),
        zeros.copy(),
        r,
        types,
        np.arange(n),
        frozen,
        *lists,
        box,
        per,
        *pair_tables(ones, sig_t),
        sig_t,
        ones,
        ones,
        np.zeros(nt),
        float(cutoff),
        1.0,
        1.0,
        0,
        0,
        x,
        r,
        sig,
        conv,
        np.empty((n, 3)),
        K.work_array(n),
    )
    return sig, conv


def _as_box(box_um, periodic) -> tuple[np.ndarray, np.ndarray]:
    box = np.asarray(box_um, dtype=np.float64).reshape(-1)
    if box.shape != (3,) or not np.all(np.isfinite(box)) or np.any(box <= 0):
        raise PorepipeError(f"packing box_um must be 3 positive edge lengths in µm, got {box_um!r}")
    if np.shape(periodic) not in ((), (3,)):
        raise PorepipeError(f"packing periodic must be one flag or 3 (x, y, z), got {periodic!r}")
    per = np.broadcast_to(np.asarray(periodic, dtype=np.bool_), (3,)).copy()
    return box, per


#: the wall clock (seconds) that times checkpoints; a test replaces it to advance time without sleeping
_checkpoint_clock = time.monotonic


class _Checkpoints:
    """Where and when a run saves its state: after a step that is a multiple of ``every_steps``, or once
    ``every_s`` wall seconds have passed since the last checkpoint (or the start); 0 switches an interval off.

    The clock is read once when the run starts and once per step (in :meth:`due`).
    """

    def __init__(self, path, key: str, spent: SpentClock, every_steps: int, every_s: float, clock):
        self.path, self.key, self.spent = Path(path), key, spent
        self.every_steps, self.every_s, self.clock = every_steps, every_s, clock
        self.last_s = self.now_s = clock()

    def due(self, step: int) -> bool:
        """Whether a checkpoint is due after stage step ``step``."""
        self.now_s = self.clock()
        by_steps = self.every_steps > 0 and step % self.every_steps == 0
        return by_steps or (self.every_s > 0 and self.now_s - self.last_s >= self.every_s)

    def write(self, state: State) -> None:
        """Save ``state`` (atomically); the wall-time interval starts again."""
        save_checkpoint(self.path, state, self.key, self.spent)
        self.last_s = self.now_s


def checkpoint_key(settings: Settings, box, periodic, seed: int, base_dir: Path) -> str:
    """Hash of everything that determines a packing: settings (less run control), box, periodicity, seed, files.

    Files named by ``insert_file`` enter by their size and modification time, so an edited file invalidates the key.
    """
    dumped = without_run_control(settings)
    files = sorted({str(st.insert_file.path) for st in settings.stages if st.insert_file is not None})
    stamps = []
    for name in files:
        path = base_dir / name
        stat = path.stat() if path.is_file() else None
        stamps.append([name, stat.st_size if stat else -1, stat.st_mtime_ns if stat else -1])
    return hash_of(
        {
            "settings": dumped,
            "box": np.asarray(box).tolist(),
            "periodic": np.asarray(periodic).tolist(),
            "seed": int(seed),
            "files": stamps,
        }
    )


def _resumed_state(checkpoint_path, key: str) -> State:
    """The checkpoint's state if it was written for the same packing and can be read; otherwise a fresh start (and
    say why: a damaged checkpoint would stop every rerun of the pack rule, which always resumes).
    """
    path = Path(checkpoint_path)
    if not path.is_file():
        return State.empty()
    try:
        found = read_checkpoint_key(path)
        if found == key:
            return load_checkpoint(path)
    except PorepipeError as err:  # damaged, truncated, not HDF5: it names the file and what failed
        print(f"pack: {err}: discarding it, starting afresh", file=sys.stderr)
    else:
        why = (
            f"it was written for other settings, box or seed (key {found}, this run {key})"
            if found
            else "it carries no key (not written by this version of porepipe pack, or damaged)"
        )
        print(f"pack: discarding checkpoint {path}: {why}; starting afresh", file=sys.stderr)
    path.unlink()
    return State.empty()


def pack_spheres(
    settings: Settings,
    box_um,
    periodic=True,
    seed: int = 0,
    *,
    base_dir: Path | str = ".",
    checkpoint_path: Path | str | None = None,
    resume: bool = False,
    progress: bool = False,
) -> Packing:
    """Run the staged DEM protocol of ``settings`` in the box and return the packing.

    Parameters
    ----------
    settings : Settings
        The scene's ``packing`` section.
    box_um : (3,) float
        Box edges in µm; the box is [0, L_x) x [0, L_y) x [0, L_z).
    periodic : bool or (3,) bool
        Periodic axes (default all); closed axes get reflecting walls.
    seed : int
        Root of the random streams (placement, radii, stochastic forces).
    base_dir : path
        Directory that relative file names in ``settings`` refer to.
    checkpoint_path : path, optional
        Where the run's state is saved every ``settings.checkpoint_every_s`` wall seconds and every
        ``settings.checkpoint_every`` steps, whichever comes first (0 switches an interval off); deleted when the
        packing is complete. Without it nothing is saved.
    resume : bool
        Continue from ``checkpoint_path`` if it exists (bit-identical to an uninterrupted run).
    progress : bool
        Print progress lines to stderr.

    Returns
    -------
    Packing
    """
    box, per = _as_box(box_um, periodic)
    if not settings.types or not settings.stages:
        raise PorepipeError("packing needs at least one entry in `types` and one in `stages`")
    base_dir = Path(base_dir)
    key = checkpoint_key(settings, box, per, seed, base_dir)
    state = _resumed_state(checkpoint_path, key) if resume and checkpoint_path is not None else State.empty()
    saver = None
    if checkpoint_path is not None:
        every = (settings.checkpoint_every, settings.checkpoint_every_s)
        if not any(every):
            print(
                f"pack: packing.checkpoint_every and checkpoint_every_s are both 0: no checkpoint is written to "
                f"{checkpoint_path}",
                file=sys.stderr,
            )
        saver = _Checkpoints(checkpoint_path, key, SpentClock(state.carried), *every, _checkpoint_clock)
    while state.stage < len(settings.stages):
        _run_stage(state, settings, settings.stages[state.stage], box, per, seed, base_dir, saver, progress)
    if checkpoint_path is not None:
        Path(checkpoint_path).unlink(missing_ok=True)  # the run is complete: a later run must not resume it
    last = state.snapshots[-1]
    history = {
        k: np.asarray(v, dtype=np.int64 if k in _HISTORY_INT else np.float64)
        for k, v in state.history.items()
    }
    return Packing(
        centres_um=last["centres_um"].copy(),
        radii_um=last["radii_um"].copy(),
        types=last["types"].copy(),
        max_overlap=last["max_overlap"],
        converged=last["converged"],
        type_names=[t.name for t in settings.types],
        box_um=box,
        periodic=per,
        history=history,
        stage_converged=list(state.stage_converged),
        stage_steps=list(state.stage_steps),
        snapshots=state.snapshots,
        carried=state.carried,
    )
