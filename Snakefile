# porepipe workflow: the Snakefile only includes rule files and names the final targets.
# Scenes come from config/config.yaml (key `scenes`) or from `--config scene=PATH` (what `porepipe run` passes).
from pathlib import Path

import yaml

if not config.get("scene") and not config.get("scenes"):
    config.update(yaml.safe_load(Path(workflow.basedir, "config", "config.yaml").read_text()))


include: "workflow/rules/common.smk"


for _rule_file in sorted(Path(workflow.basedir, "workflow", "rules").glob("*.smk")):
    if _rule_file.name != "common.smk":

        include: str(_rule_file)


rule all:
    input:
        all_targets(),
    default_target: True
