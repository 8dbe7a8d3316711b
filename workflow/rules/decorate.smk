# Grain decoration (thesis §4.7.1 step 3): grains.h5 for scenes with a `decoration:` section, and the grey volumes of
# the grain model (rule voxelize_grains); segment then reads results/{scene}/voxelize_grains/grey_a{a}.h5 instead of
# results/{scene}/voxelize/grey_a{a}.h5 (porepipe.scene.grey_stage).


rule decorate:
    input:
        stamp=scene_stamp("decorate"),
        packing=packing_input,
    output:
        "results/{scene}/decorate/grains.h5",
    log:
        "results/{scene}/logs/decorate.log",
    benchmark:
        "results/{scene}/cost/decorate.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: every_core(8)
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=4000,
        runtime=60,
    params:
        scene=scene_file,
        packing=packing_arg,
    shell:
        "porepipe decorate {params.scene:q} -o {output:q} {params.packing} --threads {threads} > {log:q} 2>&1"


rule voxelize_grains:
    input:
        stamp=scene_stamp("voxelize_grains"),
        grains="results/{scene}/decorate/grains.h5",
    output:
        "results/{scene}/voxelize_grains/grey_a{a}.h5",
    log:
        "results/{scene}/logs/voxelize_grains_a{a}.log",
    benchmark:
        "results/{scene}/cost/voxelize_grains_a{a}.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: 4
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=mem_mb(bytes_per_voxel=8),
        runtime=120,
    params:
        scene=scene_file,
    shell:
        "porepipe voxelize-grains {params.scene:q} --grains {input.grains:q} --a {wildcards.a} -o {output:q}"
        " --threads {threads} > {log:q} 2>&1"
