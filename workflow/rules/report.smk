# The accuracy-versus-cost report (HTML + PNG): the workflow's final target when a scene lists `report`. A 2-D
# granular scene has no sweep: its report page comes from rule granular_report (granular.smk), same path.


rule report:
    input:
        unpack(report_inputs),
    output:
        page=report(
            "results/{scene}/report/index.html",
            caption="../report/page.rst",
            category="Report",
        ),
        error_cost=report(
            "results/{scene}/report/error_cost.png",
            caption="../report/error_cost.rst",
            category="Accuracy against cost",
        ),
        quantities=report(
            "results/{scene}/report/quantities.png",
            caption="../report/quantities.rst",
            category="Accuracy against cost",
        ),
        limits=report(
            "results/{scene}/report/limits.csv",
            caption="../report/limits.rst",
            category="Accuracy against cost",
        ),
    log:
        "results/{scene}/logs/report.log",
    benchmark:
        "results/{scene}/cost/report.tsv"
    wildcard_constraints:
        scene=NOT_GRANULAR_SCENE_RE,
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
        "porepipe report {params.scene:q} --sweep {input.sweep:q} --grey {input.grey:q} --binary {input.binary:q}"
        " --lpt {input.lpt:q} -o {output.page:q} > {log:q} 2>&1"


ANALYSIS_TARGETS["report"] = lambda scene: [results(scene, "report", "index.html")]
