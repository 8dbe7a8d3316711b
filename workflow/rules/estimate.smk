# Grey-value estimators (thesis §7.2, §7.3): porosity and specific-surface bounds over all resolutions.


rule estimate:
    input:
        lambda wildcards: grey_volumes(scene_of(wildcards)),
    output:
        "results/{scene}/estimate/estimate.h5",
    log:
        "results/{scene}/logs/estimate.log",
    benchmark:
        "results/{scene}/cost/estimate.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=1000,
        runtime=5,
    shell:
        "porepipe estimate {input:q} -o {output:q} > {log:q} 2>&1"


ANALYSIS_TARGETS["estimate"] = lambda scene: [results(scene, "estimate", "estimate.h5")]
