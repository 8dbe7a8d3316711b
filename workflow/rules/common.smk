# Shared workflow code: load and validate the scenes (first thing, so a bad scene stops the run with every problem
# listed), the per-analysis target registries, file-name helpers, every input function of the rules, and the
# resources the rules declare.
import glob
import math
import re
import shlex
import sys
from pathlib import Path

from porepipe._shared.naming import TAG_RE, res_tag
from porepipe.diffusion import check_capillary_resolutions
from porepipe.scene import grey_stage, load_scene
from porepipe.scene_stamps import STAMP_FOLDER, write_stamp
from porepipe.warm import STAGES as WARM_STAGES
from porepipe.warm import marker_of, twin_key, warmable

# the `porepipe` command of the interpreter that runs Snakemake comes first on the jobs' PATH
shell.prefix(f'export PATH={shlex.quote(str(Path(sys.executable).parent))}:"$PATH"; ')

_scene_files = [config["scene"]] if config.get("scene") else config.get("scenes", [])
if not _scene_files:
    raise ValueError("no scene: give --config scene=PATH or list `scenes:` in config/config.yaml")
SCENES = {}
SCENE_FILES = {}
for _path in _scene_files:
    _path = str(Path(workflow.basedir, _path)) if not Path(_path).is_absolute() else _path
    _scene = load_scene(_path)
    SCENES[_scene.name] = _scene
    SCENE_FILES[_scene.name] = _path
# scenes whose sweeps a report reads for more thesis-table rows (report.thesis_rows_from): <name>.yaml beside it
for _name, _scene in list(SCENES.items()):
    for _other in getattr(getattr(_scene, "report", None), "thesis_rows_from", {}).values():
        if _other not in SCENES:
            _path = str(Path(SCENE_FILES[_name]).parent / f"{_other}.yaml")
            if not Path(_path).is_file():
                raise ValueError(
                    f"scene {_name!r}: report.thesis_rows_from names scene {_other!r}, but {_path} does not exist"
                )
            SCENES[_other] = load_scene(_path)
            SCENE_FILES[_other] = _path

#: a resolution or sub-sample edge in a file name: the repr-exact tag of porepipe._shared.naming.res_tag
NUMBER_RE = TAG_RE


wildcard_constraints:
    scene=r"[A-Za-z0-9][A-Za-z0-9_.-]*",
    a=NUMBER_RE,
    sub=rf"(_L{NUMBER_RE}(_k[0-9]+)?)?",


# -- names ------------------------------------------------------------------------------------------------------------
def results(scene, *parts):
    return str(Path("results", scene.name, *parts))


def per_resolution(scene, pattern):
    """`pattern` formatted with a = every resolution of the scene, e.g. 'segment/binary_a{a}.h5'."""
    return [results(scene, pattern.format(a=res_tag(a))) for a in scene.resolutions_um]


def subsample_tags(scene, edge_um):
    """The L part of the sub-sample names of edge `edge_um`: '<edge>' (origin corner) or '<edge>_k<i>' per cube."""
    count = scene.sweep.subsamples
    edge = res_tag(edge_um)
    return [edge] if count == 1 else [f"{edge}_k{i}" for i in range(count)]


def per_subsample(scene, pattern, edge_um):
    """`pattern` with a = every resolution and L = each sub-sample of edge L, e.g. 'minkowski/minkowski_a{a}_L{L}.h5'."""
    return [
        results(scene, pattern.format(a=res_tag(a), L=tag))
        for a in scene.resolutions_um
        for tag in subsample_tags(scene, edge_um)
    ]


def scene_of(wildcards):
    return SCENES[wildcards.scene]


def scene_file(wildcards):
    return SCENE_FILES[wildcards.scene]


#: (scene name, rule) -> the rule's scene stamp, written once per workflow run (porepipe.scene_stamps)
_scene_stamps = {}


def scene_stamp(rule):
    """An input function: `rule`'s stamp of the job's scene, its part of the scene in a file rewritten only where that
    part changed (porepipe.scene_stamps), so the rule reruns when what it reads of the scene changes, not when a
    comment does. The scene file itself goes in the rule's params.
    """

    def stamp(wildcards):
        key = (wildcards.scene, rule)
        if key not in _scene_stamps:
            folder = Path("results", wildcards.scene, STAMP_FOLDER)
            _scene_stamps[key] = write_stamp(SCENES[wildcards.scene], rule, folder)
        return _scene_stamps[key]

    return stamp


def is_acquire_scene(scene):
    return getattr(scene, "acquire", None) is not None


# a regex that matches exactly the acquire scenes (and nothing when there are none)
ACQUIRE_SCENE_RE = "|".join(re.escape(n) for n, s in SCENES.items() if is_acquire_scene(s)) or "(?!)"


def is_granular_scene(scene):
    return getattr(scene, "granular", None) is not None and "granular" in {a.value for a in scene.analyses}


# a regex that matches exactly the 2-D granular scenes (their report reads granular.h5, not a sweep), and one that
# matches every other scene name (the look-ahead ends at the name: a name character may not follow)
GRANULAR_SCENE_RE = "|".join(re.escape(n) for n, s in SCENES.items() if is_granular_scene(s)) or "(?!)"
NOT_GRANULAR_SCENE_RE = rf"(?!(?:{GRANULAR_SCENE_RE})(?![A-Za-z0-9_.-]))[A-Za-z0-9][A-Za-z0-9_.-]*"


# -- volumes ----------------------------------------------------------------------------------------------------------
def grey_volumes(scene):
    """The grey volume of every resolution of the scene."""
    return per_resolution(scene, f"{grey_stage(scene)}/grey_a{{a}}.h5")


def grey_volume(wildcards):
    """The grey volume of resolution wildcards.a."""
    scene = scene_of(wildcards)
    return results(scene, grey_stage(scene), f"grey_a{wildcards.a}.h5")


def binary_stage(scene):
    """Folder (= the writing rule) of the scene's whole binary volumes; the image's own, or the segmented model."""
    if getattr(scene.diffusion, "geometry", None) is not None:
        return "capillary"  # a synthetic capillary of diffusion.geometry (rule capillary)
    return "acquire_binary" if is_acquire_scene(scene) else "segment"


def binary_volumes(scene):
    """The whole binary volume of every resolution of the scene."""
    return per_resolution(scene, f"{binary_stage(scene)}/binary_a{{a}}.h5")


def subsample_volumes(scene, edge_um):
    """The sub-samples of edge `edge_um` of every resolution (rule subsample)."""
    return per_subsample(scene, "subsample/binary_a{a}_L{L}.h5", edge_um)


def binary_volume(wildcards):
    """Binary volume of resolution a: the whole one, or with wildcards.sub = '_L<edge>' the corner sub-sample."""
    scene = scene_of(wildcards)
    if getattr(wildcards, "sub", ""):
        return results(scene, "subsample", f"binary_a{wildcards.a}{wildcards.sub}.h5")
    return results(scene, binary_stage(scene), f"binary_a{wildcards.a}.h5")


def whole_binary_volume(wildcards):
    scene = scene_of(wildcards)
    return results(scene, binary_stage(scene), f"binary_a{wildcards.a}.h5")


def packing_input(wildcards):
    """packing.h5 of the pack rule when the scene's spheres come from it (voxelize, decorate)."""
    scene = scene_of(wildcards)
    return [results(scene, "pack", "packing.h5")] if scene.spheres.pack else []


def packing_arg(wildcards, input):
    return f"--packing {shlex.quote(input.packing[0])}" if input.packing else ""


# -- acquire ----------------------------------------------------------------------------------------------------------
def acquire_image(wildcards):
    """The image file(s) of an acquire scene, relative to the scene file (a TIFF directory/glob: every section)."""
    scene = scene_of(wildcards)
    path = Path(scene.acquire.image)
    path = path if path.is_absolute() else Path(scene_file(wildcards)).parent / path
    if path.is_dir():
        return sorted(str(p) for p in path.iterdir() if p.suffix.lower() in (".tif", ".tiff"))
    if any(c in str(path) for c in "*?["):
        return sorted(glob.glob(str(path)))
    return [str(path)]


def acquire_targets(scene):
    if not is_acquire_scene(scene):
        raise ValueError(f"scene {scene.name!r} lists analysis `acquire` but has no `acquire:` section")
    return [
        results(scene, "acquire", "statistics.h5"),
        results(scene, "acquire_compare", "comparison.h5"),
    ]


# -- segment, minkowski, permeability -------------------------------------------------------------------------------
def segmentation_args(wildcards):
    seg = scene_of(wildcards).segmentation
    threshold = f" --threshold {seg.threshold}" if seg.threshold is not None else ""
    budget = scene_of(wildcards).resources.memory_budget_mb
    budget = f" --memory-budget-mb {budget}" if budget is not None else ""
    return f"--method {seg.method.value}{threshold}{budget}"


def minkowski_inputs(wildcards):
    """Binary volume (whole or sub-sample), the scene stamp, and the grey volume when threshold functions are asked for."""
    inputs = {"binary": binary_volume(wildcards), "stamp": scene_stamp("minkowski")(wildcards)}
    if scene_of(wildcards).minkowski.threshold_functions and not wildcards.sub:
        inputs["grey"] = grey_volume(wildcards)
    return inputs


def minkowski_grey_arg(wildcards, input):
    return f"--grey {shlex.quote(input.grey)}" if "grey" in input.keys() else ""


def permeability_axes(scene):
    return [axis.value for axis in scene.permeability.axes]


def permeability_resolutions(scene):
    chosen = scene.permeability.resolutions_um or scene.resolutions_um
    unknown = sorted(set(chosen) - set(scene.resolutions_um))
    if unknown:
        raise ValueError(
            f"scene {scene.name!r}: permeability.resolutions_um = {unknown} are not among resolutions_um = "
            f"{scene.resolutions_um}"
        )
    return chosen


# -- sweep and report -----------------------------------------------------------------------------------------------
#: analyses whose outputs are not measurements to gather
SWEEP_SKIP = {"report", "segment"}


def sweep_results(wildcards):
    scene = scene_of(wildcards)
    out = []
    for analysis in scene.analyses:
        if analysis.value in SWEEP_SKIP or analysis.value not in ANALYSIS_TARGETS:
            continue
        out += ANALYSIS_TARGETS[analysis.value](scene)
        for edge in scene.sweep.sample_um:
            out += SUBSAMPLE_TARGETS.get(analysis.value, lambda scene, edge: [])(scene, edge)
    return out or ANALYSIS_TARGETS["estimate"](scene)


def sweep_volumes(wildcards):
    """Grey and binary volumes behind the results (their cost is the upstream cost of every run)."""
    scene = scene_of(wildcards)
    out = [] if is_acquire_scene(scene) or binary_stage(scene) == "capillary" else grey_volumes(scene)
    measured = {a.value for a in scene.analyses} - SWEEP_SKIP - {"estimate"}
    if measured or any(a.value == "segment" for a in scene.analyses):
        out += binary_volumes(scene)
    if any(a in SUBSAMPLE_TARGETS for a in measured):
        for edge in scene.sweep.sample_um:
            out += subsample_volumes(scene, edge)
    return out


def report_inputs(wildcards):
    scene = scene_of(wildcards)
    names = {a.value for a in scene.analyses}
    inputs = {
        "sweep": results(scene, "sweep", "sweep.h5"),
        "stamp": scene_stamp("report")(wildcards),
        "grey": grey_volumes(scene) if scene.report.slices and binary_stage(scene) != "capillary" else [],
        "binary": [],
        "lpt": per_resolution(scene, "lpt/lpt_a{a}.h5") if "lpt" in names else [],
        "thesis_rows": [
            results(SCENES[other], "sweep", "sweep.h5") for other in scene.report.thesis_rows_from.values()
        ],
    }
    if scene.report.slices and names - {"report", "estimate"}:
        inputs["binary"] = binary_volumes(scene)
    return inputs


# -- resources --------------------------------------------------------------------------------------------------------
def voxels(wildcards):
    """Voxels of the volume of resolution wildcards.a (the box of the scene; an image scene: its crop or 512³)."""
    scene = scene_of(wildcards)
    if scene.domain is None:
        crop = getattr(scene.acquire, "crop", None)
        return math.prod(crop.size) if crop is not None else 512**3
    return math.prod(round(edge / float(wildcards.a)) for edge in scene.domain.size_um)


def mem_mb(bytes_per_voxel, base_mb=500):
    """A `resources: mem_mb` function: `base_mb` plus `bytes_per_voxel` for every voxel of the rule's volume, at
    most the scene's resources.memory_budget_mb (a volume over it is processed in chunks within the budget).
    """

    def mem(wildcards):
        need = bytes_per_voxel * voxels(wildcards) / 2**20
        budget = scene_of(wildcards).resources.memory_budget_mb
        return int(base_mb + (need if budget is None else min(need, budget)))

    return mem


def every_core(cluster_threads):
    """The `threads` of a job that uses every core it gets. A local run: its --cores. A cluster job:
    `cluster_threads` (a cluster run has no --cores, and a job's own Snakemake would see the whole node)."""

    def threads(wildcards):
        if workflow.local_exec and not workflow.remote_exec:
            return workflow.cores
        return cluster_threads

    return threads


def pack_threads(wildcards):
    """The pack job's threads: one up to PACK_SPHERES_PER_THREAD spheres (the mini scene's 300 pack in 3.3 s on one
    or two threads, 5 000 in 8.0 s on either), so that a warm job runs beside it; more for larger packings, at most
    every core (8 on a cluster).
    """
    counts = [t.count for t in scene_of(wildcards).packing.types]  # None: given as a number density
    cap = every_core(8)(wildcards)
    if None in counts:
        return cap
    return max(1, min(cap, math.ceil(sum(counts) / PACK_SPHERES_PER_THREAD)))


#: spheres per thread of a pack job (pack_threads)
PACK_SPHERES_PER_THREAD = 5000


#: the twin key (porepipe.warm.twin_key) of each planned warm job: (scene name, stage) -> key or None (none planned)
_warm_twins = {}
#: the scene whose file a planned warm job reads: twin key -> scene name (scenes with the same key share the job)
WARM_SCENES = {}


def warm_twin(scene, stage):
    """The twin key of the warm job that compiles `stage`'s kernels for `scene` first (porepipe.warm), or None where
    this run plans none: it plans one on a local run of two or more cores (on one, a warm job has no idle core to
    fill and only adds its twin's run), for a scene whose grey volumes come from spheres, when no warm-up with the
    same twins finished since porepipe's sources last changed. Scenes with the same twins share one warm job.
    """
    key = (scene.name, stage)
    if key not in _warm_twins:
        local = workflow.local_exec and not workflow.remote_exec and (workflow.cores or 1) > 1
        twin = twin_key(SCENE_FILES[scene.name], stage, scene) if local and warmable(scene) else None
        if twin and marker_of(twin, stage).is_file():  # warmed since the sources last changed
            twin = None
        if twin:
            WARM_SCENES.setdefault(twin, scene.name)
        _warm_twins[key] = twin
    return _warm_twins[key]


def warm_marker(twin, stage):
    """The marker a warm job leaves: one folder per twin key, shared by the scenes with that key."""
    return str(Path("results", "_warm", twin, f"{stage}.done"))


def warm_input(stage, output):
    """An input function for `stage`'s jobs (whose output is the pattern `output`): the marker of its warm job, when
    the run plans one and the job's result does not exist yet. A job that redoes a result takes none: a marker new to
    its inputs would make Snakemake rerun every job of the stage (after a change to one job's settings, or the first
    run on two cores after runs on one), where a redone job just loads or compiles its own kernels.
    """

    def marker(wildcards):
        if Path(output.format(**dict(wildcards.items()))).exists():
            return []
        twin = warm_twin(scene_of(wildcards), stage)
        return [warm_marker(twin, stage)] if twin else []

    return marker


def warm_scene_file(wildcards):
    """The scene file a warm job reads its twins from (any scene with its twin key)."""
    return SCENE_FILES[WARM_SCENES[wildcards.twin]]


def warm_before(wildcards):
    """The warm jobs after voxelize's wait for it (of the same scene): their twins voxelise and segment first."""
    if wildcards.stage == "voxelize":
        return []
    twin = warm_twin(SCENES[WARM_SCENES[wildcards.twin]], "voxelize")
    return [warm_marker(twin, "voxelize")] if twin else []


def threads_by_volume(most, voxels_per_thread):
    """The `threads` of a job whose parallel kernels pay off only on large volumes: `most` (a number, or a function
    of the wildcards such as every_core(8)), but no more than one thread per `voxels_per_thread` voxels of the
    rule's volume, and at least one. Small jobs then share the cores: on 2 cores two one-thread jobs of the mini
    scene run side by side, where a two-thread job ran alone with its second core idle while the first compiled
    its kernels. The results are the same for any thread count.
    """

    def threads(wildcards):
        cap = most(wildcards) if callable(most) else most
        return max(1, min(cap, math.ceil(voxels(wildcards) / voxels_per_thread)))

    return threads


def cpus_per_task(wildcards, threads):
    """The `resources: cpus_per_task` of every rule: one Slurm CPU per thread the rule runs."""
    return threads


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
    if scene.diffusion.geometry is not None:  # every size a whole number of voxels at each resolution
        check_capillary_resolutions(scene.diffusion.geometry, chosen)
    return chosen


def permeability_inputs(wildcards):
    """The binary volume (whole or sub-sample) and the scene stamp, with the wall geometry for `walls: cli`: a decorated scene's
    grains.h5 (exact polyhedra); else for a whole model volume its grey volume (sub-voxel wall distances from grey
    values), for a sub-sample the packing.h5 it was cut from (the grey volume is the whole one's)."""
    scene = scene_of(wildcards)
    inputs = {"binary": binary_volume(wildcards), "stamp": scene_stamp("permeability")(wildcards)}
    if getattr(scene, "decoration", None) is not None:
        inputs["grains"] = results(scene, "decorate", "grains.h5")
    elif getattr(wildcards, "sub", ""):
        inputs["packing"] = packing_input(wildcards) if getattr(scene, "spheres", None) is not None else []
    elif getattr(scene, "acquire", None) is None:
        inputs["grey"] = grey_volume(wildcards)
    return inputs


def permeability_grey_arg(wildcards, input):
    if "grains" in input.keys():
        return f"--grains {shlex.quote(input.grains)}"
    if "packing" in input.keys():
        return packing_arg(wildcards, input)
    return f"--grey {shlex.quote(input.grey)}" if "grey" in input.keys() else ""


# MPI permeability (scene key permeability.mpi_ranks > 1): Snakemake's MPI convention, resources `tasks` and `mpi`
# (the launcher; `--set-resources permeability:mpi=srun` on a cluster) with `{resources.mpi} -n {resources.tasks}`
# in the shell command. A one-process job has no `mpi` resource (None drops it), so no executor takes it for MPI.
def permeability_ranks(wildcards):
    return max(1, scene_of(wildcards).permeability.mpi_ranks)


def permeability_threads(wildcards):
    """The LBM job's threads: one per 2^15 voxels up to every core (threads_by_volume), but at least one per MPI rank,
    so that an MPI job never runs more ranks than it has cores."""
    by_volume = threads_by_volume(every_core(8), voxels_per_thread=2**15)(wildcards)
    return max(by_volume, permeability_ranks(wildcards))


def permeability_cpus_per_task(wildcards, threads):
    """Slurm's --cpus-per-task of the LBM job: its threads shared among its --ntasks MPI ranks."""
    return max(1, threads // permeability_ranks(wildcards))


def permeability_mpi(wildcards):
    return "mpirun" if permeability_ranks(wildcards) > 1 else None


def permeability_launch(wildcards, resources):
    """`<launcher> -n <ranks>` before the command of an MPI job, else nothing."""
    if resources.get("mpi") and resources.tasks > 1:
        return f"{resources.mpi} -n {resources.tasks}"
    return ""


def permeability_rank_args(wildcards, threads, resources):
    """`--mpi` for an MPI job, and the numba threads of each rank (the job's threads shared among its ranks)."""
    ranks = resources.tasks if resources.get("mpi") else 1
    return f"--threads {resources.cpus_per_task}" + (" --mpi" if ranks > 1 else "")


#: analysis name -> function(scene) -> list of final outputs; each rule file registers its analysis here.
ANALYSIS_TARGETS = {}

#: analysis name -> function(scene, edge_um) -> that analysis's outputs on the corner sub-samples
#: results/{scene}/subsample/binary_a{a}_L{edge}.h5 (scene key sweep.sample_um); engines that accept sub-samples
#: register here, and the sweep gathers them with the sample size as a dimension.
SUBSAMPLE_TARGETS = {}


def all_targets():
    out = []
    for scene in SCENES.values():
        for analysis in scene.analyses:
            if analysis.value not in ANALYSIS_TARGETS:
                raise ValueError(
                    f"scene {scene.name!r}: no workflow rule produces analysis {analysis.value!r}"
                )
            out += ANALYSIS_TARGETS[analysis.value](scene)
    return out
