# Local porosity theory (thesis §4.6): one lpt_a{a}.h5 per resolution (the resolution sweep), and for each edge in
# the scene's lpt.rev_sample_um one lpt_a{a}_s{s}.h5 of the corner sub-cube of that edge (the sample-size sweep).


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


rule lpt_rev:
    input:
        binary="results/{scene}/segment/binary_a{a}.h5",
        scene=scene_file,
    output:
        "results/{scene}/lpt/lpt_a{a}_s{s}.h5",
    log:
        "results/{scene}/logs/lpt_a{a}_s{s}.log",
    benchmark:
        "results/{scene}/cost/lpt_a{a}_s{s}.tsv"
    wildcard_constraints:
        s=r"[0-9]+(\.[0-9]+)?",
    threads: workflow.cores
    shell:
        "porepipe lpt {input.binary} --scene {input.scene} -o {output} --subsample-um {wildcards.s}"
        " --threads {threads} > {log} 2>&1"


def lpt_targets(scene):
    out = per_resolution(scene, "lpt/lpt_a{a}.h5")
    for s in scene.lpt.rev_sample_um:
        out += per_resolution(scene, "lpt/lpt_a{a}_s" + res_tag(s) + ".h5")
    return out


ANALYSIS_TARGETS["lpt"] = lpt_targets
