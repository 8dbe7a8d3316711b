"""Units of porepipe's result files: one spelling per unit, every spelling one that pint parses.

Every writer goes through :class:`porepipe._shared.store.ResultWriter`, which passes each table through
:func:`annotate` and gives each volume and coordinate its ``units`` attribute from here, so a result file never
mixes ``um``, ``µm`` and ``1/um``. The spellings follow pint's parser (``^`` for powers, ``µ`` = U+00B5 for micro):
``pint.UnitRegistry().Unit(units)`` reads each of them. Lattice quantities (voxel², time steps) have no physical
unit; they are written as ``"1"`` with the lattice unit named in the attribute ``lattice_units``.

Notes
-----
Two pitfalls of pint's registry are avoided on purpose: ``mD`` is millidebye and ``D`` debye there, so
permeabilities are written ``millidarcy`` and ``darcy``. Memory is ``MiB`` (2^20 bytes), which is what
``getrusage`` and Snakemake's ``max_rss`` count.
"""

from __future__ import annotations

import re

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError

#: dimensionless (fractions, counts, grey values, flags)
DIMENSIONLESS = "1"
MICROMETRE = "µm"
PER_MICROMETRE = "µm^-1"
SECOND = "s"
MEBIBYTE = "MiB"
SQUARE_METRE = "m^2"
MILLIDARCY = "millidarcy"
DARCY = "darcy"

#: other spellings met in older files or in the wild -> the one porepipe writes
ALIASES = {
    "um": "µm",
    "μm": "µm",  # Greek mu
    "micron": "µm",
    "micrometre": "µm",
    "micrometer": "µm",
    "1/um": "µm^-1",
    "1/µm": "µm^-1",
    "um^-1": "µm^-1",
    "μm^-1": "µm^-1",
    "um^-2": "µm^-2",
    "1/um^2": "µm^-2",
    "um^-3": "µm^-3",
    "1/um^3": "µm^-3",
    "um^2": "µm^2",
    "um^3": "µm^3",
    "um/s": "µm/s",
    "um^2/s^2": "µm^2/s^2",
    "1/mm": "mm^-1",
    "mD": "millidarcy",
    "D": "darcy",
    "MB": "MiB",
    "dimensionless": "1",
    "": "1",
}

#: lattice units (no physical unit): written as "1", the lattice unit kept in ``lattice_units``
LATTICE = {
    "voxel": "voxel",
    "voxels": "voxel",
    "voxel^2": "voxel^2",
    "voxel^3": "voxel^3",
    "voxel^-3": "voxel^-3",
    "jiffie": "jiffie (mean free flight time)",
    "1/jiffie": "1/jiffie",
    "voxel^2/jiffie": "voxel^2/jiffie",
    "lattice (voxel per step)": "voxel per time step",
    "lattice (rho/3)": "lattice pressure rho/3",
}

#: unit of a variable from the end of its name (longest suffix first), when the writer gave none
SUFFIXES = (
    ("_per_um3", "µm^-3"),
    ("_per_um2", "µm^-2"),
    ("_per_um", "µm^-1"),
    ("_per_mm3", "mm^-3"),
    ("_per_mm2", "mm^-2"),
    ("_per_mm", "mm^-1"),
    ("_m2_s", "m^2/s"),
    ("_um2_s2", "µm^2/s^2"),
    ("_um_s", "µm/s"),
    ("_um3", "µm^3"),
    ("_um2", "µm^2"),
    ("_um", "µm"),
    ("_m2", "m^2"),
    ("_mD", "millidarcy"),
    ("_D", "darcy"),
    ("_m_s", "m/s"),
    ("_mb", "MiB"),
    ("_s", "s"),
)


#: names that are dimensionless by definition wherever a stage writes them: porosities and their bounds (phi…,
#: porosity), LPT's distributions and fractions (mu…, lambda, p), Euler numbers (chi…), relative changes (delta_…)
DIMENSIONLESS_NAME = re.compile(
    r"^(phi|porosity|mu|lambda|p|chi|delta|history_delta|history_mach|history_step)(_|$)"
)


def canonical(units: str) -> tuple[str, str | None]:
    """The spelling porepipe writes for ``units``, and the lattice unit it stands for (None if physical).

    Parameters
    ----------
    units : str
        A unit string as a writer gave it (``"um"``, ``"1/um"``, ``"mD"``, ``"voxel^2"`` …).

    Returns
    -------
    (str, str or None)
        E.g. ``("µm", None)``, ``("millidarcy", None)``, ``("1", "voxel^2")``.

    Examples
    --------
    >>> canonical("1/um")
    ('µm^-1', None)
    >>> canonical("voxel^2")
    ('1', 'voxel^2')
    """
    text = str(units).strip()
    if text in LATTICE:
        return DIMENSIONLESS, LATTICE[text]
    return ALIASES.get(text, text), None


def from_name(name: str) -> str | None:
    """The unit a variable's name states (``kappa_mD`` -> millidarcy, ``L_um`` -> µm); None if the name states none."""
    for suffix, units in SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            return units
    return None


def units_of(name: str, dtype, given: str | None = None) -> tuple[str | None, str | None]:
    """Units for one variable: the writer's (respelled), else from its name, else ``"1"`` for integers, flags and the
    names :data:`DIMENSIONLESS_NAME` matches.

    Parameters
    ----------
    name : str
        The variable's name (``kappa_mD``, ``L_um``, ``phi_lower`` …).
    dtype : numpy dtype
        Its data type (integers and booleans are counts and flags: ``"1"``).
    given : str, optional
        The unit its writer gave.

    Returns
    -------
    (str or None, str or None)
        ``(units, lattice_units)``; ``units`` is None for floats whose unit nothing states.
    """
    if given is not None:
        return canonical(given)
    named = from_name(name)
    if named is not None:
        return named, None
    kind = np.dtype(dtype).kind
    return (DIMENSIONLESS if kind in "biu" or DIMENSIONLESS_NAME.match(name) else None), None


def annotate(ds: xr.Dataset) -> xr.Dataset:
    """A copy of ``ds`` whose every numeric variable and coordinate carries ``units`` in porepipe's spelling.

    Parameters
    ----------
    ds : xarray.Dataset
        A table about to be written.

    Returns
    -------
    xarray.Dataset
        Same data; ``units`` respelled (:func:`canonical`) or filled in (:func:`units_of`). Float variables whose
        unit neither the writer nor the name states are left without one (the self-description test lists them).
    """
    out = ds.copy()
    for name in list(out.variables):
        var = out.variables[name]
        if var.dtype.kind not in "biuf":
            continue
        given = var.attrs.get("units")
        units, lattice = units_of(str(name), var.dtype, None if given is None else str(given))
        if units is None:
            continue
        var.attrs["units"] = units
        if lattice is not None:
            var.attrs.setdefault("lattice_units", lattice)
    return out


def centres_um(n: int, origin_um: float, voxel_um: float) -> np.ndarray:
    """Coordinates (µm) of the centres of ``n`` voxels along one axis whose first voxel's corner is ``origin_um``."""
    return float(origin_um) + (np.arange(int(n), dtype=np.float64) + 0.5) * float(voxel_um)


def from_voxel_units(
    value, voxel_um: float, power: int, name: str | None = None, voxel_text: str | None = None
):
    """``value``, given in units of (voxel edge)^power, in µm^power; ``power`` may be negative.

    Quantities are best computed in voxel units and scaled once at the end: one multiplication (or division) by
    ``voxel_um`` per power, so no intermediate leaves the float64 range unless the result does, and a voxel size
    of 1e-100 or 1e100 µm gives the result at 1 µm times a^power.

    Parameters
    ----------
    value : float or ndarray
        The quantity in voxel units.
    voxel_um : float
        The voxel edge (the length unit of ``value``) in µm.
    power : int
        Length dimension of the quantity (S_V: -1, a volume: 3).
    name : str, optional
        The quantity's name: a non-zero value whose result over- or underflows float64 (inf, or below the normal
        range) is then refused in one line naming ``voxel_um`` and it; without a name it becomes inf or (near) 0.
    voxel_text : str, optional
        How the message writes the voxel size (default ``repr(voxel_um)``; e.g. three edges of anisotropic voxels).

    Returns
    -------
    float64 ndarray
    """
    value = np.asarray(value, dtype=np.float64)
    out = value
    with np.errstate(over="ignore", under="ignore"):
        for _ in range(abs(int(power))):
            out = out * voxel_um if power > 0 else out / voxel_um
    if name is not None:
        lost = (value != 0) & ~(np.isfinite(out) & (np.abs(out) >= np.finfo(np.float64).tiny))
        if np.any(lost):
            example = float(value[lost].flat[0]) if value.ndim else float(value)
            raise PorepipeError(
                f"voxel_um = {voxel_text or repr(float(voxel_um))} µm: {name} = {example:.6g} voxel^{power} is "
                f"beyond the float64 range in µm^{power}; allowed: a voxel size at which {name} is representable"
            )
    return out
