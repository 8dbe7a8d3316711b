"""Run control: settings that change how a run is watched, saved or spread over processes, never its result.

A settings field marked with :data:`RUN_CONTROL` (``Field(..., json_schema_extra=RUN_CONTROL)``) enters neither a
result's hash nor a checkpoint's key nor the workflow's scene stamps (:mod:`porepipe.scene_stamps`): a new checkpoint
interval, progress interval or rank count reruns nothing and discards no checkpoint. Each stage's tests check that its
result does not depend on the fields it marks.
"""

from __future__ import annotations

from pydantic import BaseModel

__all__ = ["RUN_CONTROL", "run_control_names", "without_run_control"]

#: ``json_schema_extra`` of a run-control field
RUN_CONTROL = {"run_control": True}


def run_control_names(model: type[BaseModel]) -> frozenset[str]:
    """The names of ``model``'s own fields marked :data:`RUN_CONTROL` (not those of nested sections)."""
    return frozenset(
        name
        for name, field in model.model_fields.items()
        if isinstance(field.json_schema_extra, dict) and field.json_schema_extra.get("run_control")
    )


def without_run_control(settings: BaseModel) -> dict:
    """``settings.model_dump(mode="json")`` less every run-control field, in nested sections and lists of them too.

    Parameters
    ----------
    settings : pydantic.BaseModel
        A stage's settings, or a whole scene.

    Returns
    -------
    dict
        The JSON-ready dump without the fields marked :data:`RUN_CONTROL`.
    """
    return _strip(settings, settings.model_dump(mode="json"))


def _strip(value, dumped):
    """``dumped`` (the JSON dump of ``value``) less the run-control fields of every model inside ``value``."""
    if isinstance(value, BaseModel):
        skip = run_control_names(type(value))
        return {
            key: _strip(getattr(value, key, None), item) for key, item in dumped.items() if key not in skip
        }
    if isinstance(value, (list, tuple)) and isinstance(dumped, list):
        return [_strip(v, d) for v, d in zip(value, dumped)]
    if isinstance(value, dict) and isinstance(dumped, dict):
        return {key: _strip(value.get(key), item) for key, item in dumped.items()}
    return dumped
