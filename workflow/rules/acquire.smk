# Data acquisition (thesis §4.7 item 1, ch. 8): a scene with an `acquire:` section starts from an image.
#   acquire            image -> results/{scene}/acquire/statistics.h5 (phases volume + statistics tables)
#   acquire_binary     statistics.h5 -> results/{scene}/acquire_binary/binary_a{a}.h5, the image at its own voxel size
#                      (or a whole multiple of it, block rule); common.smk's binary_volume() hands it to minkowski, lpt
#                      and permeability of an acquire scene in place of segment's binary volume.
#   acquire_calibrate  statistics -> calibrated model scene YAML (packing + decoration), editable
#   acquire_model      calibrated scene -> model_statistics.h5 (pack, voxelise, Otsu, the same statistics)
#   acquire_compare    both -> comparison.h5 (+ .png, .md): Tables 8.4/8.5 layout and μ, λ, p overlays


rule acquire:
    input:
        stamp=scene_stamp("acquire"),
        image=acquire_image,
    output:
        "results/{scene}/acquire/statistics.h5",
    log:
        "results/{scene}/logs/acquire.log",
    benchmark:
        "results/{scene}/cost/acquire.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    conda:
        "../envs/porepipe.yaml"
    threads: every_core(8)
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=8000,
        runtime=60,
    params:
        scene=scene_file,
    shell:
        "porepipe acquire --scene {params.scene:q} -o {output:q} --threads {threads} > {log:q} 2>&1"


rule acquire_binary:
    input:
        "results/{scene}/acquire/statistics.h5",
    output:
        "results/{scene}/acquire_binary/binary_a{a}.h5",
    log:
        "results/{scene}/logs/acquire_binary_a{a}.log",
    benchmark:
        "results/{scene}/cost/acquire_binary_a{a}.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=4000,
        runtime=10,
    shell:
        "porepipe acquire-binary {input:q} --a {wildcards.a} -o {output:q} > {log:q} 2>&1"


rule acquire_calibrate:
    input:
        statistics="results/{scene}/acquire/statistics.h5",
        stamp=scene_stamp("acquire_calibrate"),
    output:
        "results/{scene}/acquire_calibrate/calibrated_scene.yaml",
    log:
        "results/{scene}/logs/acquire_calibrate.log",
    benchmark:
        "results/{scene}/cost/acquire_calibrate.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=2000,
        runtime=30,
    params:
        scene=scene_file,
    shell:
        "porepipe acquire-calibrate {input.statistics:q} --scene {params.scene:q} -o {output:q} > {log:q} 2>&1"


rule acquire_model:
    input:
        model="results/{scene}/acquire_calibrate/calibrated_scene.yaml",
        stamp=scene_stamp("acquire_model"),
    output:
        "results/{scene}/acquire_model/model_statistics.h5",
    log:
        "results/{scene}/logs/acquire_model.log",
    benchmark:
        "results/{scene}/cost/acquire_model.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    conda:
        "../envs/porepipe.yaml"
    threads: every_core(8)
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=8000,
        runtime=120,
    params:
        scene=scene_file,
    shell:
        "porepipe acquire-model {input.model:q} --scene {params.scene:q} -o {output:q} --threads {threads}"
        " > {log:q} 2>&1"


rule acquire_compare:
    input:
        experiment="results/{scene}/acquire/statistics.h5",
        model="results/{scene}/acquire_model/model_statistics.h5",
    output:
        table="results/{scene}/acquire_compare/comparison.h5",
        png=report(
            "results/{scene}/acquire_compare/comparison.png",
            caption="../report/comparison.rst",
            category="Model against experiment",
        ),
        md=report(
            "results/{scene}/acquire_compare/comparison.md",
            caption="../report/comparison.rst",
            category="Model against experiment",
        ),
    log:
        "results/{scene}/logs/acquire_compare.log",
    benchmark:
        "results/{scene}/cost/acquire_compare.tsv"
    wildcard_constraints:
        scene=ACQUIRE_SCENE_RE,
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=2000,
        runtime=10,
    shell:
        "porepipe acquire-compare {input.experiment:q} {input.model:q} -o {output.table:q} > {log:q} 2>&1"


ANALYSIS_TARGETS["acquire"] = acquire_targets
