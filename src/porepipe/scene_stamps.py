"""Scene stamps: what each workflow rule reads of a scene, kept in a file that changes only when that part does.

A rule that took the scene file itself as input reran whenever the file's time changed: a new comment reran every job
of the scene, and a change to ``permeability:`` reran the packing. A file copied back with an older time (``cp -p``)
reran nothing, so its results were stale. A rule now takes its stamp, ``results/<scene>/scene/<rule>.json``, as input:
the scene's settings as porepipe reads them (defaults filled in, comments and layout gone), less the keys that rule
cannot depend on (:data:`IGNORED`) and less run control (checkpoint and progress intervals, ranks:
:mod:`porepipe._shared.run_control`). The workflow writes a rule's stamp when it plans the rule's jobs, and only if its
text changed, so Snakemake reruns a rule exactly when its part of the scene changed. Rules not listed in :data:`IGNORED`
stamp the whole scene. ``tests/unit/warm/test_scene_stamps.py`` records which scene keys each stage's command reads
and checks that none of them is ignored for its rule.
"""

from __future__ import annotations

import json
from pathlib import Path

from porepipe._shared.atomic import atomic_path
from porepipe._shared.run_control import without_run_control

__all__ = ["IGNORED", "STAMPED_RULES", "STAMP_FOLDER", "stamp_text", "write_stamp"]

#: the folder of a scene's stamps, ``results/<scene>/<STAMP_FOLDER>/<rule>.json`` (common.smk's ``scene_stamp``)
STAMP_FOLDER = "scene"

#: the scene sections of the measuring engines and of what gathers their results
_ENGINES = frozenset({"minkowski", "lpt", "permeability", "diffusion", "sweep", "report", "granular"})
#: what the model-building rules do not read: the engines, which analyses run, the segmentation, the resolutions (a
#: job of one resolution gets it on its command line)
_MODEL = _ENGINES | {"analyses", "segmentation", "resolutions_um"}
#: what a measuring rule does not read besides the other engines: how the volume it reads was built (that volume is
#: its input, so a change there reaches it through the file)
_BUILT = frozenset(
    {"analyses", "segmentation", "resolutions_um", "packing", "decoration", "voxelize", "spheres"}
)

#: the memory budget (``resources.memory_budget_mb``): only the volume stages that chunk by it read it (voxelize,
#: minkowski, lpt; segment gets it as a command-line option)
_BUDGET = frozenset({"resources"})

#: rule -> the top-level scene keys its results cannot depend on
IGNORED: dict[str, frozenset[str]] = {
    "pack": _MODEL | _BUDGET | {"decoration", "voxelize"},
    "decorate": _MODEL | _BUDGET | {"voxelize"},
    "voxelize_grains": _MODEL | _BUDGET,
    "voxelize": _MODEL | {"decoration"},
    "minkowski": _BUILT | (_ENGINES - {"minkowski"}),
    "lpt": _BUILT | (_ENGINES - {"lpt"}),
    "permeability": _BUILT | _BUDGET | (_ENGINES - {"permeability"}),
    "diffusion": _BUILT | _BUDGET | (_ENGINES - {"diffusion"}),
    "capillary": (_MODEL | _BUDGET) - {"diffusion", "resolutions_um"},
    "granular": (_MODEL - {"granular"}) | _BUILT | _BUDGET | {"domain", "acquire"},
}
#: the workflow's rules that take a stamp (the others take no scene at all; a test checks the rule files agree)
STAMPED_RULES = (
    *IGNORED,
    "acquire",
    "acquire_calibrate",
    "acquire_model",
    "granular_report",
    "report",
    "sweep",
)


def stamp_text(scene, rule: str) -> str:
    """The stamp of ``rule`` for ``scene`` (a loaded :class:`porepipe.scene.Scene`): the scene's settings as JSON, sorted
    keys, less :data:`IGNORED`'s keys of that rule and less run control.
    """
    ignored = IGNORED.get(rule, frozenset())
    kept = {key: value for key, value in without_run_control(scene).items() if key not in ignored}
    return json.dumps(kept, sort_keys=True, indent=1) + "\n"


def write_stamp(scene, rule: str, folder) -> str:
    """Write ``rule``'s stamp of ``scene`` to ``folder/<rule>.json`` where its text changed (an unchanged stamp keeps
    its time, so Snakemake reruns nothing for it); returns its path.
    """
    path = Path(folder) / f"{rule}.json"
    text = stamp_text(scene, rule)
    try:
        same = path.read_text() == text
    except OSError:  # none yet (or unreadable: write it afresh)
        same = False
    if not same:
        with atomic_path(path) as tmp:
            Path(tmp).write_text(text)
    return str(path)
