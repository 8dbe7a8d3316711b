"""Scene fuzzing (Hypothesis): random mutations of every shipped scene.

Properties (the house rule, issue #20):
1. ``validate`` never raises anything but :class:`PorepipeError` (SceneError), within a bounded time and memory;
2. a sample of the accepted scenes, shrunk to a tiny size (see :func:`_shrink`), runs its first stage or fails
   with that same clean error (exit code 2, one error line, no output file).

The runs are deterministic (``derandomize=True``, no example database), so CI sees the same scenes every time. The
counts are printed (``pytest -s``) for the README's reliability section.
"""

from __future__ import annotations

import copy
import math
import resource
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from porepipe._shared.errors import PorepipeError
from porepipe._shared.yaml_safe import load_yaml
from porepipe.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
SCENE_DIR = ROOT / "config" / "scenes"
SHIPPED = sorted(SCENE_DIR.glob("*.yaml"))
TINY = Path(__file__).parent / "data" / "tiny" / "tiny.yaml"
BASES = {p.stem: load_yaml(p) for p in [*SHIPPED, TINY]}

#: bounds on one validation: measured 0.017 s and 0.13 MB (tracemalloc peak) for the largest shipped scene; the
#: alias bomb of #20 took 3.5 GB. The memory bound is on the growth of the process's peak RSS (cheap to read, unlike
#: tracemalloc, which made validation 4x slower); 100x margins for a loaded CI machine.
VALIDATE_S = 2.0
VALIDATE_MB = 64
VALIDATE_EXAMPLES = 300
RUN_EXAMPLES = 40
COUNTS = {"validated": 0, "accepted": 0, "refused": 0, "runs": 0, "run ok": 0, "run refused": 0, "bad": 0}

ODD_VALUES = [
    math.nan,
    math.inf,
    -math.inf,
    -1,
    0,
    -0.0,
    1e300,
    1e-300,
    10**20,
    -(10**20),
    2**63,
    True,
    False,
    None,
    "",
    "x" * 300,
    "1e2",
    [],
    {},
    [1, 2, 3],
    [[1, 2, 3, 4]] * 3,
    {"unknown": 1},
    {"a": {"b": {"c": {"d": [1, {"e": None}]}}}},
    0.5,
    3,
    -3.5,
]


def _paths(tree, prefix=()):
    """Every (path, value) in a scene tree: mapping keys and list indices."""
    yield prefix, tree
    if isinstance(tree, dict):
        for key, value in tree.items():
            yield from _paths(value, (*prefix, key))
    elif isinstance(tree, list):
        for i, value in enumerate(tree):
            yield from _paths(value, (*prefix, i))


def _set(tree, path, value):
    parent = tree
    for part in path[:-1]:
        parent = parent[part]
    parent[path[-1]] = value


def _delete(tree, path):
    parent = tree
    for part in path[:-1]:
        parent = parent[part]
    del parent[path[-1]]


@st.composite
def mutated_scene(draw, bases=tuple(BASES)):
    """(base name, YAML text) of a shipped scene with 1-4 random mutations."""
    name = draw(st.sampled_from(bases))
    tree = copy.deepcopy(BASES[name])
    duplicate = None
    for _ in range(draw(st.integers(1, 4))):
        paths = [p for p, _ in _paths(tree) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        op = draw(
            st.sampled_from(["odd", "scale", "negate", "delete", "unknown", "wrap", "duplicate", "nest"])
        )
        value = _get(tree, path)
        if op == "odd":
            _set(tree, path, copy.deepcopy(draw(st.sampled_from(ODD_VALUES))))
        elif op == "scale" and isinstance(value, (int, float)) and not isinstance(value, bool):
            _set(tree, path, value * draw(st.sampled_from([1e-9, 1e-3, 0.5, 2, 1e3, 1e9, 1e20])))
        elif op == "negate" and isinstance(value, (int, float)) and not isinstance(value, bool):
            _set(tree, path, -value)
        elif op == "delete" and isinstance(path[-1], str):
            _delete(tree, path)
        elif op == "unknown" and isinstance(value, dict):
            key = draw(st.sampled_from(["colour", "Seed", "steps ", "k"]))
            value[key] = copy.deepcopy(draw(st.sampled_from(ODD_VALUES)))
        elif op == "wrap":
            _set(tree, path, [copy.deepcopy(value)])
        elif op == "nest":
            _set(tree, path, {"value": copy.deepcopy(value)})
        elif op == "duplicate" and isinstance(path[0], str) and len(path) == 1:
            duplicate = path[0]
    text = yaml.safe_dump(tree, sort_keys=False)
    if duplicate is not None:  # the same top-level key twice (PyYAML would keep the last silently)
        text += yaml.safe_dump({duplicate: BASES[name].get(duplicate, 1)})
    return name, text


def _get(tree, path):
    for part in path:
        tree = tree[part]
    return tree


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _validate(tmp_path: Path, name: str, text: str):
    """load_scene under the time and memory bounds; the scene, or None when refused cleanly."""
    base = SCENE_DIR if name in (p.stem for p in SHIPPED) else TINY.parent
    path = base / f".fuzz-{name}-{id(text)}.yaml"  # beside the original: its relative data paths resolve
    path.write_text(text)
    rss0 = _peak_rss_mb()
    t0 = time.perf_counter()
    try:
        scene = load_scene(path)
    except PorepipeError as err:
        assert "Traceback" not in str(err)
        scene = None
    finally:
        elapsed = time.perf_counter() - t0
        path.unlink()
    assert elapsed < VALIDATE_S, f"validate took {elapsed:.2f} s"
    grown = _peak_rss_mb() - rss0
    assert grown < VALIDATE_MB, f"validate raised the peak memory by {grown:.0f} MB"
    return scene


@settings(
    max_examples=VALIDATE_EXAMPLES,
    derandomize=True,
    database=None,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(case=mutated_scene())
def test_validate_raises_only_the_clean_error(case, tmp_path):
    name, text = case
    COUNTS["validated"] += 1
    scene = _validate(tmp_path, name, text)
    COUNTS["accepted" if scene is not None else "refused"] += 1


# -- the first stage of accepted scenes ---------------------------------------------------------------------------------
def _shrink(tree: dict) -> dict:
    """The scene made tiny so its first stage runs in a second: at most 20 spheres per type and 20 steps per stage,
    a granular run of 20 steps. Everything else (the mutated settings) is kept."""
    tree = copy.deepcopy(tree)
    packing = tree.get("packing")
    if isinstance(packing, dict):
        for kind in packing.get("types") or []:
            if (
                isinstance(kind, dict)
                and isinstance(kind.get("count"), int)
                and not isinstance(kind["count"], bool)
            ):
                kind["count"] = min(kind["count"], 20)
        for stage in packing.get("stages") or []:
            if (
                isinstance(stage, dict)
                and isinstance(stage.get("steps"), int)
                and not isinstance(stage["steps"], bool)
            ):
                stage["steps"] = min(stage["steps"], 20)
    granular = tree.get("granular")
    if isinstance(granular, dict) and isinstance(granular.get("dt_s"), float):
        granular["duration_s"] = 20 * granular["dt_s"]
    return tree


def _first_stage(scene, path: Path, out: Path) -> list[str] | None:
    """The argv of the scene's first stage, or None when it starts from an image (acquire is fuzzed by file)."""
    analyses = {a.value for a in scene.analyses}
    if getattr(scene, "acquire", None) is not None:
        return None
    if analyses and analyses <= {"granular"}:
        return ["granular", str(path), "--quiet", "-o", str(out / "granular.h5")]
    if scene.spheres is not None and scene.spheres.pack:
        return ["pack", str(path), "-o", str(out / "packing.h5")]
    voxels = math.prod(edge / scene.resolutions_um[0] for edge in scene.domain.size_um)
    if voxels > 64**3:
        return None  # a large volume is not a fuzz case (the memory bound is checked by validate)
    return ["voxelize", str(path), "--a", str(scene.resolutions_um[0]), "-o", str(out / "grey.h5")]


@settings(
    max_examples=RUN_EXAMPLES,
    derandomize=True,
    database=None,
    deadline=None,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.function_scoped_fixture,
        HealthCheck.filter_too_much,
    ],
)
@given(case=mutated_scene(bases=("tiny", "granular-box", "mini", "rough-walls-ci")))
def test_accepted_scenes_run_their_first_stage_or_fail_cleanly(case, tmp_path_factory):
    from fuzz_files import files_in, run_cli

    name, text = case
    tiny_text = yaml.safe_dump(_shrink(yaml.safe_load(text)), sort_keys=False) if _loads(text) else text
    base = SCENE_DIR if name != "tiny" else TINY.parent
    work = tmp_path_factory.mktemp("run")
    path = base / f".fuzz-run-{work.name}.yaml"
    path.write_text(tiny_text)
    try:
        try:
            scene = load_scene(path)
        except PorepipeError:
            return
        argv = _first_stage(scene, path, work / "out")
        if argv is None:
            return
        outcome = run_cli(argv)
    finally:
        path.unlink()
    COUNTS["runs"] += 1
    left = files_in(work / "out") if (work / "out").exists() else set()
    if outcome.exception is None and outcome.code == 0:
        COUNTS["run ok"] += 1
        return
    if outcome.clean_error and not left:
        COUNTS["run refused"] += 1
        return
    COUNTS["bad"] += 1
    pytest.fail(
        f"{argv[0]} on a mutated {name}: code {outcome.code}, {outcome.exception!r}, {outcome.stderr[-500:]}"
    )


def _loads(text: str) -> bool:
    try:
        return isinstance(yaml.safe_load(text), dict)
    except yaml.YAMLError:
        return False


def test_zzz_print_scene_fuzz_counts():
    """Runs last in this module: the tallies for the README's reliability section."""
    print(f"\nscene fuzzing: {COUNTS}")
    assert COUNTS["bad"] == 0
