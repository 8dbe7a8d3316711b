"""Reaction studies (thesis Tables 4.2-4.4): η and r_eff over a series of (w, w′, w_follow) sets in one pore, and the
selectivity S = r_eff/r_eff(same system without the follow-up reaction).

Every set runs the same histories (the same seed: common random numbers), so a set and its reference without the
follow-up share their random streams until the first follow-up reaction; the error of S is nevertheless quoted as
if the two were independent (the root sum of the relative errors), which overstates it.
"""

from __future__ import annotations

import math

import numpy as np

from porepipe.diffusion._edmd import reactive_pore

#: per-set result columns (arrays ``series_<name>`` of the result), in order
COLUMNS = (
    "w",
    "w_reverse",
    "w_follow",
    "eta",
    "eta_err",
    "r_eff",
    "r_eff_err",
    "selectivity",
    "selectivity_err",
)


def reaction_study(pore, axis: int, sets, **common) -> dict:
    """Run :func:`porepipe.diffusion._edmd.reactive_pore` once per distinct set (and per reference without the
    follow-up); returns ``{"series_<column>": array}`` over ``sets`` in their order plus ``k0_max`` (wall hits per
    particle-jiffie, the mean over the runs) and the pore's ``length``.
    """
    runs: dict[tuple, dict] = {}

    def run(key):
        if key not in runs:
            w, w_rev, w_fol = key
            runs[key] = reactive_pore(pore, axis, w, w_reverse=w_rev, w_follow=w_fol, **common)
        return runs[key]

    cols: dict[str, list] = {c: [] for c in COLUMNS}
    for s in sets:
        key = (float(s.w), float(s.w_reverse), float(s.w_follow))
        out = run(key)
        sel, sel_err = math.nan, math.nan
        if key[2] > 0:
            ref = run((key[0], key[1], 0.0))
            sel = out["r_eff"] / ref["r_eff"]
            sel_err = sel * math.hypot(out["r_eff_err"] / out["r_eff"], ref["r_eff_err"] / ref["r_eff"])
        for c, v in zip(
            COLUMNS, (*key, out["eta"], out["eta_err"], out["r_eff"], out["r_eff_err"], sel, sel_err)
        ):
            cols[c].append(v)
    result = {f"series_{c}": np.array(v, dtype=float) for c, v in cols.items()}
    any_run = next(iter(runs.values()))
    result["k0_max"] = float(np.mean([r["k0_max"] for r in runs.values()]))
    result["length"] = any_run["length"]
    result["pore_volume"] = any_run["pore_volume"]
    result["wall_area"] = any_run["wall_area"]
    result["runs"] = len(runs)
    result["particles_per_run"] = any_run["particles"]
    result["truncated"] = int(sum(r["truncated"] for r in runs.values()))
    return result


def study_result(pore, settings, axis: int, voxel_um, periodic, seed: int = 0):
    """Setup ``reaction`` with ``reactions.series``: the study as a DiffusionResult (arrays ``series_*``)."""
    from porepipe.diffusion._api import DiffusionResult

    rs = settings.reactions
    study = reaction_study(
        pore,
        axis,
        rs.series,
        wall_law=settings.wall_law.value,
        inlet_law=settings.inlet_law.value,
        voxel_um=voxel_um,
        periodic=periodic,
        particles=rs.particles,
        batches=settings.batches,
        max_hits=settings.max_hits_per_particle,
        seed=seed,
    )
    arrays = {k: study.pop(k) for k in list(study) if k.startswith("series_")}
    return DiffusionResult("reaction", "xyz"[axis], study, arrays)
