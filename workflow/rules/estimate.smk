rule estimate:
    input:
        lambda wildcards: grey_volumes(scene_of(wildcards)),
    output:
        "results/{scene}/estimate/estimate.h5",
    log:
        "results/{scene}/logs/estimate.log",
    benchmark:
        "results/{scene}/cost/estimate.tsv"
    shell:
        "porepipe estimate {input} -o {output} > {log} 2>&1"


ANALYSIS_TARGETS["estimate"] = lambda scene: [results(scene, "estimate", "estimate.h5")]
