# Resolution and sample-size sweep (thesis §4.6.1, §7.4): corner sub-samples of the binary volumes (rule subsample),
# and the gather of every result of the scene's analyses into one sweep.h5 (quantity x resolution x sample size, with
# costs and the extrapolation a -> 0).


rule subsample:
    input:
        whole_binary_volume,
    output:
        "results/{scene}/subsample/binary_a{a}_L{L}.h5",
    log:
        "results/{scene}/logs/subsample_a{a}_L{L}.log",
    benchmark:
        "results/{scene}/cost/subsample_a{a}_L{L}.tsv"
    wildcard_constraints:
        L=NUMBER_RE,
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        mem_mb=mem_mb(bytes_per_voxel=1),
        runtime=10,
    shell:
        "porepipe subsample {input:q} --edge-um {wildcards.L} -o {output:q} > {log:q} 2>&1"


rule sweep:
    input:
        results=sweep_results,
        volumes=sweep_volumes,
        scene=scene_file,
    output:
        "results/{scene}/sweep/sweep.h5",
    log:
        "results/{scene}/logs/sweep.log",
    benchmark:
        "results/{scene}/cost/sweep.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        cost_dir=lambda wildcards: f"results/{wildcards.scene}/cost",
    shell:
        "porepipe sweep {input.results:q} --volumes {input.volumes:q} --scene {input.scene:q}"
        " --cost-dir {params.cost_dir:q} -o {output:q} > {log:q} 2>&1"
