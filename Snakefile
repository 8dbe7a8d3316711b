# porepipe workflow: the Snakefile only includes rule files and names the final targets.
# Scenes come from config/config.yaml (key `scenes`) or from `--config scene=PATH` (what `porepipe run` passes).
# A new stage adds its own `include:` line here (CI checks that every workflow/rules/*.smk is included).
from pathlib import Path

import yaml

if not config.get("scene") and not config.get("scenes"):
    config.update(yaml.safe_load(Path(workflow.basedir, "config", "config.yaml").read_text()))


include: "workflow/rules/common.smk"
include: "workflow/rules/warm.smk"
include: "workflow/rules/pack.smk"
include: "workflow/rules/decorate.smk"
include: "workflow/rules/voxelize.smk"
include: "workflow/rules/segment.smk"
include: "workflow/rules/estimate.smk"
include: "workflow/rules/minkowski.smk"
include: "workflow/rules/lpt.smk"
include: "workflow/rules/permeability.smk"
include: "workflow/rules/diffusion.smk"
include: "workflow/rules/acquire.smk"
include: "workflow/rules/granular.smk"
include: "workflow/rules/sweep.smk"
include: "workflow/rules/report.smk"


rule all:
    default_target: True
    input:
        all_targets(),
