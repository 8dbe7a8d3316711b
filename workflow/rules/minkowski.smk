# Minkowski functionals (thesis §4.5): φ, S_V, K_V, T_V, χ of pore and matrix of each segmented volume (whole, or with
# wildcard sub = "_L{L}" a corner sub-sample), from one pass over its 2x2x2 configuration histogram; with
# minkowski.threshold_functions also of the grey volume at every threshold g_th (group "threshold" of the same file).


rule minkowski:
    input:
        unpack(minkowski_inputs),
        warm=warm_input("minkowski", "results/{scene}/minkowski/minkowski_a{a}{sub}.h5"),
    output:
        "results/{scene}/minkowski/minkowski_a{a}{sub}.h5",
    log:
        "results/{scene}/logs/minkowski_a{a}{sub}.log",
    benchmark:
        "results/{scene}/cost/minkowski_a{a}{sub}.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=1000,
        runtime=30,
    params:
        scene=scene_file,
        grey=minkowski_grey_arg,
    shell:
        "porepipe minkowski {input.binary:q} --scene {params.scene:q} {params.grey} -o {output:q}"
        " --threads {threads} > {log:q} 2>&1"


ANALYSIS_TARGETS["minkowski"] = lambda scene: per_resolution(scene, "minkowski/minkowski_a{a}.h5")
SUBSAMPLE_TARGETS["minkowski"] = lambda scene, edge: per_subsample(
    scene, "minkowski/minkowski_a{a}_L{L}.h5", edge
)
