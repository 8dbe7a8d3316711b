# The accuracy-versus-cost report (HTML + PNG): the workflow's final target when a scene lists `report`.


def report_inputs(wildcards):
    scene = scene_of(wildcards)
    names = {a.value for a in scene.analyses}
    inputs = {
        "sweep": f"results/{scene.name}/sweep/sweep.h5",
        "scene": scene_file(wildcards),
        "grey": grey_volumes(scene) if scene.report.slices else [],
        "binary": [],
        "lpt": per_resolution(scene, "lpt/lpt_a{a}.h5") if "lpt" in names else [],
    }
    if scene.report.slices and names - {"report", "estimate"}:
        inputs["binary"] = per_resolution(scene, "segment/binary_a{a}.h5")
    return inputs


rule report:
    input:
        unpack(report_inputs),
    output:
        "results/{scene}/report/index.html",
    log:
        "results/{scene}/logs/report.log",
    benchmark:
        "results/{scene}/cost/report.tsv"
    shell:
        "porepipe report {input.scene} --sweep {input.sweep} --grey {input.grey} --binary {input.binary}"
        " --lpt {input.lpt} -o {output} > {log} 2>&1"


ANALYSIS_TARGETS["report"] = lambda scene: [results(scene, "report", "index.html")]
