# Knudsen diffusion in the voxel pore space (Mahler 2001, ch. 2-3): one job per resolution and transport axis.
# A scene with diffusion.geometry gets its binary volumes from rule capillary (a synthetic capillary per resolution).
# Transmission, Wicke-Kallenbach and msd runs checkpoint after each round beside the result
# (.diffusion_a{a}_{axis}.h5.checkpoint.npz), and a rerun of a killed job resumes from it (a checkpoint of another
# input, seed or settings is discarded).


rule diffusion:
    input:
        binary=binary_volume,
        stamp=scene_stamp("diffusion"),
    output:
        "results/{scene}/diffusion/diffusion_a{a}_{axis}.h5",
    log:
        "results/{scene}/logs/diffusion_a{a}_{axis}.log",
    benchmark:
        "results/{scene}/cost/diffusion_a{a}_{axis}.tsv"
    wildcard_constraints:
        axis="[xyz]",
    conda:
        "../envs/porepipe.yaml"
    threads: every_core(8)
    resources:
        cpus_per_task=cpus_per_task,
        # the 1-byte input and the 1-byte distance geometry (in-place flood fill: 1.01 B/voxel beyond the input,
        # measured at 320^3 by benchmarks/diffusion_memory.py), plus slack
        mem_mb=mem_mb(bytes_per_voxel=3, base_mb=1000),
        runtime=240,
    params:
        scene=scene_file,
    shell:
        "porepipe diffusion {input.binary:q} --scene {params.scene:q} --axis {wildcards.axis} -o {output:q}"
        " --threads {threads} --resume > {log:q} 2>&1"


rule capillary:
    input:
        stamp=scene_stamp("capillary"),
    output:
        "results/{scene}/capillary/binary_a{a}.h5",
    log:
        "results/{scene}/logs/capillary_a{a}.log",
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=mem_mb(bytes_per_voxel=2),
        runtime=10,
    params:
        scene=scene_file,
    shell:
        "porepipe diffusion-capillary --scene {params.scene:q} --a {wildcards.a} -o {output:q} > {log:q} 2>&1"


ANALYSIS_TARGETS["diffusion"] = lambda scene: [
    results(scene, "diffusion", f"diffusion_a{res_tag(a)}_{axis}.h5")
    for axis in diffusion_axes(scene)
    for a in diffusion_resolutions(scene)
]
