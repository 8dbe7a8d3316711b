# The accuracy-versus-cost report (HTML + PNG): the workflow's final target when a scene lists `report`.


rule report:
    input:
        unpack(report_inputs),
    output:
        "results/{scene}/report/index.html",
    log:
        "results/{scene}/logs/report.log",
    benchmark:
        "results/{scene}/cost/report.tsv"
    conda:
        "../envs/porepipe.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    shell:
        "porepipe report {input.scene:q} --sweep {input.sweep:q} --grey {input.grey:q} --binary {input.binary:q}"
        " --lpt {input.lpt:q} -o {output:q} > {log:q} 2>&1"


ANALYSIS_TARGETS["report"] = lambda scene: [results(scene, "report", "index.html")]
