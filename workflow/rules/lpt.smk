# Local porosity theory (thesis §4.6): one lpt_a{a}.h5 per resolution (the resolution sweep), and one
# lpt_a{a}_L{L}.h5 per corner sub-sample of the scene's sweep.sample_um (the sample-size sweep, §4.6.1), from the
# binary_a{a}_L{L}.h5 files of rule subsample; cell sizes larger than a sub-sample are left out (stated in the file).


rule lpt:
    input:
        binary="results/{scene}/segment/binary_a{a}.h5",
        scene=scene_file,
    output:
        "results/{scene}/lpt/lpt_a{a}.h5",
    log:
        "results/{scene}/logs/lpt_a{a}.log",
    benchmark:
        "results/{scene}/cost/lpt_a{a}.tsv"
    threads: workflow.cores
    shell:
        "porepipe lpt {input.binary} --scene {input.scene} -o {output} --threads {threads} > {log} 2>&1"


rule lpt_subsample:
    input:
        binary="results/{scene}/segment/binary_a{a}_L{L}.h5",
        scene=scene_file,
    output:
        "results/{scene}/lpt/lpt_a{a}_L{L}.h5",
    log:
        "results/{scene}/logs/lpt_a{a}_L{L}.log",
    benchmark:
        "results/{scene}/cost/lpt_a{a}_L{L}.tsv"
    wildcard_constraints:
        L=r"[0-9]+(\.[0-9]+)?",
    threads: workflow.cores
    shell:
        "porepipe lpt {input.binary} --scene {input.scene} -o {output} --threads {threads} > {log} 2>&1"


ANALYSIS_TARGETS["lpt"] = lambda scene: per_resolution(scene, "lpt/lpt_a{a}.h5")
SUBSAMPLE_TARGETS["lpt"] = lambda scene, edge: per_subsample(scene, "lpt/lpt_a{a}_L{L}.h5", edge)
