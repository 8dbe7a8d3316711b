"""File in, compute, file out: ``report/index.html`` (+ PNG, CSV) of a scene's sweep."""

from __future__ import annotations

from pathlib import Path

from porepipe._shared.errors import PorepipeError
from porepipe._shared.naming import res_tag
from porepipe.report._api import build_report
from porepipe.scene import Analysis, grey_stage


def existing(scene, pattern: str) -> list[str]:
    """``results/<scene>/<pattern>`` for every resolution of the scene (``{a}`` = its tag) that exists."""
    paths = [Path("results", scene.name, pattern.format(a=res_tag(a))) for a in scene.resolutions_um]
    return [str(p) for p in paths if p.is_file()]


def run(
    scene,
    scene_path,
    *,
    sweep=None,
    out=None,
    grey=None,
    binary=None,
    lpt=None,
    granular=None,
    compare=(None, None),
) -> Path:
    """Write the accuracy-versus-cost report of ``scene``.

    Parameters
    ----------
    scene : Scene
        The validated scene (its ``report`` section).
    scene_path : path-like
        Its file (named in the message when the sweep is missing).
    sweep : path-like, optional
        ``sweep.h5`` (default ``results/<scene>/sweep/sweep.h5``).
    out : path-like, optional
        ``index.html`` (default ``results/<scene>/report/index.html``).
    grey, binary, lpt : sequence of path-like, optional
        Volumes for cross-sections and LPT results for curves (default: those of the scene that exist).
    granular : path-like or sequence of path-like, optional
        A granular scene's result; several (one per seed) add the heap floor-pressure dip over seeds.
    compare : (path-like, sequence of path-like), optional
        Scene file and per-seed results of a second heap ensemble shown beside the first.

    Returns
    -------
    pathlib.Path
        The page written.
    """
    sweep = Path(sweep or Path("results", scene.name, "sweep", "sweep.h5"))
    out = Path(out or Path("results", scene.name, "report", "index.html"))
    if granular is None and not sweep.is_file() and _is_granular(scene):
        granular = Path("results", scene.name, "granular", "granular.h5")  # a 2-D granular scene has no sweep
    if granular is not None:
        return _granular(scene, granular, out, compare)
    if not sweep.is_file():
        raise PorepipeError(
            f"{sweep} does not exist: run the workflow first (`porepipe run {scene_path}` with "
            "`report` in the scene's analyses)"
        )
    grey = grey if grey is not None else existing(scene, grey_stage(scene) + "/grey_a{a}.h5")
    binary = binary if binary is not None else existing(scene, "segment/binary_a{a}.h5")
    lpt = lpt if lpt is not None else existing(scene, "lpt/lpt_a{a}.h5")
    return build_report(
        sweep,
        out,
        settings=scene.report,
        grey=grey,
        binary=binary,
        lpt=lpt,
        scene_name=scene.name,
        inputs={"thesis_rows": thesis_row_sweeps(scene)},
    )


def thesis_row_sweeps(scene) -> dict[str, Path]:
    """``report.thesis_rows_from`` as thesis model -> ``results/<scene>/sweep/sweep.h5``; a missing one is an error."""
    sweeps = {
        m: Path("results", name, "sweep", "sweep.h5") for m, name in scene.report.thesis_rows_from.items()
    }
    for model, path in sweeps.items():
        if not path.is_file():
            raise PorepipeError(
                f"report.thesis_rows_from.{model}: {path} does not exist; run the workflow on scene "
                f"{scene.report.thesis_rows_from[model]!r} first (`porepipe run` does it for you)"
            )
    return sweeps


def _granular(scene, results, out: Path, compare=(None, None)) -> Path:
    """The granular report page of ``results`` (matplotlib and the granular package only when one is built)."""
    results = [Path(r) for r in ([results] if isinstance(results, (str, Path)) else results)]
    _require_granular(scene, f"report --granular {results[0]}")
    from porepipe.report._granular import granular_report, read_heap_ensemble

    _exist(results)
    groups = []
    if len(results) > 1:
        groups.append(read_heap_ensemble(results, scene.granular, scene.name))
    if compare[0] is not None or compare[1]:
        groups.append(_compare_group(compare))
    g = scene.granular
    return granular_report(
        results[0],
        out,
        scene_name=scene.name,
        mu=g.material.friction,
        silo=g.silo,
        gravity=g.gravity,
        young=g.material.young_N_m,
        ensembles=groups,
    )


def _is_granular(scene) -> bool:
    """Whether ``scene`` runs the granular stage (every scene has default granular settings: ask its analyses)."""
    return Analysis.granular in scene.analyses


def _require_granular(scene, what: str) -> None:
    if not _is_granular(scene):
        raise PorepipeError(
            f"{what}: scene {scene.name!r} is not a granular scene (no `granular` in its analyses)"
        )


def _exist(results) -> None:
    for r in results:
        if not Path(r).is_file():
            raise PorepipeError(
                f"{r} does not exist: run the granular stage first (`porepipe run` the scene)"
            )


def _compare_group(compare) -> dict:
    """The second heap ensemble of ``--compare-scene`` / ``--compare-granular``."""
    from porepipe.report._granular import read_heap_ensemble
    from porepipe.scene import load_scene

    path, results = compare
    if path is None or not results:
        raise PorepipeError(
            "report: --compare-scene and --compare-granular go together (scene YAML and its results)"
        )
    other = load_scene(path)
    _require_granular(other, f"report --compare-scene {path}")
    _exist(results)
    return read_heap_ensemble([Path(r) for r in results], other.granular, other.name)
