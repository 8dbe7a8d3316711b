# DEM packing (thesis ch. 5): the scene's staged protocol -> packing.h5 (+ xyzr); it checkpoints and resumes.


rule pack:
    input:
        stamp=scene_stamp("pack"),
    output:
        packing="results/{scene}/pack/packing.h5",
        xyzr="results/{scene}/pack/packing.xyzr",
    log:
        "results/{scene}/logs/pack.log",
    benchmark:
        "results/{scene}/cost/pack.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: pack_threads
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=4000,
        runtime=240,
    params:
        scene=scene_file,
        checkpoint="results/{scene}/pack/checkpoint.h5",
    shell:
        "porepipe pack {params.scene:q} -o {output.packing:q} --xyzr {output.xyzr:q}"
        " --checkpoint {params.checkpoint:q} --resume --threads {threads} > {log:q} 2>&1"
