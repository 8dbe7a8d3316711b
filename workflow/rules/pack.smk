rule pack:
    input:
        scene=scene_file,
    output:
        packing="results/{scene}/pack/packing.h5",
        xyzr="results/{scene}/pack/packing.xyzr",
    log:
        "results/{scene}/logs/pack.log",
    benchmark:
        "results/{scene}/cost/pack.tsv"
    params:
        checkpoint="results/{scene}/pack/checkpoint.h5",
    threads: workflow.cores
    shell:
        "porepipe pack {input.scene} -o {output.packing} --xyzr {output.xyzr}"
        " --checkpoint {params.checkpoint} --resume --threads {threads} > {log} 2>&1"
