"""Which packages make up porepipe's stages: the CLI and the scene schema are assembled from this one list.

Every stage package provides ``_cli.register(subparsers)`` (its CLI subcommands) and, when it has a scene key,
``_settings.Settings`` (a pydantic model, put into the scene under that key). A listed stage whose module is missing is
an error, not a silent gap in the CLI or the schema.
"""

from __future__ import annotations

import importlib

#: (package, scene key) in workflow order; scene key None = the stage has no scene section.
STAGES: list[tuple[str, str | None]] = [
    ("porepipe.acquire", "acquire"),
    ("porepipe.packing", "packing"),
    ("porepipe.decorate", "decoration"),
    ("porepipe.voxelize", "voxelize"),
    ("porepipe.segment", None),
    ("porepipe.estimate", None),
    ("porepipe.minkowski", "minkowski"),
    ("porepipe.lpt", "lpt"),
    ("porepipe.lbm", "permeability"),
    ("porepipe.diffusion", "diffusion"),
    ("porepipe.sweep", "sweep"),
    ("porepipe.report", "report"),
    ("porepipe.granular", "granular"),
    ("porepipe.export", None),  # not a workflow stage: `porepipe export` only
]

#: scene sections whose presence switches a stage on (default: absent); all others default to their Settings()
OPTIONAL_SECTIONS = {"acquire", "packing", "decoration"}


def _stage_module(package: str, module: str):
    """Import ``package.module``; a listed stage that is missing is an error naming it (never silently skipped)."""
    name = f"{package}.{module}"
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as err:
        if err.name is not None and (name == err.name or name.startswith(err.name + ".")):
            raise ImportError(
                f"porepipe._registry.STAGES lists {package!r}, but {name} is missing: add the module "
                "or remove the stage from STAGES"
            ) from err
        raise


def stage_settings() -> dict[str, type]:
    """Scene key -> Settings model of every stage that has a scene section."""
    return {key: _stage_module(package, "_settings").Settings for package, key in STAGES if key is not None}


def stage_cli_modules() -> list:
    """The ``_cli`` modules of all stages, in workflow order."""
    return [_stage_module(package, "_cli") for package, _ in STAGES]
