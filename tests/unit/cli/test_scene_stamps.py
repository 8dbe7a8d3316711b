"""Scene stamps (porepipe.scene_stamps): each workflow rule reruns when what it reads of the scene changes, not when a
comment, the layout or another engine's section does, and a scene copied back with an older time still reruns.

Truth for the ignored keys: each stage's own command, run as its rule runs it on a tiny scene, with a scene object that
records which top-level keys the command reads (attribute reads, ``scene_part`` keys, a whole ``model_dump``); none of
them may be a key its rule's stamp leaves out.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pydantic
import pytest
import yaml

import porepipe.scene as scene_module
from porepipe.cli import main
from porepipe.scene import load_scene
from porepipe.scene_stamps import IGNORED, STAMPED_RULES, stamp_text, write_stamp

REPO = Path(__file__).resolve().parents[3]
TINY = REPO / "tests" / "hard" / "data" / "tiny"
WHOLE_DUMP = "(model_dump: every key)"

DECORATED = {
    "name": "tiny-deco",
    "seed": 3,
    "domain": {"size_um": [12, 12, 12], "periodic": True},
    "spheres": {"inline": [[2, 3, 4, 2.5], [8, 8, 8, 3.0], [11.5, 0.5, 6, 2.0]]},
    "decoration": {"families": [{"name": "q", "generator": "quartz", "count": 2}]},
    "resolutions_um": [2],
}
GRANULAR = (
    "name: s\nanalyses: [granular]\ngranular:\n  duration_s: 0.001\n  dt_s: 1.0e-5\n"
    "  particles:\n    - {vertices_m: [[0, 0], [0.01, 0], [0.01, 0.01]]}\n"
)


def _recording(monkeypatch) -> set[str]:
    """Make every porepipe module's ``load_scene`` return a scene that records the top-level keys read of it, and its
    ``scene_part`` record the keys it selects; returns the set they are recorded in.
    """
    seen: set[str] = set()
    original_load, original_part = scene_module.load_scene, scene_module.scene_part

    def load(path, *args, **kwargs):
        scene = original_load(path, *args, **kwargs)
        cls = type(scene)
        fields = set(cls.model_fields)

        class Recording(cls):
            def __getattribute__(self, name):
                if name in fields:
                    seen.add(name)
                return super().__getattribute__(name)

            def model_dump(self, *a, **k):
                seen.add(WHOLE_DUMP)
                return super().model_dump(*a, **k)

        return Recording.model_construct(**{key: scene.__dict__[key] for key in fields})

    def part(scene, *keys):
        seen.update(keys)
        dumped = pydantic.BaseModel.model_dump(scene, mode="json")
        return {key: dumped.get(key) for key in keys}

    for name, module in list(sys.modules.items()):
        if name.startswith("porepipe"):
            if getattr(module, "load_scene", None) is original_load:
                monkeypatch.setattr(module, "load_scene", load)
            if getattr(module, "scene_part", None) is original_part:
                monkeypatch.setattr(module, "scene_part", part)
    return seen


def _tiny(tmp_path: Path) -> Path:
    for name in ("tiny.yaml", "packing.h5", "grey_a4.h5", "binary_a4.h5"):
        shutil.copy(TINY / name, tmp_path / name)
    return tmp_path / "tiny.yaml"


def _argv(rule: str, tmp: Path) -> list[str]:
    """The command of ``rule`` as its workflow rule gives it, on a tiny input in ``tmp``."""
    tiny = str(_tiny(tmp))
    binary, grey, out = str(tmp / "binary_a4.h5"), str(tmp / "grey_a4.h5"), str(tmp / "out.h5")
    if rule == "pack":
        return ["pack", tiny, "-o", out, "--xyzr", str(tmp / "p.xyzr"), "--checkpoint", str(tmp / "ck.h5")]
    if rule == "voxelize":
        return [
            "voxelize",
            tiny,
            "--a",
            "4",
            "-o",
            out,
            "--packing",
            str(tmp / "packing.h5"),
            "--threads",
            "1",
        ]
    if rule in ("minkowski", "lpt"):
        return [rule, binary, "--scene", tiny, "-o", out, "--threads", "1"]
    if rule == "permeability":
        return [
            "permeability",
            binary,
            "--grey",
            grey,
            "--scene",
            tiny,
            "--axis",
            "z",
            "-o",
            out,
            "--threads",
            "1",
        ]
    if rule == "diffusion":
        return ["diffusion", binary, "--scene", tiny, "--axis", "z", "-o", out, "--threads", "1"]
    if rule == "capillary":
        scene = str(REPO / "config" / "scenes" / "knudsen-capillary-ci.yaml")
        return ["diffusion-capillary", "--scene", scene, "--a", "1", "-o", out]
    if rule == "granular":
        (tmp / "g.yaml").write_text(GRANULAR)
        return ["granular", str(tmp / "g.yaml"), "-o", out, "--quiet"]
    (tmp / "deco.yaml").write_text(yaml.safe_dump(DECORATED))
    grains = str(tmp / "grains.h5")
    assert main(["decorate", str(tmp / "deco.yaml"), "-o", grains, "--threads", "1"]) == 0
    if rule == "decorate":
        return ["decorate", str(tmp / "deco.yaml"), "-o", str(tmp / "grains2.h5"), "--threads", "1"]
    return [
        "voxelize-grains",
        str(tmp / "deco.yaml"),
        "--grains",
        grains,
        "--a",
        "2",
        "-o",
        out,
        "--threads",
        "1",
    ]


@pytest.mark.parametrize("rule", sorted(IGNORED))
def test_no_stage_reads_a_key_its_stamp_leaves_out(rule, tmp_path, monkeypatch):
    argv = _argv(rule, tmp_path)
    seen = _recording(monkeypatch)
    assert main(argv) == 0
    assert seen, f"{rule}: the command read no scene (the recorder is not in its path)"
    assert WHOLE_DUMP not in seen, f"{rule}: the command dumps the whole scene; its stamp must keep every key"
    assert not seen & IGNORED[rule], (
        f"{rule} reads {sorted(seen & IGNORED[rule])}, which its stamp leaves out"
    )


def test_the_workflow_stamps_exactly_the_listed_rules():
    text = "".join(p.read_text() for p in (REPO / "workflow" / "rules").glob("*.smk"))
    assert set(re.findall(r'scene_stamp\("(\w+)"\)', text)) == set(STAMPED_RULES)
    assert text.count("{input.scene") == 1  # the warm rule's, which builds its twins from the scene file


def test_a_stamp_ignores_comments_layout_and_the_keys_its_rule_does_not_read(tmp_path):
    base = yaml.safe_load((TINY / "tiny.yaml").read_text())
    first, second = tmp_path / "a.yaml", tmp_path / "b.yaml"
    first.write_text(yaml.safe_dump(base, sort_keys=True))
    edited = {**base, "permeability": {**base["permeability"], "tolerance_kappa": 2e-3}}
    second.write_text("# a comment\n" + yaml.safe_dump(edited, sort_keys=False, default_flow_style=True))
    a, b = load_scene(first), load_scene(second)
    for rule in ("pack", "voxelize", "minkowski", "lpt", "diffusion"):
        assert stamp_text(a, rule) == stamp_text(b, rule), rule
    for rule in ("permeability", "sweep", "report"):
        assert stamp_text(a, rule) != stamp_text(b, rule), rule


#: the rules whose commands read ``resources.memory_budget_mb`` (test_no_stage_reads_a_key_its_stamp_leaves_out
#: checks that the others do not): voxelize, minkowski and lpt chunk their volumes by it (segment gets it on its
#: command line, which is a rule parameter, not a stamp)
READS_THE_BUDGET = {"voxelize", "minkowski", "lpt"}


def test_a_memory_budget_edit_reruns_only_the_rules_that_read_it(tmp_path):
    # before: every stamp kept `resources`, so setting resources.memory_budget_mb (say, after lpt ran out of memory
    # at a fine resolution) also reran pack, which never reads it (runtime up to 240 min); the volumes are rebuilt
    # (voxelize reads it), so the engines after them rerun through their input files, not through their stamps
    base = yaml.safe_load((TINY / "tiny.yaml").read_text())
    first, second = tmp_path / "a.yaml", tmp_path / "b.yaml"
    first.write_text(yaml.safe_dump(base))
    second.write_text(yaml.safe_dump({**base, "resources": {"memory_budget_mb": 4000}}))
    a, b = load_scene(first), load_scene(second)
    for rule in IGNORED:
        changed = stamp_text(a, rule) != stamp_text(b, rule)
        assert changed == (rule in READS_THE_BUDGET), rule


def test_write_stamp_keeps_an_unchanged_stamp_and_rewrites_a_changed_one(tmp_path):
    scene = load_scene(TINY / "tiny.yaml")
    path = Path(write_stamp(scene, "pack", tmp_path / "scene"))
    os.utime(path, (1e9, 1e9))
    write_stamp(scene, "pack", tmp_path / "scene")
    assert path.stat().st_mtime == 1e9  # same text: the time Snakemake compares is kept
    other = scene.model_copy(update={"seed": scene.seed + 1})
    write_stamp(other, "pack", tmp_path / "scene")
    assert path.stat().st_mtime > 1e9 and f'"seed": {scene.seed + 1}' in path.read_text()
    assert [p.name for p in path.parent.iterdir()] == ["pack.json"]  # no temporary left


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    return subprocess.run(
        [sys.executable, "-m", "porepipe.cli", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )


def _planned(scene: Path, cwd: Path) -> dict[str, int]:
    """Job counts per rule of a dry run (empty: nothing to do)."""
    res = _run(["run", str(scene), "-n"], cwd)
    assert res.returncode == 0, res.stderr[-2000:]
    table = res.stdout.split("Job stats:", 1)
    rows = re.findall(r"^(\w+)\s+(\d+)$", table[1], re.M) if len(table) > 1 else []
    return {rule: int(n) for rule, n in rows if rule not in ("total", "all")}


@pytest.mark.slow
def test_the_workflow_reruns_what_a_scene_edit_changes_and_nothing_else(tmp_path):
    tree = yaml.safe_load((TINY / "tiny.yaml").read_text())
    tree.update(analyses=["segment", "minkowski", "lpt"], resolutions_um=[4])
    tree.pop("permeability"), tree.pop("diffusion")
    scene = tmp_path / "tiny.yaml"
    scene.write_text(yaml.safe_dump(tree))
    done = _run(["run", str(scene), "--cores", "1"], tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert _planned(scene, tmp_path) == {}

    scene.write_text("# only a comment and another layout\n" + yaml.safe_dump(tree, default_flow_style=True))
    assert _planned(scene, tmp_path) == {}  # before: every job reran (the scene file was every rule's input)

    lpt_only = {**tree, "lpt": {"cell_um": [8, 16]}}
    scene.write_text(yaml.safe_dump(lpt_only))
    assert _planned(scene, tmp_path) == {"lpt": 1}  # before: pack, voxelize, segment and minkowski too
    done = _run(["run", str(scene), "--cores", "1"], tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]

    scene.write_text(yaml.safe_dump(tree))
    os.utime(scene, (1e9, 1e9))  # a scene copied back with an old time (cp -p): its content still counts
    assert _planned(scene, tmp_path) == {"lpt": 1}  # before: nothing, the lpt results of lpt_only stayed
