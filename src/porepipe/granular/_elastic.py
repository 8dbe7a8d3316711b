"""Elastic constants of a packing from an adiabatic unloading of gravity (Schinner 2001 §4.3.3).

A settled packing (the *loaded* frame) has no stress-free reference: the thesis lowered g slowly to g' ~ 0 (the
*unloaded* frame), so the packing expands back along a (nearly) reversible path; the displacement from loaded to
unloaded is minus the loading displacement. :func:`elastic_constants` averages both on one grid of test areas:
the strain of loading (compression positive) is the gradient of the unloading displacement (Eqs. 4.6-4.9), the
stress its change between the frames (Eq. 2.52; compression positive), and plane strain gives nu, E and K in each
cell (Eqs. 4.4, 4.5, 4.11). Cells at the surface or where grains rearranged give unphysical values (the thesis:
nu outside [-1, 1/2), E jumping by orders of magnitude); the summary keeps the cells with -1 < nu < 1/2 and E > 0.
"""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.granular import _measure as M


def elastic_constants(
    tables: dict, loaded: int, unloaded: int = -1, *, grains_per_cell: float = 25.0, packing: float = 0.8
) -> dict:
    """Plane-strain nu, E, K of a packing in a grid of test areas, from two frames of an unloading of g.

    Parameters
    ----------
    tables : dict
        :func:`porepipe.granular.read_granular` output of a run that lowers g (``granular.gravity``).
    loaded, unloaded : int
        Frame indices before and after the unloading.
    grains_per_cell : float
        Grains per square test area at ``packing`` (sets the cell side; the thesis used the stress tensors'
        test areas, 100-200 grains).
    packing : float
        Packing fraction used to size the cells.

    Returns
    -------
    dict
        ``x_edges``, ``y_edges``, ``count`` (grains per cell), ``u`` (ny, nx, 2: unloading displacement),
        ``u_xx``, ``u_zz`` (strain of loading, compression positive), ``sigma_xx``, ``sigma_zz`` (stress change),
        ``nu``, ``E``, ``K`` per cell; ``elastic`` (cells with -1 < nu < 1/2, E > 0), ``nu_mean``, ``nu_std``,
        ``E_mean``, ``E_std``, ``E_median``, ``K_mean`` over them; ``residual_stress`` (|sigma| left at g' over
        |sigma| loaded, summed over cells), ``u_median_over_d`` and ``u_max_over_d`` (grain displacements in
        grain diameters), ``cells`` (test areas used), ``grain_diameter_m``.
    """
    before = M.frame_particles(tables, loaded)
    after = M.frame_particles(tables, unloaded)
    act = before["active"] & after["active"]
    if act.sum() < 3 * grains_per_cell:
        raise PorepipeError(
            f"elastic_constants: {int(act.sum())} grains are too few for cells of {grains_per_cell:g} grains"
        )
    cen0, cen1 = before["centroid"], after["centroid"]
    d = 2 * float(np.sqrt(np.mean(before["area"][act]) / np.pi))
    side = float(np.sqrt(grains_per_cell * np.mean(before["area"][act]) / packing))
    lo, hi = cen0[act].min(axis=0), cen0[act].max(axis=0)
    xe = lo[0] + side * np.arange(int(np.ceil((hi[0] - lo[0]) / side)) + 1)
    ye = lo[1] + side * np.arange(int(np.ceil((hi[1] - lo[1]) / side)) + 1)
    grid = M.displacement_grid(cen0, cen1, xe, ye, active=act)
    u_xx, u_zz = M.diagonal_strain(grid)
    full = grid["count"] >= 0.7 * grains_per_cell
    s0, area = _cell_stress(tables, loaded, cen0, act, xe, ye, full)
    s1, _ = _cell_stress(tables, unloaded, cen0, act, xe, ye, full, areas=area)
    dsig = s0 - s1
    const = M.plane_strain_constants(dsig[..., 0], dsig[..., 1], u_xx, u_zz)
    ok = full & np.isfinite(const["nu"]) & (const["nu"] > -1) & (const["nu"] < 0.5) & (const["E"] > 0)
    move = np.linalg.norm(cen1[act] - cen0[act], axis=1) / d
    return {
        "x_edges": xe,
        "y_edges": ye,
        "count": grid["count"],
        "u": grid["u"],
        "u_xx": u_xx,
        "u_zz": u_zz,
        "sigma_xx": dsig[..., 0],
        "sigma_zz": dsig[..., 1],
        **const,
        "elastic": ok,
        "nu_mean": float(np.mean(const["nu"][ok])) if ok.any() else float("nan"),
        "nu_std": float(np.std(const["nu"][ok])) if ok.any() else float("nan"),
        "E_mean": float(np.mean(const["E"][ok])) if ok.any() else float("nan"),
        "E_std": float(np.std(const["E"][ok])) if ok.any() else float("nan"),
        "E_median": float(np.median(const["E"][ok])) if ok.any() else float("nan"),
        "K_mean": float(np.mean(const["K"][ok])) if ok.any() else float("nan"),
        "cells": int(full.sum()),
        "residual_stress": float(np.nansum(np.abs(s1[full])) / np.nansum(np.abs(s0[full]))),
        "u_median_over_d": float(np.median(move)),
        "u_max_over_d": float(move.max()),
        "grain_diameter_m": d,
    }


def _cell_stress(tables, frame, cells_by, active, xe, ye, use, areas=None):
    """sigma_xx, sigma_zz (Eq. 2.52) of the grains binned by ``cells_by`` in each used cell, and the areas V used.

    Without ``areas`` V is the hull of the application points (the thesis's choice); the unloaded frame reuses
    the loaded frame's V, as its grains may have lost their contacts (no contact: zero stress).
    """
    parts = M.frame_particles(tables, frame)
    contacts = M.frame_contacts(tables, frame)
    ix = np.digitize(cells_by[:, 0], xe) - 1
    iy = np.digitize(cells_by[:, 1], ye) - 1
    out = np.full((len(ye) - 1, len(xe) - 1, 2), np.nan)
    area = np.full(out.shape[:2], np.nan) if areas is None else areas
    pad = np.zeros(max(int(contacts["j"].max(initial=0)) + 1 - len(active), 0), bool)
    for j, i in zip(*np.nonzero(use), strict=True):
        members = active & (ix == i) & (iy == j)
        touching = np.concatenate([members, pad])
        if areas is not None and not (touching[contacts["i"]].any() or touching[contacts["j"]].any()):
            out[j, i] = 0.0
            continue
        st = M.stress_tensor(
            contacts, parts["centroid"], members=members, area=None if areas is None else areas[j, i]
        )
        out[j, i] = st["sigma"][0, 0], st["sigma"][1, 1]
        area[j, i] = st["area_m2"]
    return out, area


def unloading_frames(tables: dict, gravity) -> tuple[int, int] | None:
    """(loaded, unloaded) frames of a run whose ``granular.gravity`` lowers g below 1 % of its start, else None.

    Loaded: the last frame at or before the ramp's start; unloaded: the last frame, if it is at or after the ramp's
    end.
    """
    if gravity is None or gravity.kind.value == "CONSTANT" or not gravity.g2_m_s2 < 0.01 * gravity.g1_m_s2:
        return None
    t = tables["frames"]["time_s"].values
    before = np.nonzero(t <= gravity.time_s[0])[0]
    if len(before) == 0 or t[-1] < gravity.time_s[1]:
        return None
    return int(before[-1]), len(t) - 1
