# Resolution and sample-size sweep (thesis §4.6.1, §7.4): corner sub-samples of the binary volumes, and the gather
# of every result of the scene's analyses into one sweep.h5 (quantity x resolution x sample size, with costs and
# the extrapolation a -> 0).

#: analyses whose outputs are not measurements to gather
SWEEP_SKIP = {"report", "segment"}


def sweep_results(scene):
    out = []
    for analysis in scene.analyses:
        if analysis.value in SWEEP_SKIP or analysis.value not in ANALYSIS_TARGETS:
            continue
        out += ANALYSIS_TARGETS[analysis.value](scene)
        for edge in scene.sweep.sample_um:
            out += SUBSAMPLE_TARGETS.get(analysis.value, lambda scene, edge: [])(scene, edge)
    return out or ANALYSIS_TARGETS["estimate"](scene)


def sweep_volumes(scene):
    """Grey and binary volumes behind the results (their cost is the upstream cost of every run)."""
    out = grey_volumes(scene)
    measured = {a.value for a in scene.analyses} - SWEEP_SKIP - {"estimate"}
    if measured or any(a.value == "segment" for a in scene.analyses):
        out += per_resolution(scene, "segment/binary_a{a}.h5")
    if any(a in SUBSAMPLE_TARGETS for a in measured):
        for edge in scene.sweep.sample_um:
            out += per_resolution(scene, "segment/binary_a{a}_L" + res_tag(edge) + ".h5")
    return out


rule subsample:
    input:
        "results/{scene}/segment/binary_a{a}.h5",
    output:
        "results/{scene}/segment/binary_a{a}_L{L}.h5",
    log:
        "results/{scene}/logs/subsample_a{a}_L{L}.log",
    benchmark:
        "results/{scene}/cost/subsample_a{a}_L{L}.tsv"
    wildcard_constraints:
        L=r"[0-9]+(\.[0-9]+)?",
    shell:
        "porepipe subsample {input} --edge-um {wildcards.L} -o {output} > {log} 2>&1"


rule sweep:
    input:
        results=lambda wildcards: sweep_results(scene_of(wildcards)),
        volumes=lambda wildcards: sweep_volumes(scene_of(wildcards)),
        scene=scene_file,
    output:
        "results/{scene}/sweep/sweep.h5",
    log:
        "results/{scene}/logs/sweep.log",
    benchmark:
        "results/{scene}/cost/sweep.tsv"
    params:
        cost_dir=lambda wildcards: f"results/{wildcards.scene}/cost",
    shell:
        "porepipe sweep {input.results} --volumes {input.volumes} --scene {input.scene}"
        " --cost-dir {params.cost_dir} -o {output} > {log} 2>&1"
