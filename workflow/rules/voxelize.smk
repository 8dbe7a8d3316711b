# Grey-value voxelisation (thesis §4.7.2): the grey volume 0..216 of the scene's spheres at every resolution.


rule voxelize:
    input:
        stamp=scene_stamp("voxelize"),
        packing=packing_input,
        warm=warm_input("voxelize", "results/{scene}/voxelize/grey_a{a}.h5"),
    output:
        "results/{scene}/voxelize/grey_a{a}.h5",
    log:
        "results/{scene}/logs/voxelize_a{a}.log",
    benchmark:
        "results/{scene}/cost/voxelize_a{a}.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: threads_by_volume(4, voxels_per_thread=2**20)
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=mem_mb(bytes_per_voxel=4),
        runtime=60,
    params:
        scene=scene_file,
        packing=packing_arg,
    shell:
        "porepipe voxelize {params.scene:q} --a {wildcards.a} -o {output:q} {params.packing}"
        " --threads {threads} > {log:q} 2>&1"
