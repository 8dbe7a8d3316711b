# Lattice-Boltzmann permeability (thesis ch. 6): one job per resolution and flow axis.


def permeability_axes(scene):
    return [axis.value for axis in scene.permeability.axes]


rule permeability:
    input:
        binary="results/{scene}/segment/binary_a{a}.h5",
        scene=scene_file,
    output:
        "results/{scene}/permeability/perm_a{a}_{axis}.h5",
    log:
        "results/{scene}/logs/permeability_a{a}_{axis}.log",
    benchmark:
        "results/{scene}/cost/permeability_a{a}_{axis}.tsv"
    wildcard_constraints:
        axis="[xyz]",
    threads: workflow.cores
    shell:
        "porepipe permeability {input.binary} --scene {input.scene} --axis {wildcards.axis} -o {output}"
        " --threads {threads} > {log} 2>&1"


ANALYSIS_TARGETS["permeability"] = lambda scene: [
    path
    for axis in permeability_axes(scene)
    for path in per_resolution(scene, "permeability/perm_a{a}_" + axis + ".h5")
]
