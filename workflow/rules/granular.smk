# 2-D frictional DEM of convex polygons (gc2d, Schinner 2001): the scene's `granular:` section in,
# frames of particle state, contact forces and time series out.


rule granular:
    input:
        scene=scene_file,
    output:
        "results/{scene}/granular/granular.h5",
    log:
        "results/{scene}/logs/granular.log",
    benchmark:
        "results/{scene}/cost/granular.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: every_core(4)
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=2000,
        runtime=240,
    params:
        checkpoint="results/{scene}/granular/checkpoint.npz",
    shell:
        "porepipe granular {input.scene:q} -o {output:q} --checkpoint {params.checkpoint:q} --resume"
        " --threads {threads} > {log:q} 2>&1"


ANALYSIS_TARGETS["granular"] = lambda scene: [results(scene, "granular", "granular.h5")]
