def packing_input(wildcards):
    scene = scene_of(wildcards)
    return [results(scene, "pack", "packing.h5")] if scene.spheres.pack else []


rule voxelize:
    input:
        scene=scene_file,
        packing=packing_input,
    output:
        "results/{scene}/voxelize/grey_a{a}.h5",
    log:
        "results/{scene}/logs/voxelize_a{a}.log",
    benchmark:
        "results/{scene}/cost/voxelize_a{a}.tsv"
    params:
        packing=lambda wildcards, input: f"--packing {input.packing}" if input.packing else "",
    threads: workflow.cores
    shell:
        "porepipe voxelize {input.scene} --a {wildcards.a} -o {output} {params.packing}"
        " --threads {threads} > {log} 2>&1"
