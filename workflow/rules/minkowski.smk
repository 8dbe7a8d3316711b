# Minkowski functionals (thesis §4.5): φ, S_V, K_V, T_V, χ of pore and matrix of each segmented volume, from one
# pass over its 2x2x2 configuration histogram; with minkowski.threshold_functions also of the grey volume at every
# threshold g_th (group "threshold" of the same file).


def minkowski_inputs(wildcards):
    inputs = {
        "binary": f"results/{wildcards.scene}/segment/binary_a{wildcards.a}.h5",
        "scene": scene_file(wildcards),
    }
    if scene_of(wildcards).minkowski.threshold_functions:
        inputs["grey"] = grey_volume(wildcards)
    return inputs


def minkowski_grey_arg(wildcards, input):
    return f"--grey {input.grey}" if "grey" in input.keys() else ""


rule minkowski:
    input:
        unpack(minkowski_inputs),
    output:
        "results/{scene}/minkowski/minkowski_a{a}.h5",
    log:
        "results/{scene}/logs/minkowski_a{a}.log",
    benchmark:
        "results/{scene}/cost/minkowski_a{a}.tsv"
    params:
        grey=minkowski_grey_arg,
    threads: workflow.cores
    shell:
        "porepipe minkowski {input.binary} --scene {input.scene} {params.grey} -o {output}"
        " --threads {threads} > {log} 2>&1"


ANALYSIS_TARGETS["minkowski"] = lambda scene: per_resolution(scene, "minkowski/minkowski_a{a}.h5")


rule minkowski_subsample:
    input:
        binary="results/{scene}/segment/binary_a{a}_L{L}.h5",
        scene=scene_file,
    output:
        "results/{scene}/minkowski/minkowski_a{a}_L{L}.h5",
    log:
        "results/{scene}/logs/minkowski_a{a}_L{L}.log",
    benchmark:
        "results/{scene}/cost/minkowski_a{a}_L{L}.tsv"
    wildcard_constraints:
        L=r"[0-9]+(\.[0-9]+)?",
    threads: workflow.cores
    shell:
        "porepipe minkowski {input.binary} --scene {input.scene} -o {output} --threads {threads} > {log} 2>&1"


SUBSAMPLE_TARGETS["minkowski"] = lambda scene, edge: per_subsample(
    scene, "minkowski/minkowski_a{a}_L{L}.h5", edge
)
