"""File in, compute, file out: ``perm_a{a}_{axis}.h5`` from a binary volume, one file per flow axis."""

from __future__ import annotations

import re
from pathlib import Path

from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import read_attrs, read_binary_volume, result_hash
from porepipe.lbm._api import PermeabilityResult, permeability
from porepipe.lbm._io import write_result
from porepipe.lbm._mpi import decomposition, other_checkpoints
from porepipe.lbm._settings import Axis, Settings, Walls
from porepipe.lbm._walls import geometry_from_files


def output_path(binary, axis: Axis, out=None, out_dir=None) -> Path:
    """``out`` if given, else ``perm_a{a}_{axis}.h5`` in ``out_dir`` (default: beside ``binary``)."""
    if out:
        return Path(out)
    binary = Path(binary)
    match = re.search(r"_a([0-9.]+?)\.h5$", binary.name)
    tag = match.group(1) if match else binary.stem
    return Path(out_dir or binary.parent) / f"perm_a{tag}_{axis.value}.h5"


def default_checkpoint(out) -> Path:
    """The checkpoint beside a result file when none is named: ``.<name>.checkpoint.h5`` (hidden)."""
    out = Path(out)
    return out.with_name(f".{out.name}.checkpoint.h5")


def _checkpoint_of(path: Path, checkpoint, comm, resume: bool) -> Path:
    """The checkpoint file of this process; checkpoints of another decomposition are refused (or, without resume,
    deleted) so that no run resumes from a state it cannot continue.
    """
    base = Path(checkpoint) if checkpoint else default_checkpoint(path)
    others = other_checkpoints(base, comm.size)
    if others and resume:
        raise PorepipeError(
            f"checkpoint(s) of a run with another number of processes: {', '.join(p.name for p in others)} "
            f"(this run: {comm.size}); rerun with that number, or with --no-resume to discard them"
        )
    ckpt = comm.checkpoint_path(base)
    if not resume and comm.root:
        for stale in others:
            stale.unlink(missing_ok=True)
    if not resume:
        ckpt.unlink(missing_ok=True)
    return ckpt


def run(
    binary,
    settings: Settings,
    axes=None,
    *,
    out=None,
    out_dir=None,
    threads: int | None = None,
    checkpoint=None,
    resume: bool = True,
    packing=None,
    grey=None,
    grains=None,
    mpi: bool = False,
) -> list[tuple[Path, PermeabilityResult]]:
    """Read ``binary`` (volume ``pore``), run every requested axis, write one result file per axis.

    Parameters
    ----------
    binary : path-like
        Binary volume (1 = pore) with ``voxel_um``, ``origin_um``, ``periodic``.
    settings : Settings
        The ``permeability`` settings (scene section with command-line options laid over it).
    axes : sequence of Axis or str, optional
        Flow axes (default ``settings.axes``).
    out : path-like, optional
        The result file (one axis only).
    out_dir : path-like, optional
        Directory of the ``perm_a{a}_{axis}.h5`` files (default: beside ``binary``).
    threads : int, optional
        Numba threads (default: all).
    checkpoint : path-like, optional
        Checkpoint file (one axis only); default ``.<result name>.checkpoint.h5`` beside each result. It is written
        every ``checkpoint_every_s`` and at the step limit, keyed by the geometry and physics, deleted on success.
    resume : bool
        Continue from a matching checkpoint; False discards an existing one and starts afresh.
    packing : path-like, optional
        ``packing.h5`` whose spheres the volume shows: exact sub-voxel wall distances for interpolated walls.
    grey : path-like, optional
        ``grey_a{a}.h5`` of the volume: sub-voxel wall distances estimated from the grey values.
    grains : path-like, optional
        ``grains.h5`` whose decorated grains the volume shows: exact sub-voxel wall distances (ray–polyhedron).
    mpi : bool
        Run as one rank of ``mpirun -n P`` (:mod:`porepipe.lbm._mpi`): every rank computes its slab, rank 0 writes
        the result; each rank keeps its own checkpoint ``<checkpoint stem>.rank<r>of<P>.h5``.

    Returns
    -------
    list of (pathlib.Path, PermeabilityResult)
        Each axis's result file and result.
    """
    axes = tuple(Axis(a) for a in axes) if axes else settings.axes
    if out and len(axes) != 1:
        raise PorepipeError(f"--out names one file but {len(axes)} axes were asked for; use --out-dir")
    if checkpoint and len(axes) != 1:
        raise PorepipeError(
            f"--checkpoint names one file but {len(axes)} axes were asked for; give one --axis"
        )
    comm = decomposition(mpi)
    threads = set_threads(threads)
    pore, meta = read_binary_volume(binary)
    scene = read_attrs(binary).get("scene", "")
    interpolated = (
        settings.walls is not Walls.halfway
    )  # halfway walls need no sub-voxel geometry: read nothing more
    geometry = (
        None
        if not interpolated
        else geometry_from_files(
            pore.shape,
            meta.voxel_um,
            meta.origin_um,
            packing=packing,
            grey=grey,
            threshold=meta.attrs.get("threshold"),
            periodic=meta.periodic,
            grains=grains,
            pore=pore,
        )
    )
    written = []
    for axis in axes:
        path = output_path(binary, axis, out, out_dir)
        ckpt = _checkpoint_of(path, checkpoint, comm, resume)
        result = permeability(
            pore.astype(bool), axis, settings, meta.voxel_um, checkpoint=ckpt, geometry=geometry, comm=comm
        )
        sources = [binary] + ([p for p in (packing, grey, grains) if p] if interpolated else [])
        digest = result_hash("permeability", settings=settings, inputs=sources, axis=axis.value)
        if comm.root:
            write_result(
                path, result, scene=scene, scene_hash=digest, threads=threads, origin_um=meta.origin_um
            )
        written.append((path, result))
    return written
