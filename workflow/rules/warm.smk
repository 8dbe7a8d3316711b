# Kernel warm-up (porepipe.warm): on a local run whose numba cache does not yet hold a stage's kernels for this scene,
# one job per stage compiles them on a small twin of the scene, beside the pack job's single thread, before the
# stage's own jobs start (they take warm_input's marker); voxelize's first, the others after it (their twins
# voxelise too). A job is named by its twin key (porepipe.warm.twin_key), so scenes with the same twins (a model
# and its variant) share it. A run with the kernels cached, or on a cluster, plans none of these jobs.


rule warm:
    input:
        scene=warm_scene_file,
        before=warm_before,
    output:
        temp("results/_warm/{twin}/{stage}.done"),
    log:
        "results/_warm/{twin}/{stage}.log",
    benchmark:
        "results/_warm/{twin}/{stage}_cost.tsv"
    wildcard_constraints:
        twin="[0-9a-f]{20}",
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
