# 2-D frictional DEM of convex polygons (gc2d, Schinner 2001): the scene's `granular:` section in,
# frames of particle state, contact forces and time series out.


rule granular:
    input:
        stamp=scene_stamp("granular"),
    output:
        "results/{scene}/granular/granular.h5",
    log:
        "results/{scene}/logs/granular.log",
    benchmark:
        "results/{scene}/cost/granular.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: every_core(4)
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=2000,
        runtime=240,
    params:
        scene=scene_file,
        checkpoint="results/{scene}/granular/checkpoint.npz",
    shell:
        "porepipe granular {params.scene:q} -o {output:q} --checkpoint {params.checkpoint:q} --resume"
        " --threads {threads} > {log:q} 2>&1"


# the report page of a granular scene (`report` in its analyses): silo or heap read-out, figures and CSVs beside it
rule granular_report:
    input:
        stamp=scene_stamp("granular_report"),
        granular="results/{scene}/granular/granular.h5",
    output:
        page=report(
            "results/{scene}/report/index.html",
            caption="../report/granular.rst",
            category="Report",
        ),
    log:
        "results/{scene}/logs/report.log",
    benchmark:
        "results/{scene}/cost/report.tsv"
    wildcard_constraints:
        scene=GRANULAR_SCENE_RE,
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        cpus_per_task=cpus_per_task,
        mem_mb=2000,
        runtime=10,
    params:
        scene=scene_file,
    shell:
        "porepipe report {params.scene:q} --granular {input.granular:q} -o {output.page:q} > {log:q} 2>&1"


ANALYSIS_TARGETS["granular"] = lambda scene: [results(scene, "granular", "granular.h5")]
