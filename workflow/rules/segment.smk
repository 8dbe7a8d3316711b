# Segmentation (thesis §4.7.2): pore if grey <= g_th (Otsu or fixed), one binary volume per resolution.


rule segment:
    input:
        grey_volume,
    output:
        "results/{scene}/segment/binary_a{a}.h5",
    log:
        "results/{scene}/logs/segment_a{a}.log",
    benchmark:
        "results/{scene}/cost/segment_a{a}.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=1000,
        runtime=10,
    params:
        method=segmentation_args,
    shell:
        "porepipe segment {input:q} -o {output:q} {params.method} > {log:q} 2>&1"


ANALYSIS_TARGETS["segment"] = lambda scene: binary_volumes(scene)
