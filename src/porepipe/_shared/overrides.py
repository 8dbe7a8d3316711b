"""Command-line options laid over a scene's settings: the one merge that acquire, lpt and permeability share, and the
``--threads`` option every compute subcommand takes.
"""

from __future__ import annotations

import argparse
import re
from typing import Any

from pydantic import BaseModel, ValidationError

from porepipe._shared.errors import PorepipeError
from porepipe._shared.naming import SCENE_NAME_RE

__all__ = [
    "MERGED_CONTEXT",
    "add_threads_option",
    "check_resume_has_checkpoint",
    "given_options",
    "merge_settings",
    "option_names",
    "scene_name",
    "seed_number",
    "whole_count",
]


#: key of the validation context merge_settings validates with: the merged dump sets every key of the base, so a
#: check of what its user gave explicitly (``model_fields_set``) cannot tell there and is left to the caller
MERGED_CONTEXT = "merged_settings"


def given_options(args: Any, keys) -> dict:
    """``{key: args.key}`` for the keys the command line gave (None = not given)."""
    return {k: getattr(args, k) for k in keys if getattr(args, k, None) is not None}


def _deep_merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        out[key] = (
            _deep_merge(out[key], value)
            if isinstance(value, dict) and isinstance(out.get(key), dict)
            else value
        )
    return out


def option_names(keys) -> dict[str, str]:
    """``{key: "--key-with-dashes"}``: the options of settings keys named as the command line spells them."""
    return {key: "--" + key.replace("_", "-") for key in keys}


def merge_settings(
    model: type[BaseModel],
    base: BaseModel | dict | None,
    overrides: dict,
    what: str,
    options: dict[str, str] | None = None,
) -> BaseModel:
    """``base`` (a scene section, or None for the defaults) with ``overrides`` laid over it, validated as ``model``.

    Parameters
    ----------
    model : pydantic model class
        The stage's ``Settings``.
    base : model instance, dict or None
        The scene's section; None = the defaults.
    overrides : dict
        Options from the command line (only those given); nested dicts merge into nested sections key by key.
    what : str
        Names the settings in the error message (``"lpt options"``).
    options : dict, optional
        Settings key (dotted below the section) -> the command-line option that gave it, for the options given. A
        problem at or below such a key is named by its option (``--phases``), one that a check across keys finds in
        a section holding some by the options there that its message names (all of them where it names none), any
        other by its settings key. Default: :func:`option_names` of the top-level keys of ``overrides``.

    Returns
    -------
    model instance

    Raises
    ------
    PorepipeError
        The merged settings are invalid; the message names ``what`` and, per problem, the option or key, its value
        and pydantic's reason, on one line.
    """
    if isinstance(base, BaseModel):
        base = base.model_dump()
    if options is None:
        options = option_names(k for k, v in overrides.items() if not isinstance(v, dict))
    merged = _deep_merge(base or {}, overrides)
    try:
        return model.model_validate(merged, context={MERGED_CONTEXT: True})
    except ValidationError as err:
        raise PorepipeError(f"{what}: {_reasons(err, merged, options)}") from None


def _reasons(err: ValidationError, merged: dict, options: dict[str, str]) -> str:
    """The validation's reasons on one line, one ``name = value: reason`` per problem (its own text spans 4 lines each)."""
    return "; ".join(
        f"{_named(e, merged, options)}: {e['msg'].removeprefix('Value error, ')}" for e in err.errors()
    )


def _named(error: dict, merged: dict, options: dict[str, str]) -> str:
    """``name = value`` of one problem: by the option that gave its key, or the options a check across keys names,
    else by its settings key (see :func:`merge_settings`).
    """
    loc = tuple(str(part) for part in error["loc"])
    keys = {key: tuple(key.split(".")) for key in options}
    above = [key for key, parts in keys.items() if loc[: len(parts)] == parts]
    if above:
        key = max(above, key=lambda k: len(keys[k]))
        rest = _path(error["loc"][len(keys[key]) :], inner=True)
        return f"{options[key]}{rest} = {repr(error['input'])[:80]}"
    below = [key for key, parts in keys.items() if parts[: len(loc)] == loc]
    named = [key for key in below if re.search(rf"\b{re.escape(keys[key][-1])}\b", error["msg"])]
    if below:
        return ", ".join(f"{options[key]} = {repr(_at(merged, key))[:80]}" for key in named or below)
    return f"{_path(error['loc']) or 'settings'} = {repr(error['input'])[:80]}"


def _path(loc, inner: bool = False) -> str:
    """``a.b[0]``: a settings key as the scene writes it (list items in brackets); ``inner``: the rest of a key
    below an option (``[0]`` or ``.b``).
    """
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text or inner else str(part))
    return text


def _at(merged: dict, key: str):
    """The merged value at the dotted ``key`` (None where it is missing)."""
    for part in key.split("."):
        merged = merged.get(part) if isinstance(merged, dict) else None
    return merged


def _whole_number(text: str, least: int, advice: str) -> int:
    """``text`` as a whole number >= ``least``; else argparse's error with ``advice`` (what to give instead)."""
    try:
        number = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if number < least:
        raise argparse.ArgumentTypeError(f"{number}: {advice}")
    return number


def whole_count(option: str, unset: str = "every core"):
    """The argparse ``type`` of a count option such as ``--threads`` or ``--cores``: a whole number >= 1 (0 or a
    negative count ran on one thread without a word, or, for Snakemake's ``--cores``, scheduled nothing for ever).

    Parameters
    ----------
    option : str
        The option's flag, for the message (``"--cores"``).
    unset : str
        What leaving the option out gives (the refusal says so).
    """
    return lambda text: _whole_number(text, 1, f"give 1 or more (leave {option} out for {unset})")


def seed_number(text: str) -> int:
    """The argparse ``type`` of ``--seed``: a whole number >= 0, as the scene's ``seed:`` (a negative seed got past
    the command line and ended in the random streams' raw ValueError once the stage had started).
    """
    return _whole_number(text, 0, "give a whole number >= 0, as the scene's seed")


def scene_name(text: str) -> str:
    """The argparse ``type`` of an option that names a scene (``acquire-calibrate --name``): what a scene's ``name:``
    allows (a name such as ``a/b`` or ``x y`` got through and the scene written with it was refused in a
    multi-line scene error after the calibration had run).
    """
    if not re.fullmatch(SCENE_NAME_RE, text):
        raise argparse.ArgumentTypeError(
            f"{text!r}: a scene name is a letter or digit, then letters, digits, '_', '.' or '-'"
        )
    return text


def add_threads_option(parser: argparse.ArgumentParser) -> None:
    """``--threads N``: numba threads for the subcommand's kernels (default every core; more than there are: capped)."""
    parser.add_argument(
        "--threads",
        type=whole_count("--threads"),
        default=None,
        help="threads for the kernels (default: every core; a count above the cores is capped)",
    )


def check_resume_has_checkpoint(args) -> None:
    """``--resume`` of a stage that keeps no checkpoint unless told where (pack, granular) needs ``--checkpoint``:
    without it the run started afresh without a word.
    """
    if getattr(args, "resume", False) and not getattr(args, "checkpoint", None):
        raise PorepipeError(
            "--resume needs --checkpoint FILE: this stage keeps no checkpoint unless told where"
        )
