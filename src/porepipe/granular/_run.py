"""``run``: a ``granular:`` scene section in, ``granular.h5`` out (frames, contacts, time series, cost).

Result layout (``xarray.open_dataset(path, engine="h5netcdf")`` reads the root; ``group="contacts"`` and
``group="series"`` the others):

- root: centroid ``position_m`` (frame, particle, xy) in m and ``angle_rad`` (frame, particle), their rates
  ``velocity_m_s`` (m/s) and ``angular_velocity_rad_s`` (rad/s), ``active``, ``time_s`` (frame); particle outlines
  ``vertices_m`` (particle, corner, xy; NaN-padded), ``mass_kg`` (density kg/m² × area), ``inertia_kg_m2``; walls
  ``wall_vertices_m`` (wall, corner, xy). Every variable carries ``units`` in one spelling pint parses;
- ``contacts``: one row per contact and frame: ``frame``, ``i``, ``j`` (j >= n_particles: wall j - n), force on i
  ``fx_N``, ``fy_N`` (-F on j), application point ``sx_m``, ``sy_m``, ``fn_N``, ``ft_N``, ``area_m2``,
  ``length_m``;
- ``series``: ``time_s``, ``kinetic_energy_J``, ``contacts``, ``coordination``, ``max_overlap`` (overlap area /
  r_eq² of the smaller particle, dimensionless).
"""

from __future__ import annotations

import pickle
import time
import zipfile
from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.atomic import atomic_path
from porepipe._shared.cost import SpentClock, carried_by
from porepipe._shared.errors import PorepipeError
from porepipe._shared.progress import Progress, notice
from porepipe._shared.store import ResultWriter, result_hash
from porepipe.granular._api import Frame, Simulation
from porepipe.granular._settings import Settings

STAGE = "granular"
#: most time steps a run can count (Simulation takes 2^62 as "never" for a particle that is not inserted)
_MAX_STEPS = 2**62
#: cost of a run on one core, to warn before one that would take days: ~3 us per step whatever the size (one grain
#: stepped in chunks of 100: 2.7 us on a quiet machine, 5-7.5 us on a loaded one) plus 0.4 us per particle-step
#: (2.5e6 polygon-steps per CPU-s on one thread: benchmarks/granular.py --smoke, benchmarks/granular_settled.py)
_STEP_S, _PARTICLE_STEP_S = 3e-6, 4e-7
#: a planned run estimated above this many seconds gets a warning line at the start (the shipped scenes: <= 1.1 h)
_LONG_RUN_S = 86400.0
_CONTACT_KEYS = ("i", "j", "fx_N", "fy_N", "sx_m", "sy_m", "fn_N", "ft_N", "area_m2", "length_m")
#: units of the contact and series columns (pint spellings); the rest (indices, counts, ratios) are "1"
_UNITS = {
    **dict.fromkeys(("fx_N", "fy_N", "fn_N", "ft_N"), "N"),
    **dict.fromkeys(("sx_m", "sy_m", "length_m"), "m"),
    "area_m2": "m^2",
    "time_s": "s",
    "kinetic_energy_J": "J",
}


def _save_checkpoint(
    path: Path, key: str, sim: Simulation, frames: list, series: list, clock: SpentClock
) -> None:
    """Everything a bit-identical resume needs, and what the run has spent so far (``clock``)."""
    state = sim.state()
    clock.record(state)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:  # fsync, then rename
        np.savez(
            fh,
            key=np.array(key),
            frames=np.array(_pack_frames(frames), dtype=object),
            series=np.asarray(series, dtype=np.float64).reshape(-1, 5),
            **state,
        )


def _pack_frames(frames: list) -> list:
    return [(f.time_s, f.position, f.velocity, f.active, f.contacts) for f in frames]


def _load_checkpoint(path: Path, key: str):
    """(state, frames, series, carried) of a checkpoint with the same key, else None (a stale one is discarded);
    ``carried``: the (wall s, CPU s) it records as spent (NaN where it predates the record).
    """
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=True) as z:
            if str(z["key"]) != key:
                print(
                    f"porepipe granular: checkpoint {path} is for another scene (key mismatch); starting afresh"
                )
                path.unlink()
                return None
            state = {k: z[k] for k in (*Simulation.STATE, "scalars", "max_overlap_seen")}
            frames = [Frame(*f) for f in z["frames"]]
            series = [tuple(r) for r in z["series"]]
            carried = carried_by(z)
    except (
        OSError,
        ValueError,
        KeyError,
        EOFError,
        TypeError,
        pickle.UnpicklingError,
        zipfile.BadZipFile,
    ) as err:
        raise PorepipeError(
            f"granular checkpoint {path} is damaged ({type(err).__name__}: {err}); delete it to start afresh"
        ) from None
    return state, frames, series, carried


def _sample(sim: Simulation) -> tuple:
    c = sim.contacts()
    n_act = max(int(sim.active[: sim.n_mob].sum()), 1)
    mobile_pairs = int(np.sum(c["j"] < sim.n_mob))
    return (sim.time_s, sim.kinetic_energy(), len(c["i"]), 2.0 * mobile_pairs / n_act, sim.max_overlap_seen)


def run(
    settings: Settings,
    out,
    *,
    seed: int = 0,
    scene: str = "",
    threads: int | None = None,
    checkpoint=None,
    resume: bool = False,
    progress: bool = True,
) -> Path:
    """Run the granular DEM of ``settings`` and write the result file ``out``.

    Parameters
    ----------
    settings : Settings
        The scene's ``granular:`` section.
    out : path-like
        Result HDF5 file (written atomically).
    seed : int
        Scene seed.
    scene : str
        Scene name (recorded in the file).
    threads : int, optional
        Thread count actually used (recorded).
    checkpoint : path-like, optional
        Checkpoint file, written every ``checkpoint_every_steps`` and deleted on success.
    resume : bool
        Continue from ``checkpoint`` if it exists and belongs to the same scene part.
    progress : bool
        Print progress lines on stderr.

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    out = Path(out)
    key = result_hash(STAGE, settings=settings, seed=int(seed))
    with ResultWriter(out, stage=STAGE, scene=scene, scene_hash=key, threads=threads) as w:
        sim, frames, series, particle_steps, rate, w.carried = _simulate(
            settings, seed, checkpoint, resume, progress, key
        )
        _write(w, sim, frames, series)
        w.attrs.update(
            {
                "steps": sim.step,
                "dt_s": sim.dt,
                "dt_rule_s": sim.dt_rule,
                "dt_damping_s": sim.dt_damping,
                "rebuilds": sim.rebuilds,
                "integrator": settings.integrator.value,
                "neighbour_search": settings.neighbour_search.value,
                "effects": ",".join(k for k, v in sim.effects.items() if v) or "none",
                "n_particles": sim.n_mob,
                "n_walls": sim.n_walls,
                "particle_steps": particle_steps,
                "particle_steps_per_s": rate,
                "max_overlap": sim.max_overlap_seen,
            }
        )
    if checkpoint:
        Path(checkpoint).unlink(missing_ok=True)
    return out


def _simulate(settings, seed, checkpoint, resume, progress, key):
    """Step the simulation to the end, collecting frames and time series; checkpoint on the way."""
    sim = Simulation(settings, seed)
    steps = settings.duration_s / sim.dt
    if not steps < _MAX_STEPS:
        raise PorepipeError(
            f"granular.duration_s = {settings.duration_s:g} s is {steps:.3g} time steps of dt = {sim.dt:.3g} s, "
            f"more than the step counter holds (2^62); shorten duration_s or raise dt_s (the default dt follows "
            "the lightest grain, Eq. 2.9: are the sizes in metres?)"
        )
    total = round(steps)
    if total == 0 and settings.duration_s > 0:
        raise PorepipeError(
            f"granular.duration_s = {settings.duration_s:g} s is shorter than half a time step (dt = {sim.dt:.3g} s), "
            "so the run would make no step; give duration_s >= dt, or 0 to write the initial state alone"
        )
    if total == 0:
        notice("granular.duration_s = 0: no time step; the result holds the initial state alone")
    if (line := _long_run_notice(settings, sim, total)) is not None:
        notice(line)
    if (line := sim.damping_bound_notice()) is not None:
        notice(line)
    frame_steps = np.unique(np.round(np.linspace(0, total, settings.output.frames + 1)).astype(np.int64))
    frames: list[Frame] = []
    series: list[tuple] = []
    ck = Path(checkpoint) if checkpoint else None
    carried = (0.0, 0.0)
    if ck is not None and resume:
        loaded = _load_checkpoint(ck, key)
        if loaded is not None:
            state, frames, series, carried = loaded
            sim.restore(state)
    if sim.step == 0 and (line := _start_overlap_notice(sim)) is not None:
        notice(line)
    clock = SpentClock(carried)
    prog = Progress("granular", total) if progress else None
    t0 = time.perf_counter()
    particle_steps = 0  # active particles x steps: slots not yet inserted, or gone, cost nothing
    every = settings.output.series_every
    while True:
        if sim.step in frame_steps and (not frames or frames[-1].time_s < sim.time_s):
            frames.append(sim.frame())
        if sim.step % every == 0 and (not series or series[-1][0] < sim.time_s):
            series.append(_sample(sim))
        if sim.step >= total:
            break
        nxt = min(total, (sim.step // every + 1) * every, int(frame_steps[frame_steps > sim.step][0]))
        nxt = min(nxt, (sim.step // settings.checkpoint_every_steps + 1) * settings.checkpoint_every_steps)
        particle_steps += int(np.count_nonzero(sim.active[: sim.n_mob] == 1)) * (nxt - sim.step)
        sim.advance(nxt - sim.step)
        if ck is not None and sim.step % settings.checkpoint_every_steps == 0 and sim.step < total:
            _save_checkpoint(ck, key, sim, frames, series, clock)
        if prog is not None:
            prog.update(sim.step, f"t = {sim.time_s:.4g} s, {len(sim.contacts()['i'])} contacts")
    wall = time.perf_counter() - t0
    rate = (
        particle_steps / wall if wall > 0 else 0.0
    )  # active count taken at the start of each chunk of steps
    return sim, frames, series, particle_steps, rate, carried


def _long_run_notice(settings: Settings, sim: Simulation, total: int) -> str | None:
    """A line warning that ``total`` steps would take longer than a day on one core (None where they would not)."""
    estimate_s = total * (_STEP_S + _PARTICLE_STEP_S * sim.n_mob)
    if estimate_s <= _LONG_RUN_S:
        return None
    dt_from = (
        "granular.dt_s"
        if settings.dt_s is not None
        else "the lightest grain (Eq. 2.9: are the sizes in metres?)"
    )
    return (
        f"granular: {total:.3g} time steps of dt = {sim.dt:.3g} s for duration_s = {settings.duration_s:g} s with "
        f"{sim.n_mob} particle(s) would take about {estimate_s / 3600:.3g} h on one core (~3 us a step + 0.4 us a "
        f"particle-step); dt comes from {dt_from}; if this is not meant, stop the run and shorten "
        "granular.duration_s or set a larger granular.dt_s"
    )


def _start_overlap_notice(sim: Simulation) -> str | None:
    """A line saying how many pairs overlap as placed, and by how much (None where none does)."""
    o = sim.start_overlaps()
    if not o["grains"] + o["walls"]:
        return None
    i, j = o["pair"]
    other = f"particle {j}" if j < sim.n_mob else f"wall {sim.wall_names[j - sim.n_mob]!r}"
    return (
        f"granular: {o['grains']} grain-grain and {o['walls']} grain-wall pair(s) overlap as placed, the largest by "
        f"{o['largest']:.2g} r_eq² (particle {i} and {other}; granular.guard.max_overlap "
        f"{sim.settings.guard.max_overlap:g}): they push apart in the first steps, which adds kinetic energy; to "
        "start without overlaps, widen the block's grid_m, lower its jitter_fraction or move the particles"
    )


def _write(w: ResultWriter, sim: Simulation, frames: list[Frame], series: list[tuple]) -> None:
    n = sim.n_mob
    kmax = sim.body.shape[1]
    verts = np.full((n, kmax, 2), np.nan)
    for i in range(n):
        verts[i, : sim.nc[i]] = sim.body[i, : sim.nc[i]]
    wverts = np.full((sim.n_walls, kmax, 2), np.nan)
    for k in range(sim.n_walls):
        b = n + k
        wverts[k, : sim.nc[b]] = sim.body[b, : sim.nc[b]] + sim.G[0, b, :2]
    position = np.stack([f.position for f in frames])  # (frame, particle, x y phi)
    velocity = np.stack([f.velocity for f in frames])
    root = xr.Dataset(
        {
            "position_m": (("frame", "particle", "xy"), position[..., :2], {"units": "m"}),
            "angle_rad": (("frame", "particle"), position[..., 2], {"units": "rad"}),
            "velocity_m_s": (("frame", "particle", "xy"), velocity[..., :2], {"units": "m/s"}),
            "angular_velocity_rad_s": (("frame", "particle"), velocity[..., 2], {"units": "rad/s"}),
            "active": (("frame", "particle"), np.stack([f.active for f in frames])),
            "time_s": (("frame",), np.array([f.time_s for f in frames])),
            "vertices_m": (("particle", "corner", "xy"), verts, {"units": "m"}),
            "n_corners": (("particle",), sim.nc[:n].copy()),
            "mass_kg": (("particle",), sim.mass, {"units": "kg"}),
            "inertia_kg_m2": (("particle",), sim.inertia, {"units": "kg*m^2"}),
            "wall_vertices_m": (("wall", "corner", "xy"), wverts, {"units": "m"}),
        },
        coords={"xy": ["x", "y"], "wall_name": (("wall",), sim.wall_names)},
        attrs={
            "angles": "counter-clockwise (gc2d: clockwise)",
            "unit_system": "SI, 2-D: Young's modulus N/m, density kg/m^2",
        },
    )
    w.write_table(root)
    rows = {k: np.concatenate([f.contacts[k] for f in frames]) for k in _CONTACT_KEYS}
    rows["frame"] = np.concatenate([np.full(len(f.contacts["i"]), k, np.int64) for k, f in enumerate(frames)])
    w.write_table(
        xr.Dataset({k: (("contact",), v, {"units": _UNITS.get(k, "1")}) for k, v in rows.items()}),
        group="contacts",
    )
    s = np.asarray(series, dtype=np.float64).reshape(-1, 5)
    names = ("time_s", "kinetic_energy_J", "contacts", "coordination", "max_overlap")
    table = {k: (("sample",), s[:, c], {"units": _UNITS.get(k, "1")}) for c, k in enumerate(names)}
    w.write_table(xr.Dataset(table), group="series")


def read_granular(path) -> dict[str, xr.Dataset]:
    """The three tables of a ``granular.h5``: ``frames`` (root), ``contacts``, ``series``."""
    from porepipe._shared.store import read_table

    path = Path(path)
    if not path.is_file():
        raise PorepipeError(f"granular result {path} does not exist")
    return {
        "frames": read_table(path),
        "contacts": read_table(path, "contacts"),
        "series": read_table(path, "series"),
    }
