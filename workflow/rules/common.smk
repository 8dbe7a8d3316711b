# Shared workflow code: load and validate the scenes (first thing, so a bad scene stops the run with every problem
# listed), the per-analysis target registry, and input helpers.
import os
import sys
from pathlib import Path

from porepipe.scene import grey_stage, load_scene

# the `porepipe` command of the interpreter that runs Snakemake comes first on the jobs' PATH
os.environ["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])

_scene_files = [config["scene"]] if config.get("scene") else config.get("scenes", [])
if not _scene_files:
    raise ValueError("no scene: give --config scene=PATH or list `scenes:` in config/config.yaml")
SCENES = {}
SCENE_FILES = {}
for _path in _scene_files:
    _path = str(Path(workflow.basedir, _path)) if not Path(_path).is_absolute() else _path
    _scene = load_scene(_path)
    SCENES[_scene.name] = _scene
    SCENE_FILES[_scene.name] = _path


wildcard_constraints:
    scene=r"[A-Za-z0-9][A-Za-z0-9_.-]*",
    a=r"[0-9]+(\.[0-9]+)?",


def res_tag(a):
    """Resolution as it appears in file names: 2.0 -> '2', 0.5 -> '0.5'."""
    return f"{a:g}"


def results(scene, *parts):
    return str(Path("results", scene.name, *parts))


def per_resolution(scene, pattern):
    """`pattern` formatted with a = every resolution of the scene, e.g. 'segment/binary_a{a}.h5'."""
    return [results(scene, pattern.format(a=res_tag(a))) for a in scene.resolutions_um]


def scene_of(wildcards):
    return SCENES[wildcards.scene]


def grey_volumes(scene):
    """The grey volume of every resolution of the scene."""
    return per_resolution(scene, grey_stage(scene) + "/grey_a{a}.h5")


def grey_volume(wildcards):
    """The grey volume of resolution wildcards.a."""
    return results(scene_of(wildcards), grey_stage(scene_of(wildcards)), f"grey_a{wildcards.a}.h5")


def scene_file(wildcards):
    return SCENE_FILES[wildcards.scene]


#: analysis name -> function(scene) -> list of final outputs; each rule file registers its analysis here.
ANALYSIS_TARGETS = {}


def all_targets():
    out = []
    for scene in SCENES.values():
        for analysis in scene.analyses:
            if analysis.value not in ANALYSIS_TARGETS:
                raise ValueError(f"scene {scene.name!r}: no workflow rule produces analysis {analysis.value!r}")
            out += ANALYSIS_TARGETS[analysis.value](scene)
    return out


#: analysis name -> function(scene, edge_um) -> that analysis's outputs on the corner sub-samples
#: results/{scene}/segment/binary_a{a}_L{edge}.h5 (scene key sweep.sample_um); engines that accept sub-samples
#: register here, and the sweep gathers them with the sample size as a dimension.
SUBSAMPLE_TARGETS = {}


def per_subsample(scene, pattern, edge_um):
    """`pattern` with a = every resolution and L = the sub-sample edge, e.g. 'minkowski/minkowski_a{a}_L{L}.h5'."""
    return [results(scene, pattern.format(a=res_tag(a), L=res_tag(edge_um))) for a in scene.resolutions_um]
