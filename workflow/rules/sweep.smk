# Resolution and sample-size sweep (thesis §4.6.1, §7.4): sub-samples of the binary volumes (rule subsample: the origin
# corner, or with sweep.subsamples = 8 / 64 cube k of a 2³ / 4³ grid, wildcard k = "_k<i>"),
# and the gather of every result of the scene's analyses into one sweep.h5 (quantity x resolution x sample size, with
# costs and the extrapolation a -> 0).


rule subsample:
    input:
        whole_binary_volume,
    output:
        "results/{scene}/subsample/binary_a{a}_L{L}{k}.h5",
    log:
        "results/{scene}/logs/subsample_a{a}_L{L}{k}.log",
    benchmark:
        "results/{scene}/cost/subsample_a{a}_L{L}{k}.tsv"
    wildcard_constraints:
        L=NUMBER_RE,
        k=r"(_k[0-9]+)?",
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=mem_mb(bytes_per_voxel=1),
        runtime=10,
    params:
        cube=lambda w: f"--index {w.k[2:]} --count {scene_of(w).sweep.subsamples}" if w.k else "",
    shell:
        "porepipe subsample {input:q} --edge-um {wildcards.L} {params.cube} -o {output:q} > {log:q} 2>&1"


rule sweep:
    input:
        results=sweep_results,
        volumes=sweep_volumes,
        stamp=scene_stamp("sweep"),
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
        cpus_per_task=cpus_per_task,
        mem_mb=2000,
        runtime=10,
    params:
        scene=scene_file,
        cost_dir=lambda wildcards: f"results/{wildcards.scene}/cost",
    shell:
        "porepipe sweep {input.results:q} --volumes {input.volumes:q} --scene {params.scene:q}"
        " --cost-dir {params.cost_dir:q} -o {output:q} > {log:q} 2>&1"
