# Knudsen diffusion in the voxel pore space (Mahler 2001, ch. 2-3): one job per resolution and transport axis.


def diffusion_axes(scene):
    return [axis.value for axis in scene.diffusion.axes]


def diffusion_resolutions(scene):
    chosen = scene.diffusion.resolutions_um or scene.resolutions_um
    unknown = sorted(set(chosen) - set(scene.resolutions_um))
    if unknown:
        raise ValueError(
            f"scene {scene.name!r}: diffusion.resolutions_um = {unknown} are not among resolutions_um = "
            f"{scene.resolutions_um}"
        )
    return chosen


rule diffusion:
    input:
        binary="results/{scene}/segment/binary_a{a}.h5",
        scene=scene_file,
    output:
        "results/{scene}/diffusion/diffusion_a{a}_{axis}.h5",
    log:
        "results/{scene}/logs/diffusion_a{a}_{axis}.log",
    benchmark:
        "results/{scene}/cost/diffusion_a{a}_{axis}.tsv"
    wildcard_constraints:
        axis="[xyz]",
    threads: workflow.cores
    shell:
        "porepipe diffusion {input.binary:q} --scene {input.scene:q} --axis {wildcards.axis} -o {output:q}"
        " --threads {threads} > {log:q} 2>&1"


ANALYSIS_TARGETS["diffusion"] = lambda scene: [
    results(scene, "diffusion", f"diffusion_a{res_tag(a)}_{axis}.h5")
    for axis in diffusion_axes(scene)
    for a in diffusion_resolutions(scene)
]
