"""Public API: ``permeability(pore, axis, settings, voxel_um)`` -> :class:`PermeabilityResult`."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe.lbm._domain import Prepared, chamber_setup, periodic_setup
from porepipe.lbm._lattice import CS2
from porepipe.lbm._mpi import Serial
from porepipe.lbm._settings import Axis, Lateral, Settings, Setup, Walls
from porepipe.lbm._solver import Run, StabilityError, check_tau, solve
from porepipe.lbm._throats import throat_warning
from porepipe.lbm._velocity import flow_velocity_stats, time_step_s
from porepipe.lbm._walls import GrainWalls, GreyWalls, MirroredWalls, ShiftedWalls, SphereWalls, build_links

_VELOCITY_NAMES = {
    "mean_velocity_um_s": "mean flow velocity over the sample's pore voxels (c_s of the settings)",
    "velocity_variance_um2_s2": "variance of the flow velocity over the sample's pore voxels",
}

#: 1 darcy in m² (9.869233e-13; thesis §4.4: 1 D = 0.9869 µm²).
DARCY_M2 = 9.869233e-13


def kappa_units(kappa_lu: float, voxel_um: float) -> dict[str, float]:
    """κ̂ (lattice units, voxel² ) in m², mD and D for a voxel of ``voxel_um`` micrometres."""
    m2 = kappa_lu * (voxel_um * 1e-6) ** 2
    return {"kappa_lu": kappa_lu, "kappa_m2": m2, "kappa_mD": m2 / DARCY_M2 * 1e3, "kappa_D": m2 / DARCY_M2}


@dataclasses.dataclass
class PermeabilityResult:
    """κ along one axis with everything needed to judge it.

    ``kappa_lu`` is in voxel² (lattice units); ``kappa_m2``/``kappa_mD``/``kappa_D`` use ``voxel_um``.
    ``velocity`` (3, X, Y, Z) and ``pressure`` (X, Y, Z) are lattice-unit fields over the sample (if requested).
    """

    axis: Axis
    voxel_um: float
    kappa_lu: float
    kappa_m2: float
    kappa_mD: float
    kappa_D: float
    method: str
    estimates: dict[str, float]
    converged: bool
    steps: int
    reason: str
    history: dict[str, np.ndarray]
    mlups: float
    n_nodes: int
    n_pruned: int
    n_spanning: int
    porosity: float
    settings: Settings
    velocity: np.ndarray | None = None
    pressure: np.ndarray | None = None
    total_mass: float = float("nan")
    stopped_by: str = ""
    kappa_error: float = float("nan")
    walls: str = "halfway"
    n_links: int = 0
    throat_voxels: float = float("nan")
    warning: str = ""
    ranks: int = 1  # MPI ranks of the run (1: one process)
    mean_velocity_um_s: float = float("nan")  # flow component over the sample's pore voxels (Table 8.5)
    velocity_variance_um2_s2: float = float("nan")
    resumed_step: int = 0  # the checkpoint's step the run resumed from (0: started afresh)
    carried: tuple[float, float] = (
        0.0,
        0.0,
    )  # (wall s, CPU s) of the earlier processes up to that checkpoint

    def to_dataset(self) -> xr.Dataset:
        """Tables of the result (κ in all units, estimates, convergence history) as an xarray Dataset."""
        est_names = sorted(self.estimates)
        data = {
            "kappa_lu": ((), self.kappa_lu, {"units": "voxel^2", "long_name": "permeability, lattice units"}),
            "kappa_m2": ((), self.kappa_m2, {"units": "m^2"}),
            "kappa_mD": ((), self.kappa_mD, {"units": "mD"}),
            "kappa_D": ((), self.kappa_D, {"units": "D"}),
            "estimate_lu": (
                "estimate",
                np.array([self.estimates[k] for k in est_names], dtype=np.float64),
                {"units": "voxel^2", "long_name": "κ̂ by pressure-gradient/velocity method"},
            ),
        }
        for name, unit in (("mean_velocity_um_s", "µm/s"), ("velocity_variance_um2_s2", "µm^2/s^2")):
            data[name] = ((), getattr(self, name), {"units": unit, "long_name": _VELOCITY_NAMES[name]})
        for name, values in self.history.items():  # κ̂ in voxel² like kappa_lu; steps, changes, Mach: "1"
            units = "voxel^2" if name == "kappa" else "1"
            data[f"history_{name}"] = ("check", np.asarray(values, dtype=np.float64), {"units": units})
        attrs = {k: (v.value if hasattr(v, "value") else v) for k, v in self.attrs().items()}
        return xr.Dataset(
            {k: xr.Variable(*v) for k, v in data.items()},
            coords={"estimate": np.array(est_names, dtype=str)},
            attrs=attrs,
        )

    def attrs(self) -> dict:
        s = self.settings
        return {
            "axis": self.axis.value,
            "voxel_um": self.voxel_um,
            "method": self.method,
            "converged": int(self.converged),
            "steps": self.steps,
            "reason": self.reason,
            "mlups": self.mlups,
            "n_nodes": self.n_nodes,
            "n_pruned": self.n_pruned,
            "n_spanning_clusters": self.n_spanning,
            "porosity": self.porosity,
            "collision": s.collision.value,
            "tau": s.tau,
            "tau_bulk": s.tau_bulk,
            "magic": s.magic,
            "mrt_magic": s.mrt_magic if s.mrt_magic is not None else float("nan"),
            "precision": s.precision.value,
            "setup": s.setup.value,
            "mirror": int(s.mirror),
            "lateral": s.lateral.value,
            "body_force_lu": s.body_force,
            "velocity_kind": "superficial (Darcy)",
            "stop": s.stop.value,
            "stopped_by": self.stopped_by,
            "kappa_error": self.kappa_error,
            "walls": self.walls,
            "n_interpolated_links": self.n_links,
            "resumed_step": self.resumed_step,
            "throat_voxels": self.throat_voxels,
            "warning": self.warning,
            "mpi_ranks": self.ranks,
            "sound_speed_m_s": s.sound_speed_m_s,
            "time_step_s": time_step_s(self.voxel_um, s.sound_speed_m_s),
        }


def _check_pore(pore: np.ndarray) -> np.ndarray:
    pore = np.asarray(pore)
    if pore.ndim != 3 or min(pore.shape) < 1:
        raise PorepipeError(f"pore volume must be 3-D with at least 1 voxel per axis, got shape {pore.shape}")
    if pore.dtype != bool:
        values = np.unique(pore)
        if not np.all(np.isin(values, (0, 1))):
            raise PorepipeError(
                f"pore volume must be binary (1 = pore, 0 = matrix), found values {values[:5]}"
            )
        pore = pore.astype(bool)
    return pore


def prepare(
    pore_internal: np.ndarray, settings: Settings, keep_wall_links: bool = False, comm=None
) -> Prepared:
    """Build the set-up the settings ask for (flow along axis 0 of ``pore_internal``); ``comm``: the domain
    decomposition (:mod:`porepipe.lbm._mpi`) whose part of the lattice to build (default: all of it).
    """
    build = {"build": comm.build} if comm is not None else {}
    lateral_periodic = settings.lateral is Lateral.periodic
    if settings.setup is Setup.periodic:
        return periodic_setup(
            pore_internal,
            mirror=settings.mirror,
            lateral_periodic=lateral_periodic,
            prune=settings.prune,
            keep_wall_links=keep_wall_links,
            **build,
        )
    return chamber_setup(
        pore_internal,
        inlet_layers=settings.inlet_layers,
        outlet_layers=settings.outlet_layers,
        force_layers=settings.force_layers,
        lateral_periodic=lateral_periodic,
        prune=settings.prune,
        keep_wall_links=keep_wall_links,
        **build,
    )


def _fields_to_sample(prep: Prepared, run: Run, axis: int, sample_shape) -> tuple[np.ndarray, np.ndarray]:
    """Velocity (3, X, Y, Z) and pressure (X, Y, Z) over the sample, in the caller's axis order (lattice units)."""
    lat = prep.lattice
    s0 = lat.sample_layers[0]
    n_s = sample_shape[0]
    internal = np.zeros((4, *lat.shape))
    internal[:, lat.pore] = run.fields
    internal = internal[:, s0 : s0 + n_s]
    others = [i for i in range(3) if i != axis]
    velocity = np.zeros((3, *internal.shape[1:]))
    velocity[axis] = internal[1]
    velocity[others[0]] = internal[2]
    velocity[others[1]] = internal[3]
    pressure = np.where(lat.pore[s0 : s0 + n_s], CS2 * (1.0 + internal[0]), np.nan)
    velocity = np.moveaxis(velocity, 1, axis + 1)
    return velocity, np.moveaxis(pressure, 0, axis)


def _velocity_stats(
    prep: Prepared, run: Run, internal: np.ndarray, settings: Settings, comm
) -> tuple[float, float]:
    """Mean and variance of the flow velocity in µm/s over the sample's pore voxels (NaN for an MPI run: each rank
    holds only its slab).
    """
    if comm.distributed:
        return float("nan"), float("nan")
    lat = prep.lattice
    layer = np.nonzero(lat.pore)[0]
    s0 = lat.sample_layers[0]
    return flow_velocity_stats(
        run.fields[1], layer, (s0, s0 + internal.shape[0]), int(internal.sum()), settings.sound_speed_m_s
    )


def _interpolating(settings: Settings, geometry) -> bool:
    """Whether this run interpolates its walls."""
    return geometry is not None and settings.walls is not Walls.halfway


def _domain_geometry(geometry, settings: Settings, axis: int, sample_layers: int):
    """The sample's wall geometry in the internal axis order and the domain of the set-up (chambers before the
    sample, or the sample's mirror image after it).
    """
    order = [axis] + [k for k in range(3) if k != axis]
    inner = geometry.permuted(order)
    if settings.setup is Setup.chambers:
        return ShiftedWalls(inner, settings.inlet_layers, sample_layers)
    if settings.mirror:
        return MirroredWalls(inner, sample_layers)
    return inner


def _check_geometry(geometry, shape) -> None:
    if isinstance(geometry, GreyWalls) and geometry.solid.shape != tuple(shape):
        raise PorepipeError(
            f"grey volume shape {geometry.solid.shape} differs from the pore volume's {shape}"
        )
    if isinstance(geometry, SphereWalls) and tuple(geometry.box) != tuple(float(s) for s in shape):
        raise PorepipeError(
            f"sphere box {geometry.box} (voxels) differs from the pore volume's shape {shape}"
        )


def _check_distributable(settings: Settings) -> None:
    """Refuse what an MPI run cannot do yet: field output, multi-reflection walls."""
    if settings.walls is Walls.mr1:
        raise PorepipeError(
            "permeability.walls = mr1 is not available under MPI (its links read two nodes behind the wall, the "
            "slabs exchange one layer); use walls: cli with --mpi"
        )
    if settings.write_fields or settings.write_vti:
        raise PorepipeError(
            "permeability.write_fields / write_vti are not available under MPI (the fields stay spread over the "
            "ranks); run without --mpi to write them"
        )


def _not_converged(run, axis: Axis, settings: Settings) -> str:
    """The one line of a run that hit ``max_steps`` unconverged: the changes of its last full convergence window, or,
    before the first (steps ``window_steps`` to ``2 window_steps``; a check after a shorter chunk has no changes: inf),
    that no check could run yet.
    """
    head = f"LBM run along {axis.value} not converged after {run.steps} steps"
    tail = "raise `max_steps` (the run resumes from its checkpoint)"
    h = run.history
    checked = [i for i, d in enumerate(h["delta_rho"]) if math.isfinite(d)]  # inf after a shorter chunk
    if not checked:
        return (
            f"{head}: no convergence check has run yet (the first compares steps window_steps="
            f"{settings.window_steps} and {2 * settings.window_steps}); {tail} or lower `window_steps`"
        )
    i = checked[-1]
    return (
        f"{head} (at step {int(h['step'][i])}: δv={h['delta_v'][i]:.3g}, δρ={h['delta_rho'][i]:.3g}, "
        f"δκ={h['delta_kappa'][i]:.3g}): {tail} or loosen the tolerances"
    )


def permeability(
    pore: np.ndarray,
    axis: Axis | str = Axis.z,
    settings: Settings | None = None,
    voxel_um: float = 1.0,
    *,
    checkpoint: Path | None = None,
    progress: bool = True,
    label: str | None = None,
    geometry: SphereWalls | GrainWalls | GreyWalls | None = None,
    comm=None,
) -> PermeabilityResult:
    """Lattice-Boltzmann permeability of a binary sample along one axis.

    Parameters
    ----------
    pore : (X, Y, Z) bool or {0, 1} ndarray
        1 = pore, 0 = matrix.
    axis : Axis or {"x", "y", "z"}
        Flow direction; gives one diagonal element of the permeability tensor.
    settings : Settings, optional
        Operator, set-up, tolerances (defaults: TRT with Λ = 3/16, τ̂ = 0.857 as the thesis's, periodic body
        force, CLI walls where a geometry is given).
    voxel_um : float
        Voxel edge in µm, for κ in m², mD and D.
    checkpoint : path, optional
        Checkpoint file: written every ``checkpoint_every_s`` and when the step limit is hit; a run with the same
        geometry and physics resumes from it. Removed after a converged run.
    geometry : SphereWalls, GrainWalls or GreyWalls, optional
        Sub-voxel wall positions for ``walls`` = cli/bfl, in the caller's axis order and the sample's voxel grid
        (exact spheres, exact decorated grains, or grey values); every set-up (periodic, mirror, chamber) takes them.
        Without it the walls are halfway bounce-back (``result.walls``).
    comm : Serial or Slabs, optional
        Domain decomposition (:mod:`porepipe.lbm._mpi`): ``Slabs()`` under ``mpirun`` runs this process's slab
        (every rank calls with the same arguments and gets the same result; halfway walls, no fields). Default:
        one process.

    Returns
    -------
    PermeabilityResult

    Raises
    ------
    PorepipeError
        Bad input; :class:`StabilityError` (a PorepipeError) for τ too close to ½, Mach > ``mach_max`` or NaN; an
        unconverged run unless ``accept_unconverged``.

    Notes
    -----
    Thesis ch. 6: D3Q19, halfway or interpolated bounce-back (:mod:`porepipe.lbm._walls`), body force by Ladd-Verberg with h2 = 0 (Eq. 6.1.20), Darcy's law
    with the superficial velocity (Eq. 6.1.35), pressure gradient by method 3 (Eq. 6.1.39) in the chamber set-up.
    """
    settings = settings or Settings()
    axis = Axis(axis)
    if not np.isfinite(voxel_um) or voxel_um <= 0:
        raise PorepipeError(f"voxel_um must be a positive number, got {voxel_um}")
    pore = _check_pore(pore)
    check_tau(settings)
    interpolate = _interpolating(settings, geometry)
    comm = comm or Serial()
    if comm.distributed:
        _check_distributable(settings)
    if interpolate:
        _check_geometry(geometry, pore.shape)
    internal = np.ascontiguousarray(np.moveaxis(pore, axis.index, 0))
    prep = prepare(internal, settings, keep_wall_links=interpolate, comm=comm)
    throat, warning = throat_warning(internal, settings, interpolate)
    base = {
        "axis": axis,
        "voxel_um": float(voxel_um),
        "settings": settings,
        "porosity": float(pore.mean()),
        "n_pruned": prep.pruned_nodes,
        "n_spanning": prep.n_spanning,
        "throat_voxels": throat,
        "warning": warning,
        "ranks": comm.size,
    }
    if prep.lattice is None:
        return PermeabilityResult(
            **kappa_units(0.0, voxel_um),
            method="percolation",
            estimates={},
            converged=True,
            steps=0,
            reason=prep.reason,
            history={},
            mlups=0.0,
            n_nodes=0,
            **base,
        )
    if not comm.has_walls(prep.lattice):
        return PermeabilityResult(
            **kappa_units(float("inf"), voxel_um),
            method="no_walls",
            estimates={},
            converged=True,
            steps=0,
            history={},
            mlups=0.0,
            n_nodes=comm.n_nodes(prep.lattice),
            reason="no solid voxel and no wall anywhere: nothing resists the flow, "
            "κ is unbounded (use `lateral: walls` for a duct)",
            **base,
        )
    links = None
    if interpolate:
        lat = prep.lattice
        domain = _domain_geometry(geometry, settings, axis.index, internal.shape[0])
        links = build_links(
            lat.pore, lat.periodic, *lat.wall_links, comm.local_geometry(domain), settings.walls
        )
        lat.wall_links = None
    run = solve(
        prep.lattice,
        settings,
        sample_voxels=prep.sample_voxels,
        sample_area=prep.sample_area,
        label=label or f"lbm {axis.value}",
        checkpoint=checkpoint,
        progress=progress,
        links=links,
        comm=comm,
    )
    reason = (
        f"converged ({run.stopped_by} rule)"
        if run.converged
        else f"step limit max_steps={settings.max_steps} reached before convergence"
    )
    if not run.converged and not settings.accept_unconverged:
        raise StabilityError(_not_converged(run, axis, settings))
    if run.converged and checkpoint is not None:
        Path(checkpoint).unlink(missing_ok=True)
    velocity = pressure = None
    stats = _velocity_stats(prep, run, internal, settings, comm)
    if settings.write_fields or settings.write_vti:
        velocity, pressure = _fields_to_sample(prep, run, axis.index, internal.shape)
    return PermeabilityResult(
        **kappa_units(run.kappa, voxel_um),
        method=run.kappa_key,
        estimates=run.estimates,
        converged=run.converged,
        steps=run.steps,
        reason=reason,
        history=run.history,
        mlups=run.mlups,
        n_nodes=comm.n_nodes(prep.lattice),
        velocity=velocity,
        pressure=pressure,
        total_mass=run.total_mass,
        stopped_by=run.stopped_by,
        kappa_error=run.kappa_error,
        walls=settings.walls.value if interpolate else Walls.halfway.value,
        n_links=comm.owned_links(links, prep.lattice) if links is not None else 0,
        mean_velocity_um_s=stats[0],
        velocity_variance_um2_s2=stats[1],
        resumed_step=run.resumed_step,
        carried=run.carried,
        **base,
    )
