# Grain decoration (thesis §4.7.1 step 3): grains.h5 for scenes with a `decoration:` section, and the grey volumes
# of the grain model. The segment rule reads results/{scene}/decorate/grey_a{a}.h5 instead of
# results/{scene}/voxelize/grey_a{a}.h5 when the scene has `decoration`.


def decorate_packing_input(wildcards):
    scene = scene_of(wildcards)
    return [results(scene, "pack", "packing.h5")] if scene.spheres.pack else []


rule decorate:
    input:
        scene=scene_file,
        packing=decorate_packing_input,
    output:
        "results/{scene}/decorate/grains.h5",
    log:
        "results/{scene}/logs/decorate.log",
    benchmark:
        "results/{scene}/cost/decorate.tsv"
    params:
        packing=lambda wildcards, input: f"--packing {input.packing}" if input.packing else "",
    threads: workflow.cores
    shell:
        "porepipe decorate {input.scene} -o {output} {params.packing} --threads {threads} > {log} 2>&1"


rule voxelize_grains:
    input:
        scene=scene_file,
        grains="results/{scene}/decorate/grains.h5",
    output:
        "results/{scene}/decorate/grey_a{a}.h5",
    log:
        "results/{scene}/logs/voxelize_grains_a{a}.log",
    benchmark:
        "results/{scene}/cost/voxelize_grains_a{a}.tsv"
    threads: workflow.cores
    shell:
        "porepipe voxelize-grains {input.scene} --grains {input.grains} --a {wildcards.a} -o {output}"
        " --threads {threads} > {log} 2>&1"
