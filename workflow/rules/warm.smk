# Kernel warm-up (porepipe.warm): on a local run whose numba cache does not yet hold a stage's kernels for this scene,
# one job per stage compiles them on a small twin of the scene, beside the pack job's single thread, before the
# stage's own jobs start (they take warm_input's marker); voxelize's first, the others after it (their twins
# voxelise too). A run with the kernels cached, or on a cluster, plans none of these jobs.


rule warm:
    input:
        scene=scene_file,
        before=warm_before,
    output:
        temp("results/{scene}/warm/{stage}.done"),
    log:
        "results/{scene}/logs/warm_{stage}.log",
    benchmark:
        "results/{scene}/cost/warm_{stage}.tsv"
    wildcard_constraints:
        stage="|".join(WARM_STAGES),
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=1500,
        runtime=15,
    shell:
        "porepipe warm {wildcards.stage} --scene {input.scene:q} -o {output:q} > {log:q} 2>&1"
