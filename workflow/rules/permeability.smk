# Lattice-Boltzmann permeability (thesis ch. 6): one job per resolution and flow axis; a run that hits its step limit
# leaves its checkpoint beside the result, and the rerun resumes from it.


rule permeability:
    input:
        unpack(permeability_inputs),
    output:
        "results/{scene}/permeability/perm_a{a}_{axis}.h5",
    log:
        "results/{scene}/logs/permeability_a{a}_{axis}.log",
    benchmark:
        "results/{scene}/cost/permeability_a{a}_{axis}.tsv"
    wildcard_constraints:
        axis="[xyz]",
    conda:
        "../envs/porepipe.yaml"
    threads: every_core(8)
    resources:
        cpus_per_task=cpus_per_task,
        # 19 populations x 2 copies in float64 per node, plus the fields and the index arrays
        mem_mb=mem_mb(bytes_per_voxel=400, base_mb=1000),
        runtime=720,
        # the MPI hook (issue 23 part 3): `--config permeability_tasks=P` asks Slurm for P ranks (--ntasks) and sets
        # `mpi`, the launcher the command runs the solver under; one process (the default) has neither
        tasks=permeability_tasks,
        mpi=permeability_mpi,
    params:
        grey=permeability_grey_arg,
    shell:
        "porepipe permeability {input.binary:q} {params.grey} --scene {input.scene:q} --axis {wildcards.axis}"
        " -o {output:q} --resume --threads {threads} > {log:q} 2>&1"


ANALYSIS_TARGETS["permeability"] = lambda scene: [
    results(scene, "permeability", f"perm_a{res_tag(a)}_{axis}.h5")
    for axis in permeability_axes(scene)
    for a in permeability_resolutions(scene)
]
