"""Result file names: the resolution tag that puts a voxel size into a name and reads back exactly.

``res_tag(a)`` is the shortest positional decimal that parses back to the same float (``repr``-exact, no exponent):
2.0 -> ``2``, 0.5 -> ``0.5``, 0.1234567 -> ``0.1234567`` (``f"{a:g}"`` would give ``0.123457``), 1e-05 ->
``0.00001``. The workflow (``workflow/rules/common.smk``), the report and the permeability output names use it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SCENE_NAME_RE", "TAG_RE", "res_tag"]

#: a scene's ``name:`` (it names the results folder): a letter or digit, then letters, digits, ``_``, ``.`` or ``-``
SCENE_NAME_RE = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"

#: every tag :func:`res_tag` makes matches this (the workflow's wildcard constraint for ``a`` and ``L``)
TAG_RE = r"[0-9]+(\.[0-9]+)?"


def res_tag(a: float) -> str:
    """The tag of voxel size ``a`` (µm) in file names; ``float(res_tag(a)) == a`` for every positive finite ``a``.

    Parameters
    ----------
    a : float
        A positive, finite voxel size or length in µm.

    Returns
    -------
    str
        Digits and at most one ``.``; no exponent, no trailing zeros, no trailing ``.``.

    Examples
    --------
    >>> [res_tag(x) for x in (2.0, 0.5, 0.1234567, 1e-5, 300)]
    ['2', '0.5', '0.1234567', '0.00001', '300']
    """
    a = float(a)
    if not (np.isfinite(a) and a > 0):
        raise ValueError(f"a resolution tag needs a positive finite number, got {a!r}")
    return np.format_float_positional(a, unique=True, trim="-")
