# Local porosity theory (thesis §4.6): one lpt_a{a}.h5 per resolution (the resolution sweep), and one lpt_a{a}_L{L}.h5
# per corner sub-sample of the scene's sweep.sample_um (the sample-size sweep, §4.6.1, wildcard sub = "_L{L}"), from
# the files of rule subsample; cell sizes larger than a sub-sample are left out (stated in the file).


rule lpt:
    input:
        binary=binary_volume,
        stamp=scene_stamp("lpt"),
        warm=warm_input("lpt", "results/{scene}/lpt/lpt_a{a}{sub}.h5"),
    output:
        "results/{scene}/lpt/lpt_a{a}{sub}.h5",
    log:
        "results/{scene}/logs/lpt_a{a}{sub}.log",
    benchmark:
        "results/{scene}/cost/lpt_a{a}{sub}.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: threads_by_volume(2, voxels_per_thread=2**20)
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=mem_mb(bytes_per_voxel=24),
        runtime=60,
    params:
        scene=scene_file,
    shell:
        "porepipe lpt {input.binary:q} --scene {params.scene:q} -o {output:q} --threads {threads} > {log:q} 2>&1"


ANALYSIS_TARGETS["lpt"] = lambda scene: per_resolution(scene, "lpt/lpt_a{a}.h5")
SUBSAMPLE_TARGETS["lpt"] = lambda scene, edge: per_subsample(scene, "lpt/lpt_a{a}_L{L}.h5", edge)
