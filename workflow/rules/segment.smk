def segmentation_args(wildcards):
    seg = scene_of(wildcards).segmentation
    return f"--method {seg.method.value}" + (f" --threshold {seg.threshold}" if seg.threshold is not None else "")


rule segment:
    input:
        grey_volume,
    output:
        "results/{scene}/segment/binary_a{a}.h5",
    log:
        "results/{scene}/logs/segment_a{a}.log",
    benchmark:
        "results/{scene}/cost/segment_a{a}.tsv"
    params:
        method=segmentation_args,
    shell:
        "porepipe segment {input} -o {output} {params.method} > {log} 2>&1"


ANALYSIS_TARGETS["segment"] = lambda scene: per_resolution(scene, "segment/binary_a{a}.h5")
