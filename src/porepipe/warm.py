"""Compile a scene's kernels ahead of its jobs: ``porepipe warm STAGE --scene S`` runs the stage's own commands on
a tiny twin of the scene, so that numba's on-disk cache holds the kernels before the real jobs start.

A cold workflow spends most of its time compiling, and its first job (pack) compiles on one core while the other
waits: the workflow's ``warm`` jobs (``workflow/rules/warm.smk``) fill that core. The twin keeps every setting of the
scene that selects a kernel (voxelisation method, segmentation, the permeability, Minkowski and LPT sections,
periodicity) and replaces what only sets the size: one resolution, a box of :data:`SMALL_EDGE` voxels per edge (and
one of :data:`LARGE_EDGE` where the scene's jobs run the parallel kernel variants, :func:`twin_edges`), eight inline
spheres instead of the packing. Its jobs run one thread each, as the jobs of a small scene do; a job on more threads,
on a volume past the memory budget (chunked) or with MPI still compiles what the twin did not.

Warming is a shortcut, never a condition: a twin that fails (a setting the tiny box cannot satisfy) prints one line and
leaves the compilation to the real jobs. A marker beside numba's cache (:func:`marker_path`, keyed by
:func:`twin_key`: the porepipe sources, the numba and Python versions, the stage and the twins it runs) records a
finished warm-up, so a later run of the same scene, or of any scene with the same twins (a model and its variant that
differ only in the packing, say), plans no warm jobs, and one run of such scenes plans one warm job per stage for
them all; deleting the cache deletes the marker, and a stale marker only costs the time a cold job takes. Where that
folder cannot be written, no marker is kept and each run warms again (from numba's cache: seconds).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import io
import math
import os
import sys
import tempfile
from pathlib import Path

import yaml

#: stages with a warm job, in the order the workflow needs their kernels
STAGES: tuple[str, ...] = ("voxelize", "permeability", "minkowski", "lpt")

#: the twin's edge in voxels for the kernels of small jobs: enough for LPT cell sizes up to 16 and a percolating cell
SMALL_EDGE = 24
#: the twin's edge for the parallel kernel variants, which a job runs even on one thread once an array holds more than
#: numba_config.SERIAL_MAX_ELEMENTS (2^17) elements: 52^3 voxels just exceed it
LARGE_EDGE = 52

#: the twin's spheres: centres (in box edges) of a slightly jittered 2 x 2 x 2 lattice; radius 0.26 box edges, so
#: neighbours overlap a little and the pore space (porosity ~0.45) percolates along every axis
_TWIN_CENTRES = [(x, y, z) for x in (0.24, 0.75) for y in (0.26, 0.74) for z in (0.25, 0.76)]
_TWIN_RADIUS = 0.26

#: scene sections of the twin taken unchanged from the scene (the others are dropped or rewritten)
_KEPT = ("seed", "domain", "voxelize", "segmentation", "permeability", "minkowski", "lpt", "resources")
#: stage -> the twin's sections its warm-up commands (_commands) do not read, left out of its twin key: an edit of the
#: LPT settings must not plan a voxelize warm-up, whose marker, new to the voxelize jobs, would rerun every one of them
_NOT_READ = {
    "voxelize": frozenset({"segmentation", "permeability", "minkowski", "lpt"}),
    "permeability": frozenset({"minkowski", "lpt"}),
    "minkowski": frozenset({"permeability", "lpt"}),
    "lpt": frozenset({"permeability", "minkowski"}),
}


def warmable(scene) -> bool:
    """Whether the scene's grey volumes come from spheres (not decorated grains or an acquired image): only then
    can a twin of inline spheres run its stages.
    """
    return (
        all(getattr(scene, key, None) is None for key in ("decoration", "acquire"))
        and scene.spheres is not None
    )


def twin(scene_path: str | os.PathLike, edge_voxels: int = SMALL_EDGE) -> dict:
    """The twin of the scene file ``scene_path`` with ``edge_voxels`` voxels per edge, as a scene mapping (see the
    module docstring).
    """
    raw = yaml.safe_load(Path(scene_path).read_text())
    out = {key: raw[key] for key in _KEPT if key in raw}
    a = float(max(raw["resolutions_um"]))
    edge = edge_voxels * a
    out["name"] = "twin"
    out["domain"] = {**raw.get("domain", {}), "size_um": [edge] * 3}
    out["resolutions_um"] = [a]
    out["spheres"] = {
        "inline": [[x * edge, y * edge, z * edge, _TWIN_RADIUS * edge] for x, y, z in _TWIN_CENTRES]
    }
    if "permeability" in out:  # the twin's flow runs through its whole box
        out["permeability"] = {**out["permeability"], "resolutions_um": [a], "whole_volume": True}
    out["analyses"] = ["segment", "minkowski", "lpt", "permeability"]
    return out


def twin_edges(scene, stage: str) -> list[int]:
    """The twin edges ``stage``'s warm-up runs for ``scene``: :data:`SMALL_EDGE` where a job's volume is small
    enough for the serial kernel variants, :data:`LARGE_EDGE` where one is over (not for permeability, whose twin
    would have to flow to convergence on 52^3: its large jobs compile their parallel variants themselves).
    """
    from porepipe._shared.numba_config import SERIAL_MAX_ELEMENTS

    if stage == "permeability":
        return [SMALL_EDGE]
    size = scene.domain.size_um
    volumes = [math.prod(round(e / a) for e in size) for a in scene.resolutions_um]
    edges = [SMALL_EDGE] if min(volumes) <= SERIAL_MAX_ELEMENTS else []
    return edges + ([LARGE_EDGE] if max(volumes) > SERIAL_MAX_ELEMENTS else [])


def twin_key(scene_path: str | os.PathLike, stage: str, scene=None) -> str:
    """20 hex digits that name ``stage``'s warm-up of the scene file ``scene_path`` by what it runs: the twins of
    :func:`twin_edges` (all the warm-up reads of the scene), the stage, porepipe's sources and the numba and Python
    versions. Scenes with equal keys warm the same kernels; ``scene`` is the loaded scene, where the caller has it.
    """
    if scene is None:
        from porepipe.scene import load_scene

        scene = load_scene(scene_path)
    h = hashlib.sha256(_sources_digest())
    h.update(stage.encode())
    for edge in twin_edges(scene, stage):
        read = {key: value for key, value in twin(scene_path, edge).items() if key not in _NOT_READ[stage]}
        h.update(yaml.safe_dump(read, sort_keys=True).encode())
    return h.hexdigest()[:20]


def marker_path(scene_path: str | os.PathLike, stage: str, scene=None) -> Path:
    """Where a finished warm-up of ``stage`` for this scene leaves its marker: :func:`marker_of` its
    :func:`twin_key`.
    """
    return marker_of(twin_key(scene_path, stage, scene), stage)


def marker_of(key: str, stage: str) -> Path:
    """The marker of ``stage``'s warm-up with twin key ``key``: in numba's cache folder (``NUMBA_CACHE_DIR``, else
    the ``__pycache__`` of porepipe's package).
    """
    cache = os.environ.get("NUMBA_CACHE_DIR")
    folder = Path(cache) if cache else Path(__file__).resolve().parent / "__pycache__"
    return folder / f"porepipe-warm-{stage}-{key}"


@functools.cache
def _sources_digest() -> bytes:
    """sha256 of porepipe's sources and the numba and Python versions, once per process (the Snakefile asks for
    every stage's marker).
    """
    from importlib.metadata import version  # not numba itself: the Snakefile asks before any job runs

    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for f in sorted(root.rglob("*.py")):
        h.update(str(f.relative_to(root)).encode())
        h.update(f.read_bytes())
    h.update(f"{version('numba')} {sys.version}".encode())
    return h.digest()


def _commands(stage: str, scene: Path, tmp: Path, twin_scene) -> list[list[str]]:
    """The ``porepipe`` commands (argument lists) that run ``stage`` on the twin, with the stages it reads first,
    each with the options its workflow rule gives it.
    """
    a = twin_scene.resolutions_um[0]
    grey, binary = str(tmp / "grey.h5"), str(tmp / "binary.h5")
    seg = twin_scene.segmentation
    voxelize = ["voxelize", str(scene), "--a", f"{a:g}", "-o", grey, "--threads", "1"]
    segment = ["segment", grey, "-o", binary, "--method", seg.method.value]
    segment += ["--threshold", str(seg.threshold)] if seg.threshold is not None else []
    if stage == "voxelize":
        return [voxelize]
    read = [voxelize, segment]
    scene_opts = ["--scene", str(scene), "--threads", "1"]
    if stage == "permeability":
        axis = twin_scene.permeability.axes[0].value
        return [
            *read,
            ["permeability", binary, "--grey", grey, *scene_opts, "--axis", axis, "-o", str(tmp / "p.h5")],
        ]
    if stage == "minkowski":
        grey_opt = ["--grey", grey] if twin_scene.minkowski.threshold_functions else []
        return [*read, ["minkowski", binary, *grey_opt, *scene_opts, "-o", str(tmp / "m.h5")]]
    if stage == "lpt":
        return [*read, ["lpt", binary, *scene_opts, "-o", str(tmp / "l.h5")]]
    raise ValueError(f"no warm-up for stage {stage!r} (known: {', '.join(STAGES)})")


def warm(scene_path: str | os.PathLike, stage: str, run) -> bool:
    """Run ``stage``'s commands on the twin of the scene in a temporary folder and leave the marker.

    Parameters
    ----------
    scene_path : path-like
        The scene YAML.
    stage : str
        One of :data:`STAGES`.
    run : callable
        The ``porepipe`` command as a function of its argument list, returning the exit code
        (``porepipe.cli.main``).

    Returns
    -------
    bool
        True when every command ran; False (after one line on stderr naming the command and its error) otherwise.
    """
    from porepipe._shared.progress import CONSOLE_ENV, notice
    from porepipe.scene import load_scene

    if stage not in STAGES:
        raise ValueError(f"no warm-up for stage {stage!r} (known: {', '.join(STAGES)})")
    notice(f"compiling the {stage} kernels ahead of its jobs, on a small twin of the scene (first run only)")
    console = os.environ.pop(CONSOLE_ENV, None)  # the twin's own progress lines stay off the console
    try:
        return _warm_in_temp(scene_path, stage, run, load_scene)
    finally:
        if console is not None:
            os.environ[CONSOLE_ENV] = console


def _warm_in_temp(scene_path, stage: str, main, load_scene) -> bool:
    scene = load_scene(scene_path)
    for edge in twin_edges(scene, stage):
        if not _run_twin(scene_path, stage, edge, main, load_scene):
            return False
    marker = marker_path(scene_path, stage, scene)
    try:
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.touch()
    except OSError as err:  # a read-only install: warm again next time
        print(f"porepipe warm {stage}: no marker kept ({err})", file=sys.stderr)
    return True


def _run_twin(scene_path, stage: str, edge: int, main, load_scene) -> bool:
    with tempfile.TemporaryDirectory(prefix="porepipe-warm-") as folder:
        tmp = Path(folder)
        scene = tmp / "twin.yaml"
        scene.write_text(yaml.safe_dump(twin(scene_path, edge), sort_keys=False))
        try:
            commands = _commands(stage, scene, tmp, load_scene(scene))
        except Exception as err:  # a warm-up never stops the workflow
            return _failed(stage, "the twin scene", f"{type(err).__name__}: {err}")
        for argv in commands:
            said = io.StringIO()
            try:
                with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
                    code = main(argv)
            except Exception as err:  # a warm-up never stops the workflow
                code, said = 1, io.StringIO(f"{type(err).__name__}: {err}")
            if code:
                return _failed(stage, f"`porepipe {argv[0]}` on the twin", said.getvalue())
    return True


def _failed(stage: str, what: str, message: str) -> bool:
    """Say in one line that ``what`` failed with ``message`` (its last line); False."""
    last = (message.strip().splitlines() or ["no message"])[-1].strip()
    print(
        f"porepipe warm {stage}: {what} failed ({last}); its jobs compile their kernels themselves",
        file=sys.stderr,
    )
    return False
