"""Run control (checkpoint and progress intervals, MPI ranks, the threading threshold) changes no result, so it enters
no result hash and no scene stamp: a scene edit of it reruns nothing and discards no checkpoint. A change of a setting
that does change results still changes both. Whether a marked field really changes no result is each stage's own
test: tests/unit/packing/test_checkpoint_interval.py, tests/unit/granular/test_run.py (another checkpoint interval,
the same result bit for bit), and the permeability stage's checkpoint-resume and MPI tests."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from porepipe._registry import stage_settings
from porepipe._shared.run_control import run_control_names, without_run_control
from porepipe._shared.store import result_hash
from porepipe.lbm import Settings as LbmSettings
from porepipe.scene import load_scene
from porepipe.scene_stamps import stamp_text

MINI = Path(__file__).parents[3] / "config" / "scenes" / "mini.yaml"

#: every run-control field, by scene section: reviewed by hand, each one shown not to change its stage's result
#: (see above)
MARKED = {
    "packing": {"checkpoint_every", "checkpoint_every_s", "parallel_min_spheres", "progress_every_s"},
    "permeability": {"checkpoint_every_s", "mpi_ranks"},
    "granular": {"checkpoint_every_steps"},
}


def test_only_the_reviewed_fields_are_run_control():
    marked = {section: set(run_control_names(model)) for section, model in stage_settings().items()}
    assert {section: names for section, names in marked.items() if names} == MARKED


def _edited(tmp_path: Path, name: str, section: str, **keys) -> Path:
    tree = yaml.safe_load(MINI.read_text())
    tree.setdefault(section, {}).update(keys)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(tree))
    return path


@pytest.mark.parametrize(
    ("rule", "section", "run_control", "physics"),
    [
        ("pack", "packing", {"checkpoint_every_s": 5.0, "progress_every_s": 1.0}, {"cutoff": 1.5}),
        ("permeability", "permeability", {"checkpoint_every_s": 7.0, "mpi_ranks": 2}, {"tau": 0.8}),
    ],
)
def test_stamp_ignores_run_control_only(tmp_path, rule, section, run_control, physics):
    base = stamp_text(load_scene(MINI), rule)
    assert stamp_text(load_scene(_edited(tmp_path, "a.yaml", section, **run_control)), rule) == base
    assert stamp_text(load_scene(_edited(tmp_path, "b.yaml", section, **physics)), rule) != base


def test_result_hash_ignores_run_control_only():
    base = LbmSettings()
    same = result_hash("permeability", settings=LbmSettings(checkpoint_every_s=1.0, mpi_ranks=4))
    assert same == result_hash("permeability", settings=base)
    assert result_hash("permeability", settings=LbmSettings(tau=0.8)) != result_hash(
        "permeability", settings=base
    )
    assert "mpi_ranks" not in without_run_control(base) and "tau" in without_run_control(base)
