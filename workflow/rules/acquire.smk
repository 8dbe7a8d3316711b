# Data acquisition (thesis §4.7 item 1, ch. 8): a scene with an `acquire:` section starts from an image.
#   acquire            image -> results/{scene}/acquire/statistics.h5 (phases volume + statistics tables)
#   acquire_binary     statistics.h5 -> results/{scene}/segment/binary_a{a}.h5, the image at its own voxel size (or a
#                      whole multiple of it, block rule), so minkowski/lpt/permeability run on it unchanged. It only
#                      matches acquire scenes (wildcard constraint) and wins over `segment` there (ruleorder); model
#                      scenes keep `segment`, for which this rule does not match at all.
#   acquire_calibrate  statistics -> calibrated model scene YAML (packing + decoration), editable
#   acquire_model      calibrated scene -> model_statistics.h5 (pack, voxelise, Otsu, the same statistics)
#   acquire_compare    both -> comparison.h5 (+ .png, .md): Tables 8.4/8.5 layout and μ, λ, p overlays
import glob
import re


def _acquire_scene_names():
    return [name for name, scene in SCENES.items() if getattr(scene, "acquire", None) is not None]


# a regex that matches exactly the acquire scenes (and nothing when there are none)
ACQUIRE_SCENE_RE = "|".join(re.escape(n) for n in _acquire_scene_names()) or "(?!)"


def acquire_image(wildcards):
    """The image file(s) of an acquire scene, relative to the scene file (a TIFF directory/glob: every section)."""
    scene = scene_of(wildcards)
    path = Path(scene.acquire.image)
    path = path if path.is_absolute() else Path(scene_file(wildcards)).parent / path
    if path.is_dir():
        return sorted(str(p) for p in path.iterdir() if p.suffix.lower() in (".tif", ".tiff"))
    if any(c in str(path) for c in "*?["):
        return sorted(glob.glob(str(path)))
    return [str(path)]


rule acquire:
    input:
        scene=scene_file,
        image=acquire_image,
    output:
        "results/{scene}/acquire/statistics.h5",
    log:
        "results/{scene}/logs/acquire.log",
    benchmark:
        "results/{scene}/cost/acquire.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    threads: workflow.cores
    shell:
        "porepipe acquire --scene {input.scene} -o {output} --threads {threads} > {log} 2>&1"


rule acquire_binary:
    input:
        "results/{scene}/acquire/statistics.h5",
    output:
        "results/{scene}/segment/binary_a{a}.h5",
    log:
        "results/{scene}/logs/acquire_binary_a{a}.log",
    benchmark:
        "results/{scene}/cost/acquire_binary_a{a}.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    shell:
        "porepipe acquire-binary {input} --a {wildcards.a} -o {output} > {log} 2>&1"


ruleorder: acquire_binary > segment


rule acquire_calibrate:
    input:
        statistics="results/{scene}/acquire/statistics.h5",
        scene=scene_file,
    output:
        "results/{scene}/acquire/calibrated_scene.yaml",
    log:
        "results/{scene}/logs/acquire_calibrate.log",
    benchmark:
        "results/{scene}/cost/acquire_calibrate.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    shell:
        "porepipe acquire-calibrate {input.statistics} --scene {input.scene} -o {output} > {log} 2>&1"


rule acquire_model:
    input:
        model="results/{scene}/acquire/calibrated_scene.yaml",
        scene=scene_file,
    output:
        "results/{scene}/acquire/model_statistics.h5",
    log:
        "results/{scene}/logs/acquire_model.log",
    benchmark:
        "results/{scene}/cost/acquire_model.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    threads: workflow.cores
    shell:
        "porepipe acquire-model {input.model} --scene {input.scene} -o {output} --threads {threads} > {log} 2>&1"


rule acquire_compare:
    input:
        experiment="results/{scene}/acquire/statistics.h5",
        model="results/{scene}/acquire/model_statistics.h5",
    output:
        table="results/{scene}/acquire/comparison.h5",
        png="results/{scene}/acquire/comparison.png",
        md="results/{scene}/acquire/comparison.md",
    log:
        "results/{scene}/logs/acquire_compare.log",
    benchmark:
        "results/{scene}/cost/acquire_compare.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    shell:
        "porepipe acquire-compare {input.experiment} {input.model} -o {output.table} > {log} 2>&1"


def acquire_targets(scene):
    if getattr(scene, "acquire", None) is None:
        raise ValueError(f"scene {scene.name!r} lists analysis `acquire` but has no `acquire:` section")
    return [results(scene, "acquire", f) for f in ("statistics.h5", "comparison.h5")]


ANALYSIS_TARGETS["acquire"] = acquire_targets
