"""Decoration of a sphere packing: a grain type, a rotation and a scale for every sphere (§4.7.1 step 3, §8.2.2)."""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.spheres import check_spheres
from porepipe.decorate._api import (
    _STREAM_ASSIGN,
    _STREAM_MINIMISER,
    _STREAM_ORIENT,
    Decoration,
    _check_box,
    _rng,
    build_library,
)
from porepipe.decorate._minimiser import minimise_overlap
from porepipe.decorate._rotation import anisotropic_rotations, uniform_rotations
from porepipe.decorate._settings import OrientationMode, ScaleRule, Settings


# -- decoration ------------------------------------------------------------------------------------------------------
def _assign_types(radii, sphere_types, settings, families, rng) -> np.ndarray:
    n_fam = len(settings.families)
    names = [f.name for f in settings.families]
    probs = np.full((len(radii), n_fam), 1.0 / n_fam)
    done = np.zeros(len(radii), dtype=bool)
    for rule in settings.assign:
        match = ~done & (radii >= rule.radius_min_um) & (radii < rule.radius_max_um)
        if rule.sphere_type is not None:
            match &= sphere_types == rule.sphere_type
        row = np.array([rule.probabilities.get(nm, 0.0) for nm in names])
        probs[match] = row / row.sum()
        done |= match
    cum = np.cumsum(probs, axis=1)
    fam = np.minimum((rng.uniform(size=(len(radii), 1)) > cum).sum(axis=1), n_fam - 1)
    members = [np.flatnonzero(families == f) for f in range(n_fam)]
    pick = rng.uniform(size=len(radii))
    return np.array([members[f][int(u * len(members[f]))] for f, u in zip(fam, pick)], dtype=np.int64)


def _check_library(lib, families, n_families: int) -> None:
    """Refuse a library whose family indices are not one per type, each family of the settings given a type."""
    families = np.asarray(families)
    if families.shape != (len(lib),) or not np.array_equal(np.unique(families), np.arange(n_families)):
        raise PorepipeError(
            f"library: family indices {families.tolist()} must be one per type ({len(lib)}) and cover the "
            f"{n_families} decoration.families 0..{n_families - 1}"
        )


def scale_factors(library, types, radii, rule: ScaleRule) -> np.ndarray:
    """Scale s of each grain so that it matches its sphere of radius r.

    ``equal_volume``: s³ V_type = 4/3 π r³; ``circumscribed``: s · R_circ = r (grain inside the sphere);
    ``inscribed``: s · min(d) = r (grain contains the sphere, both centred at the centroid). A sphere type has s = r
    under every rule.
    """
    rule = ScaleRule(rule)
    if rule is ScaleRule.equal_volume:
        unit = np.array([(4.0 / 3.0 * np.pi / t.volume) ** (1.0 / 3.0) for t in library])
    elif rule is ScaleRule.circumscribed:
        unit = np.array([1.0 / t.circumradius for t in library])
    else:
        unit = np.array([1.0 / t.centre_inradius for t in library])
    return unit[types] * radii


def decorate(
    centres_um,
    radii_um,
    settings: Settings,
    seed: int = 0,
    sphere_types=None,
    box_um=None,
    periodic: bool = True,
    base_dir=".",
    library=None,
    progress: bool = False,
) -> Decoration:
    """Give every sphere a grain type, a rotation and a scale (Zauner 2020, §4.7.1 step 3, §8.2.2).

    Parameters
    ----------
    centres_um : (N, 3) array_like
    radii_um : (N,) array_like
    settings : decorate Settings
        The scene's ``decoration`` section.
    seed : int
        Scene seed; library, assignment and orientations use their own sub-streams.
    sphere_types : (N,) array_like of int, optional
        Sphere type per sphere (packing ``types``); default all 0.
    box_um, periodic
        The box (needed by the overlap minimiser to find neighbours across periodic faces).
    library : (list of GrainType, families), optional
        A prebuilt library instead of generating one from ``settings``.
    """
    centres, radii = check_spheres(centres_um, radii_um)
    if box_um is not None:
        box_um = _check_box(box_um, "decorate")
    st = (
        np.zeros(len(radii), dtype=np.int64)
        if sphere_types is None
        else np.asarray(sphere_types, dtype=np.int64)
    )
    if st.shape != radii.shape:
        raise PorepipeError(f"sphere types need shape {radii.shape}, got {st.shape}")
    lib, families = library if library is not None else build_library(settings, seed, base_dir)
    _check_library(lib, families, len(settings.families))
    types = _assign_types(radii, st, settings, families, _rng(seed, _STREAM_ASSIGN))
    scales = scale_factors(lib, types, radii, settings.scale)
    orient = settings.orientation
    rng = _rng(seed, _STREAM_ORIENT)
    if orient.mode is OrientationMode.anisotropic:
        rotations = anisotropic_rotations(rng, len(radii), orient.axis, orient.concentration)
    else:
        rotations = uniform_rotations(rng, len(radii))
    deco = Decoration(centres, types, rotations, scales, lib, families)
    if orient.mode is OrientationMode.overlap_minimizer:
        if box_um is None:
            raise PorepipeError("decoration.orientation.mode overlap_minimizer needs the box (box_um)")
        deco = minimise_overlap(
            deco,
            box_um,
            periodic,
            orient.trials_per_grain,
            orient.passes,
            orient.points_per_grain,
            _rng(seed, _STREAM_MINIMISER),
            progress,
            size_window=orient.size_window,
            volume_weight=orient.volume_weight,
            cell_volume_um3=orient.cell_volume_um3,
        )
    return deco
