"""Readable names and units of the sweep's quantities (``group.var[label]``) for titles, axes and tables."""

from __future__ import annotations

import re
import textwrap

import numpy as np
import xarray as xr

#: variable name -> (symbol, what it is)
NAMES = {
    "phi": ("φ", "porosity"),
    "porosity": ("φ", "porosity"),
    "phi_bar": ("φ̄", "mean local porosity"),
    "phi_lower": ("φ_lower", "porosity, lower bound"),
    "phi_upper": ("φ_upper", "porosity, upper bound"),
    "phi_limit": ("φ_limit", "porosity, grey-value limit"),
    "S_V": ("S_V", "specific surface"),
    "K_V": ("K_V", "integral of mean curvature per volume"),
    "T_V": ("T_V", "integral of Gaussian curvature per volume"),
    "chi": ("χ", "Euler number"),
    "kappa_mD": ("κ", "permeability"),
    "kappa_m2": ("κ", "permeability"),
    "kappa_D": ("κ", "permeability"),
    "kappa_lu": ("κ", "permeability (lattice units)"),
    "L_star_um": ("L*", "critical cell edge"),
    "S_min": ("S_min", "specific surface, lower bound"),
    "S_mf": ("S_mf", "specific surface, mean-field estimate"),
    "S_max": ("S_max", "specific surface, upper bound"),
    "phi_mean_grey": ("φ_grey", "porosity from the mean grey value"),
    "estimate_lu": ("κ̂", "permeability estimate (lattice units)"),
    "mean_velocity_um_s": ("v̄", "mean flow velocity over the pore voxels"),
    "velocity_variance_um2_s2": ("Var v", "variance of the flow velocity"),
}
#: same quantity in another unit: only the first of each family is plotted and tabled
SAME_AS = {"kappa_m2": "kappa_mD", "kappa_D": "kappa_mD", "kappa_lu": "kappa_mD", "estimate_lu": "kappa_mD"}
#: the matrix phase repeats the pore phase (S_V equal, K_V opposite, φ complementary): only pore is shown
SHADOW_LABEL = "matrix"
_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
_PARTS = re.compile(r"^(?P<group>[^.]+)\.(?P<var>[^\[]+)(?:\[(?P<label>[^\]]+)\])?$")


def parts(quantity: str) -> tuple[str, str, str]:
    """(group, variable, label) of ``group.var[label]``; ('', quantity, '') if it has another form."""
    m = _PARTS.match(str(quantity))
    return (m["group"], m["var"], m["label"] or "") if m else ("", str(quantity), "")


def symbol(quantity: str) -> str:
    """The quantity's symbol (``minkowski.S_V[pore]`` -> ``S_V``)."""
    return NAMES.get(parts(quantity)[1], (parts(quantity)[1], ""))[0]


def title(quantity: str, width: int | None = None) -> str:
    """A readable title: ``minkowski.S_V[pore]`` -> ``specific surface S_V (minkowski, pore)``.

    Parameters
    ----------
    quantity : str
        A sweep quantity (``group.var[label]``).
    width : int, optional
        Wrap into lines of at most this many characters (figure titles and legends).

    Returns
    -------
    str
    """
    group, var, label = parts(quantity)
    sym, what = NAMES.get(var, (var, ""))
    where = ", ".join(x for x in (group.replace("_", " "), label) if x)
    text = f"{what} {sym}".strip() + (f" ({where})" if where else "")
    return "\n".join(textwrap.wrap(text, width)) if width else text


def pretty_unit(units: str) -> str:
    """Units for a label: ``µm^-1`` -> ``µm⁻¹``, ``millidarcy`` -> ``mD``, ``1`` -> ``1``."""
    text = str(units or "").replace("millidarcy", "mD").replace("darcy", "D")
    return re.sub(r"\^(-?[0-9]+)", lambda m: m[1].translate(_SUPERSCRIPT), text)


def unit_of(ds: xr.Dataset, quantity: str) -> str:
    """The unit of ``quantity`` in a sweep Dataset (coordinate ``unit``), '' where unknown."""
    if "unit" not in ds.coords:
        return ""
    return str(ds.unit.sel(quantity=quantity).item())


def axis_label(ds: xr.Dataset, quantity: str) -> str:
    """``S_V [µm⁻¹]`` for a y axis."""
    units = unit_of(ds, quantity)
    return f"{symbol(quantity)} [{pretty_unit(units)}]" if units else f"{symbol(quantity)} [unit not stated]"


def is_duplicate(quantity: str, names) -> bool:
    """True for the matrix twin of a pore quantity and for κ in a second unit, when the original is present."""
    group, var, label = parts(quantity)
    names = set(map(str, names))
    if label == SHADOW_LABEL and f"{group}.{var}[pore]" in names:
        return True
    return var in SAME_AS and bool({f"{group}.{SAME_AS[var]}", f"{group}.{SAME_AS[var]}[{label}]"} & names)


def is_core(quantity: str) -> bool:
    """Porosity, Euler number and permeability: plotted whenever the scene measured them."""
    var = parts(quantity)[1]
    return var in ("phi", "porosity", "chi", "kappa_mD")


def distinct(names) -> list[str]:
    """``names`` without duplicates (:func:`is_duplicate`), order kept."""
    names = [str(n) for n in np.asarray(names).tolist()]
    return [n for n in names if not is_duplicate(n, names)]
