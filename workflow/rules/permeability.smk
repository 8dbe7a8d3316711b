# Lattice-Boltzmann permeability (thesis ch. 6): one job per resolution and flow axis, on the whole volume or (wildcard
# sub = "_L{L}" or "_L{L}_k{i}") a sub-sample of sweep.sample_um; a run that hits its step limit leaves its
# checkpoint beside the result, and the rerun resumes from it.


rule permeability:
    input:
        unpack(permeability_inputs),
        warm=warm_input("permeability", "results/{scene}/permeability/perm_a{a}{sub}_{axis}.h5"),
    output:
        "results/{scene}/permeability/perm_a{a}{sub}_{axis}.h5",
    log:
        "results/{scene}/logs/permeability_a{a}{sub}_{axis}.log",
    benchmark:
        "results/{scene}/cost/permeability_a{a}{sub}_{axis}.tsv"
    wildcard_constraints:
        axis="[xyz]",
    conda:
        "../envs/porepipe.yaml"
    threads: permeability_threads  # below: 1-2 parallel chunks of nodes; an MPI job: at least a core per rank
    resources:
        cpus_per_task=permeability_cpus_per_task,  # per MPI rank
        # 19 populations x 2 copies in float64 per node, plus the fields and the index arrays
        mem_mb=mem_mb(bytes_per_voxel=400, base_mb=1000),
        runtime=720,
        tasks=permeability_ranks,  # MPI ranks (permeability.mpi_ranks; 1: one process)
        mpi=permeability_mpi,  # the MPI launcher; none for a one-process job
    params:
        scene=scene_file,
        grey=permeability_grey_arg,
        launch=permeability_launch,
        ranks=permeability_rank_args,
    shell:
        "{params.launch} porepipe permeability {input.binary:q} {params.grey} --scene {params.scene:q}"
        " --axis {wildcards.axis} -o {output:q} --resume {params.ranks} > {log:q} 2>&1"


ANALYSIS_TARGETS["permeability"] = lambda scene: [
    results(scene, "permeability", f"perm_a{res_tag(a)}_{axis}.h5")
    for axis in permeability_axes(scene)
    for a in permeability_resolutions(scene)
    if scene.permeability.whole_volume
]
SUBSAMPLE_TARGETS["permeability"] = lambda scene, edge: [
    results(scene, "permeability", f"perm_a{res_tag(a)}_L{tag}_{axis}.h5")
    for axis in permeability_axes(scene)
    for a in permeability_resolutions(scene)
    for tag in subsample_tags(scene, edge)
]
