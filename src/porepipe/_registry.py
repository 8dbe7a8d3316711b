"""Which packages make up porepipe's stages: the CLI and the scene schema are assembled from this one list.

A stage package may provide ``_settings.Settings`` (a pydantic model, put into the scene under ``scene_key``) and
``_cli.register(subparsers)`` (its CLI subcommands).
"""

from __future__ import annotations

import importlib
import importlib.util

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
    ("porepipe.sweep", "sweep"),
    ("porepipe.report", "report"),
    ("porepipe.granular", "granular"),
]

#: scene sections whose presence switches a stage on (default: absent); all others default to their Settings()
OPTIONAL_SECTIONS = {"acquire", "packing", "decoration"}


def _optional_module(name: str):
    """Import ``name`` if its package is installed (stages land one by one), else None."""
    try:
        spec = importlib.util.find_spec(name)
    except ModuleNotFoundError:
        return None
    return importlib.import_module(name) if spec is not None else None


def stage_settings() -> dict[str, type]:
    """Scene key -> Settings model of every installed stage that has one."""
    found = {}
    for package, key in STAGES:
        if key is None:
            continue
        module = _optional_module(f"{package}._settings")
        if module is not None:
            found[key] = module.Settings
    return found


def stage_cli_modules() -> list:
    """The ``_cli`` modules of all installed stages, in workflow order."""
    return [m for m in (_optional_module(f"{p}._cli") for p, _ in STAGES) if m is not None]
