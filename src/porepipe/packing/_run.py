"""File in, compute, file out: the scene's DEM packing protocol -> ``packing.h5`` (and optionally ``xyzr``)."""

from __future__ import annotations

from pathlib import Path

from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.run_control import without_run_control
from porepipe._shared.store import ResultWriter, result_hash
from porepipe.packing._api import pack_spheres
from porepipe.packing._io import write_packing, write_xyzr_file
from porepipe.packing._types import Packing
from porepipe.scene import load_scene, scene_part


def run(
    scene_path,
    out,
    *,
    xyzr=None,
    threads: int | None = None,
    checkpoint=None,
    resume: bool = False,
    progress: bool = True,
) -> Packing:
    """Pack the spheres of the scene at ``scene_path`` and write the result file ``out``.

    Parameters
    ----------
    scene_path : path-like
        Scene YAML with a ``packing:`` section (files it names are relative to it).
    out : path-like
        ``packing.h5``.
    xyzr : path-like, optional
        Also write the spheres as ``x y z r`` lines (µm).
    threads : int, optional
        Numba threads (default: all); the packing does not depend on it.
    checkpoint : path-like, optional
        Checkpoint file, written every ``packing.checkpoint_every_s`` wall seconds (default 300) and every
        ``packing.checkpoint_every`` steps (default 0: off), whichever comes first; deleted on success.
    resume : bool
        Continue from ``checkpoint`` if it exists (bit-identical to an uninterrupted run).
    progress : bool
        Print progress lines.

    Returns
    -------
    Packing
    """
    scene = load_scene(scene_path)
    settings = scene.packing
    if settings is None or not settings.types or not settings.stages:
        raise PorepipeError(f"{scene_path}: the scene has no `packing:` section with types and stages to run")
    threads = set_threads(threads)
    part = scene_part(scene, "seed", "domain")  # and the packing less its run control, as the checkpoint key
    part["packing"] = without_run_control(settings)
    digest = result_hash("pack", scene_part=part)
    with ResultWriter(out, stage="pack", scene=scene.name, scene_hash=digest, threads=threads) as w:
        packing = pack_spheres(
            settings,
            scene.domain.size_um,
            scene.domain.periodic,
            scene.seed,
            base_dir=Path(scene_path).parent,
            checkpoint_path=checkpoint,
            resume=resume,
            progress=progress,
        )
        w.carried = packing.carried  # a resumed run's cost includes the processes before it
        write_packing(w, packing)
    if xyzr:
        write_xyzr_file(xyzr, packing)
    return packing
