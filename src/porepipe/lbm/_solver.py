"""Time stepping with convergence control, stability guards, progress and checkpoint/resume."""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import math
import time
from pathlib import Path

import h5py
import numba
import numpy as np

from porepipe._shared.atomic import atomic_path
from porepipe._shared.cost import SPENT_ATTRS, SpentClock, carried_by
from porepipe._shared.errors import PorepipeError
from porepipe._shared.progress import Progress
from porepipe._shared.store import hash_of, open_h5
from porepipe.lbm import _kernels as K
from porepipe.lbm._darcy import estimate_key, estimates, sample_mean_rho
from porepipe.lbm._domain import Lattice
from porepipe.lbm._lattice import CS2, dhumieres_matrix, mrt_rates, trt_minus_tau, viscosity
from porepipe.lbm._mpi import ONE_PROCESS, Serial, SharedError
from porepipe.lbm._settings import Collision, Precision, Settings, StopRule, Streaming
from porepipe.lbm._walls import Links

#: τ̂ − ½ below this is refused (ν̂ → 0: the scheme loses stability and the wall position runs away).
TAU_MIN_GAP = 5e-3
#: velocity changes are taken relative to max(|v|, this × max |v|): near-stagnant nodes (slower than 1 % of the
#: peak, negligible for the flux) do not hold up Eq. 6.1.30.
VELOCITY_FLOOR = 1e-2
#: below this many pore nodes per thread a parallel step costs more in thread wake-ups than it saves.
NODES_PER_THREAD = 32_768
#: keys of the settings that change the numbers (checkpoints must match them).
_PHYSICS_KEYS = ("collision", "tau", "tau_bulk", "magic", "mrt_magic", "body_force", "precision", "walls")
#: relative κ̂ changes below this are round-off: the tail estimate of :func:`kappa_error` is not needed.
ROUND_OFF = 1e-13
#: κ̂ changes below this fraction of ``tolerance_kappa`` count as noise (a residual oscillation, e.g. of
#: interpolated walls at large τ on thin plates, ~1e-8): κ̂ is settled to that size even if they do not decay.
NOISE_FRACTION = 1e-2


class StabilityError(SharedError):
    """The run became unstable; the message names the step and the parameter to change (every rank of an MPI run
    decides it from the same reduced numbers).
    """


@dataclasses.dataclass
class Run:
    """Outcome of :func:`solve`."""

    converged: bool
    steps: int
    history: dict[str, np.ndarray]
    fields: np.ndarray  # (4, N): δρ, u0, u1, u2 of the last check
    estimates: dict[str, float]
    kappa_key: str
    mlups: float
    step_wall_s: float
    total_mass: float
    stopped_by: str = "step_limit"  # "kappa", "density" or "step_limit"
    kappa_error: float = float("inf")  # estimated relative distance of κ̂ to its converged value
    resumed_step: int = 0  # the checkpoint's step this run resumed from (0: started afresh)
    #: (wall s, CPU s) the earlier processes spent in the solver up to that checkpoint (NaN: not recorded there)
    carried: tuple[float, float] = (0.0, 0.0)

    @property
    def kappa(self) -> float:
        return self.estimates[self.kappa_key]


def check_tau(settings: Settings) -> None:
    """Refuse τ̂ too close to ½ before anything runs."""
    if settings.tau - 0.5 < TAU_MIN_GAP:
        raise StabilityError(
            f"tau={settings.tau} is within {TAU_MIN_GAP} of 1/2 (viscosity → 0, unstable): "
            f"increase `tau` to at least {0.5 + TAU_MIN_GAP}"
        )
    if settings.collision is Collision.mrt and settings.tau_bulk - 0.5 < TAU_MIN_GAP:
        raise StabilityError(
            f"tau_bulk={settings.tau_bulk} is within {TAU_MIN_GAP} of 1/2: increase `tau_bulk`"
        )


def _in_place_links(settings: Settings, links: Links) -> bool:
    """Whether the in-place (AA) kernel can run these wall links: none, or linear ones (cli, bfl) in float64 (a
    link value in place is stored in the population array; in float32 that rounding would change the bits).
    """
    if links.size == 0:
        return True
    return not links.multi_reflection and settings.precision is Precision.float64


def _streams_in_place(settings: Settings, lat: Lattice, links: Links) -> bool:
    """What ``streaming`` chooses: aa (refused later where the links cannot), pull, or for auto in place with
    halfway walls, and with linear links where the arrays exceed the cache.
    """
    if settings.streaming is not Streaming.auto:
        return settings.streaming is Streaming.aa
    # below the cache a run takes seconds, and the in-place variant's ~3 CPU-s of compilation would cost more (the
    # mini scene's 25³ lattice): only beyond it does streaming in place with wall links pay
    if links.size == 0:
        return True
    nbytes = 2 * 19 * lat.n_nodes * np.dtype(settings.precision.value).itemsize
    return _in_place_links(settings, links) and K.beyond_cache(nbytes)


#: the in-place link table of a run without links, or of a pull run
_NO_LINKS_IN_PLACE = np.zeros(0, dtype=np.uint32)


def _in_place_link_table(lat: Lattice, links: Links) -> np.ndarray:
    """(K,) uint32: the slot behind each linear link in an in-place gather step (:func:`K.aa_link_slots`)."""
    if links.size == 0:
        return _NO_LINKS_IN_PLACE
    table = np.empty(links.size, dtype=np.uint32)
    bad = K.aa_link_slots(
        lat.gather, lat.run_start, lat.run_offset, lat.run_base, links.tile_start, links.slot, table
    )
    if bad >= 0:
        raise PorepipeError(
            f"wall link {bad} is not a bounce-back link of this lattice (links of another lattice?)"
        )
    return table


def make_stepper(settings: Settings, lat: Lattice, links: Links | None = None, stores: int | None = None):
    """``step(src, dst, fields, store, n_steps)`` for the chosen operator (its parameters are fixed once, here);
    ``links``: interpolated boundary links (None: halfway bounce-back everywhere); ``stores``: how the kernel writes
    the populations (``_kernels.STORE_*`` or ``IN_PLACE``; None: ``settings.streaming`` decides, and for pull
    :func:`porepipe.lbm._kernels.streams` chooses by array size).
    """
    links = links if links is not None else Links.none()
    if stores is None and _streams_in_place(settings, lat, links):
        stores = K.IN_PLACE
    if stores == K.IN_PLACE and not _in_place_links(settings, links):
        raise PorepipeError(
            f"permeability.streaming = aa cannot run these wall links (walls: {settings.walls.value}, precision: "
            f"{settings.precision.value}): in place needs linear links in float64; use streaming: auto or pull"
        )
    link_aa = _in_place_link_table(lat, links) if stores == K.IN_PLACE else _NO_LINKS_IN_PLACE
    lo, hi = lat.force_nodes
    force = np.array([settings.body_force, 0.0, 0.0])
    tau = settings.tau
    omega = np.array([1.0 / tau, 0.0])
    rates = (0.0,) * 19  # MRT's s_k / |M_k|², a tuple: constants of the collision loop
    if settings.collision is Collision.bgk:
        op = K.BGK
        omega[1] = omega[0]  # BGK is TRT with ω⁻ = ω (the multi-reflection walls read it)
    elif settings.collision is Collision.trt:
        op = K.TRT
        omega[1] = 1.0 / trt_minus_tau(tau, settings.magic)
    elif settings.collision is Collision.mrt:
        op = K.MRT
        m = dhumieres_matrix()
        scaled = mrt_rates(tau, settings.tau_bulk, settings.mrt_magic) / (m * m).sum(axis=1)
        rates = tuple(float(x) for x in scaled)
    else:
        raise PorepipeError(
            f"permeability.collision = {settings.collision!r}: no stepper for it (steppers exist for "
            "bgk, trt and mrt)"
        )

    def step(src, dst, fields, store, n):  # one step (MPI steps one at a time) pulls: nothing to pair it with
        K.step(
            op,
            stores == K.IN_PLACE,
            src,
            dst,
            lat.gather,
            lat.run_start,
            lat.run_offset,
            lat.run_base,
            lo,
            hi,
            force,
            fields,
            store,
            n,
            K.streams(src) if stores is None or (stores == K.IN_PLACE and n < 2) else stores,
            omega,
            rates,
            links.tile_start,
            links.slot,
            links.b,
            links.c,
            links.mr,
            links.state,
            link_aa,
        )

    return step


def _checkpoint_key(lat: Lattice, settings: Settings, links: Links | None, decomposition: str = "") -> str:
    q = ""
    if links is not None and links.size:
        q = hashlib.sha256(links.slot.tobytes() + links.b.tobytes() + links.c.tobytes()).hexdigest()[:16]
    record = {"lattice": lat.key(), "links": q, **{k: str(getattr(settings, k)) for k in _PHYSICS_KEYS}}
    if decomposition:  # one process keeps its keys of before
        record["decomposition"] = decomposition
    return hash_of(record)


def kappa_error(kappas, noise: float = ROUND_OFF) -> float:
    """Estimated relative distance of the last κ̂ to the converged one, from the last three checks a window apart.

    With successive changes Δ₁, Δ₂ and r = Δ₂/Δ₁: a geometric tail |Δ₂| r/(1 − r) for 0 ≤ r < 1 (exponential
    approach to the steady state), |Δ₂| for r < 0 (an alternating series is within its last term), unbounded for
    r ≥ 1 (not yet converging) unless |Δ₂|/|κ̂| is below ``noise`` (round-off, or a residual oscillation of that
    size: κ̂ is then known to about |Δ₂|). Relative to |κ̂|; inf with fewer than three checks.
    """
    if len(kappas) < 3 or not all(math.isfinite(k) for k in kappas[-3:]) or kappas[-1] == 0:
        return float("inf")
    k1, k2, k3 = kappas[-3:]
    d1, d2 = k2 - k1, k3 - k2
    rel = abs(d2) / abs(k3)
    if rel < max(noise, ROUND_OFF):
        return rel
    r = d2 / d1 if d1 != 0 else float("inf")
    if r < 0:
        return rel
    return rel * r / (1 - r) if r < 1 else float("inf")


def _save_checkpoint(
    path: Path,
    key: str,
    step: int,
    pops: np.ndarray,
    fields: np.ndarray,
    history: dict,
    state,
    spent: tuple[float, float],
) -> None:
    """``state``: the multi-reflection links' carried n⁻ (:attr:`Links.state`), if any; ``spent``: (wall s, CPU s)
    in the solver up to now, earlier processes of a resumed run included.
    """
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["key"] = key
        f.attrs["step"] = step
        f.attrs[SPENT_ATTRS[0]], f.attrs[SPENT_ATTRS[1]] = spent
        f.create_dataset("populations", data=pops)
        if state is not None and state.size:
            f.create_dataset("link_state", data=state)
        f.create_dataset("fields", data=fields)
        for name, values in history.items():
            f.create_dataset(f"history/{name}", data=np.asarray(values))


def _load_checkpoint(path: Path, key: str, pops: np.ndarray, state=None):
    """(step, fields, history, spent) from a matching checkpoint, or None; fills ``pops`` (and ``state``, the
    multi-reflection links' n⁻, if given and non-empty). ``spent``: the (wall s, CPU s) it records, NaN in a
    checkpoint written before it recorded them.
    """
    if path is None or not path.is_file():
        return None
    try:
        with open_h5(path) as f:
            if f.attrs.get("key") != key or f["populations"].shape != pops.shape:
                return None
            pops[...] = f["populations"][...]
            if state is not None and state.size:
                state[...] = f["link_state"][...]
            history = (
                {name: list(f[f"history/{name}"][...]) for name in f["history"]} if "history" in f else {}
            )
            return int(f.attrs["step"]), f["fields"][...], history, carried_by(f.attrs)
    except (PorepipeError, KeyError, ValueError, TypeError) as err:
        raise PorepipeError(
            f"LBM checkpoint {path} is damaged ({err}); delete it to start afresh, or rerun with --no-resume"
        ) from None


def _guard(fields: np.ndarray, step: int, settings: Settings, comm=ONE_PROCESS) -> float:
    """Raise on NaN/Inf or a Mach number above the limit (over every process); return the Mach number."""
    finite, u2 = K._finite_and_max_speed2(fields)
    finite, u2 = not comm.max(float(not finite)), comm.max(u2)
    if not finite:
        raise StabilityError(
            f"non-finite density or velocity at step {step}: the run is unstable; increase `tau` "
            f"(now {settings.tau}) or reduce `body_force` (now {settings.body_force})"
        )
    mach = math.sqrt(u2 / CS2)
    if mach > settings.mach_max:
        raise StabilityError(
            f"Mach number {mach:.3g} > mach_max={settings.mach_max} at step {step}: reduce "
            f"`body_force` (now {settings.body_force}) or increase `tau` (now {settings.tau})"
        )
    return mach


def _next_check(done: int, window: int) -> int:
    """Step of the next check: 1, 2, 4, … (an early blow-up is caught at once), then multiples of the window.

    A function of the step alone, so a resumed run checks at the same steps as an uninterrupted one.
    """
    if done == 0:
        return 1
    if 2 * done < window:
        return 2 * done
    return (done // window + 1) * window


@contextlib.contextmanager
def _threads_for(n_nodes: int):
    """Use at most one thread per NODES_PER_THREAD nodes while stepping (tiny lattices run serially)."""
    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(before, n_nodes // NODES_PER_THREAD)))
    try:
        yield
    finally:
        numba.set_num_threads(before)


def solve(
    lat: Lattice,
    settings: Settings,
    *,
    sample_voxels: int,
    sample_area: int,
    label: str = "lbm",
    checkpoint: Path | None = None,
    progress: bool = True,
    links: Links | None = None,
    comm=None,
) -> Run:
    """Run the lattice to a steady state and evaluate κ̂ (see :func:`_solve`); ``comm``: the decomposition that
    built ``lat`` (:mod:`porepipe.lbm._mpi`; default one process).
    """
    with _threads_for(lat.n_nodes):
        return _solve(
            lat,
            settings,
            sample_voxels=sample_voxels,
            sample_area=sample_area,
            label=label,
            checkpoint=checkpoint,
            progress=progress,
            links=links,
            comm=comm or Serial(),
        )


def _density_change(d_new: np.ndarray, d_old: np.ndarray, mean_new: float, mean_old: float) -> float:
    """Largest relative change of ρ/⟨ρ⟩ between two checks (Eq. 6.1.30 without a uniform shift of the level).

    Interpolated walls do not conserve mass exactly (they leak ~1e-8 of it per step; :func:`_restore_mass` puts
    it back at every check); a uniform change of ρ is no change of the incompressible flow. With halfway walls
    ⟨ρ⟩ is constant and this is Eq. 6.1.30 itself. ``mean_new``, ``mean_old``: ⟨ρ⟩ over the sample (of every
    process).
    """
    if d_new.size == 0:
        return 0.0
    rho_new, rho_old = 1.0 + d_new, 1.0 + d_old
    return K._max_rel_change(rho_new / mean_new, rho_old / mean_old, 1e-300)


def _restore_mass(pops: np.ndarray, n_nodes: int, owned: slice, comm) -> None:
    """Put the mass the interpolated walls lost back, spread evenly over the rest populations (ρ° = 1 per node) of
    the owned nodes of every process.
    """
    deficit = -comm.sum(float(np.sum(pops.reshape(19, n_nodes)[:, owned], dtype=np.float64)))
    pops[owned] += deficit / comm.sum(owned.stop - owned.start)


def _stop(settings: Settings, dv: float, drho: float, dk: float, err: float) -> str | None:
    """Name of the rule that declares convergence now, or None."""
    if settings.stop is StopRule.kappa:
        return "kappa" if dk < settings.tolerance_kappa and err < settings.tolerance_kappa else None
    ok = (
        dv < settings.tolerance_velocity
        and drho < settings.tolerance_density
        and dk < settings.tolerance_kappa
    )
    return "density" if ok else None


def _velocity_change(u_new: np.ndarray, u_old: np.ndarray, comm) -> float:
    """Largest relative change of the flow velocity (Eq. 6.1.30, floored at VELOCITY_FLOOR × the peak)."""
    peak = comm.max(float(np.max(np.abs(u_new))) if u_new.size else 0.0)
    return comm.max(K._max_rel_change(u_new, u_old, max(VELOCITY_FLOOR * peak, 1e-300)))


def _mass(src: np.ndarray, n: int, owned: slice, comm) -> float:
    """Total mass Σ f over the owned nodes of every process (ρ° = 1 per node plus the zero-centred populations)."""
    pops = src.reshape(19, n)[:, owned]
    return comm.sum(float(pops.shape[1] + np.sum(pops, dtype=np.float64)))


def _resume(checkpoint, ckey, src, comm, state=None):
    """(step, fields, history, spent) of this process's matching checkpoint, or None; every process must agree."""
    resumed = _load_checkpoint(checkpoint, ckey, src, state)
    comm.agree(resumed[0] if resumed is not None else -1, checkpoint)
    return resumed


def _solve(
    lat: Lattice,
    settings: Settings,
    *,
    sample_voxels: int,
    sample_area: int,
    label: str,
    checkpoint: Path | None,
    progress: bool,
    links: Links | None,
    comm,
) -> Run:
    """Run the lattice to a steady state and evaluate κ̂.

    Checks every ``window_steps`` steps. ``stop: kappa``: converged when the relative change of κ̂ over the last
    window and the estimated remaining relative error (:func:`kappa_error`, from the last three checks) are both
    below ``tolerance_kappa``. ``stop: density``: when, over one window, the largest relative change of the flow
    velocity and of the density over the sample's pore nodes (thesis Eq. 6.1.30) and the relative change of κ̂
    are all below their tolerances. Raises :class:`StabilityError` on NaN/Inf or Mach > ``mach_max``. Every
    check reduces over the processes of ``comm``, so all of them take the same decisions.
    """
    check_tau(settings)
    dtype = np.dtype(settings.precision.value)
    n = lat.n_nodes
    src = np.zeros(19 * n, dtype=dtype)  # zero-centred: equilibrium at rest, ρ = 1
    dst = np.zeros_like(src)
    fields = np.zeros((4, n))
    step = comm.wrap(make_stepper(settings, lat, links))
    owned = comm.owned(lat)
    leaky = comm.max(float(links.size if links is not None else 0)) > 0  # interpolated walls somewhere
    sampler = comm.sampler(lat)
    nu = viscosity(settings.tau)
    key_name = estimate_key(sampler.everywhere, settings.gradient, settings.velocity)
    ckey = _checkpoint_key(lat, settings, links, comm.key())
    names = ("step", "kappa", "delta_v", "delta_rho", "delta_kappa", "kappa_error", "mach")
    history: dict[str, list] = {k: [] for k in names}
    done = 0
    state = links.state if links is not None else None
    carried = (0.0, 0.0)
    resumed = _resume(checkpoint, ckey, src, comm, state)
    if resumed is not None:
        done, fields, old_history, carried = resumed
        history.update({k: list(v) for k, v in old_history.items() if k in history})
    start = done
    spent = SpentClock(carried).spent

    kappa_stop = settings.stop is StopRule.kappa
    tolerance = settings.tolerance_kappa if kappa_stop else settings.tolerance_density
    reporter = Progress(label, settings.max_steps, target=tolerance) if progress and comm.root else None
    window = settings.window_steps
    prev_fields = fields.copy() if done else None
    prev_rho = sample_mean_rho(comm.sum(sampler.tables(fields[:, owned]))) if done else 1.0
    prev_kappa = history["kappa"][-1] if history["kappa"] else float("nan")
    est = {}
    converged = False
    stopped_by = "step_limit"
    err = float("inf")
    settled = [k for k, d in zip(history["kappa"], history["delta_kappa"]) if math.isfinite(d)]
    step_wall = 0.0
    last_ckpt = time.perf_counter()
    while done < settings.max_steps:
        n_run = min(_next_check(done, window), settings.max_steps) - done
        t0 = time.perf_counter()
        step(src, dst, fields, True, n_run)
        step_wall += time.perf_counter() - t0
        if n_run % 2 == 1:
            src, dst = dst, src
        done += n_run
        own = fields[:, owned]
        mach = _guard(own, done, settings, comm)
        if leaky:
            _restore_mass(src, n, owned, comm)
        tables = comm.sum(sampler.tables(own))
        est = estimates(
            sampler,
            tables,
            nu=nu,
            body_force=settings.body_force,
            sample_voxels=sample_voxels,
            sample_area=sample_area,
            trim_layers=settings.trim_layers,
        )
        kappa = est[key_name]
        rho = sample_mean_rho(tables)
        dv, drho, dk = (float("inf"),) * 3
        if prev_fields is not None and n_run == window:  # Eq. 6.1.30 compares over a full window dt
            sel = sampler.sample_nodes
            old = prev_fields[:, owned]
            dv = _velocity_change(own[1, sel], old[1, sel], comm)
            drho = comm.max(_density_change(own[0, sel], old[0, sel], rho, prev_rho))
            dk = abs(kappa - prev_kappa) / abs(kappa) if kappa != 0 and math.isfinite(kappa) else float("inf")
            settled = (settled or [prev_kappa])[-2:] + [kappa]
            err = kappa_error(settled, NOISE_FRACTION * settings.tolerance_kappa)
        for name, value in zip(history, (done, kappa, dv, drho, dk, err, mach)):
            history[name].append(value)
        if reporter is not None:
            reporter.update(
                done,
                f"κ̂={kappa:.6g} δκ={dk:.2e} err={err:.1e} δv={dv:.2e} δρ={drho:.2e}",
                residual=max(err, dk) if kappa_stop else drho,
            )
        prev_fields, prev_kappa, prev_rho = fields.copy(), kappa, rho
        rule = _stop(settings, dv, drho, dk, err)
        if rule is not None:
            converged, stopped_by = True, rule
            break
        if checkpoint is not None and comm.max(time.perf_counter() - last_ckpt) > settings.checkpoint_every_s:
            _save_checkpoint(checkpoint, ckey, done, src, fields, history, state, spent())
            last_ckpt = time.perf_counter()
    if converged and not math.isfinite(est[key_name]):
        raise StabilityError(
            f"κ̂ estimate {key_name} is not finite at step {done} (no pressure drop across the "
            f"sample?): check the set-up or raise `body_force` (now {settings.body_force})"
        )
    if not converged and checkpoint is not None:
        _save_checkpoint(
            checkpoint, ckey, done, src, fields, history, state, spent()
        )  # a rerun with more steps resumes here
    n_owned = comm.sum(owned.stop - owned.start)
    step_wall = comm.max(step_wall)
    mlups = n_owned * (done - start) / max(step_wall, 1e-12) / 1e6
    if reporter is not None:
        reporter.close(
            f"{'converged (' + stopped_by + ' rule)' if converged else 'NOT converged (step limit)'} after {done} "
            f"steps, κ̂ = {est.get(key_name, float('nan')):.6g} voxel², {mlups:.1f} MLUPS"
        )
    return Run(
        converged,
        done,
        {k: np.asarray(v, dtype=np.float64) for k, v in history.items()},
        fields[:, owned],
        est,
        key_name,
        mlups,
        step_wall,
        _mass(src, n, owned, comm),
        stopped_by,
        err,
        start,
        carried,
    )
