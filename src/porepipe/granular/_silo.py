"""Silo and heap read-outs of a granular result: the measurements of §1.10 put together as the thesis did in ch. 3-4.

:func:`analyse_silo` turns a settled silo (a ``box`` or two vertical side walls and a floor) into the wall-pressure
profile, the bulk packing fraction, k = sigma_xx/sigma_zz from stress tensors in horizontal slabs, the share of the
weight the walls carry, and the Janssen fits (k and mu_j free; mu_j with k fixed at the measured mean).
:func:`analyse_heap` gives the floor-pressure profile, repose angles, packing fraction and fabric of a heap.
"""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.granular import _measure as M
from porepipe.granular import _theory as T

#: the thesis's Janssen silo (§3.1): k, its spread, fitted wall friction, bulk packing fraction and its spread
THESIS_SILO = {"k": 0.64, "k_err": 0.19, "mu_j": 0.33, "rho_rel": 0.78, "rho_rel_err": 0.03, "mu": 0.4}


def _wall(tables, name):
    names = [str(v) for v in tables["frames"]["wall_name"].values]
    if name not in names:
        raise PorepipeError(f"granular result has no wall {name!r} (walls: {', '.join(names) or 'none'})")
    k = names.index(name)
    return k, tables["frames"]["wall_vertices_m"].values[k]


def _surface_height(centroid, x0, x1, width):
    nb = max(int((x1 - x0) / width), 1)
    _, top = M.surface_profile(centroid, np.linspace(x0, x1, nb + 1))
    return float(np.nanmean(top))


def analyse_silo(
    tables: dict,
    frame: int = -1,
    *,
    walls: tuple[str, str] = ("box left", "box right"),
    floor: str = "box floor",
    g: float = 9.81,
    contacts_per_window: float = 15.0,
    slab_rows: float = 4.0,
    floor_zone: float = 1.0,
    mu: float | None = None,
) -> dict:
    """Janssen read-out of a settled 2-D silo.

    Parameters
    ----------
    tables : dict
        :func:`porepipe.granular.read_granular` output.
    frame : int
        Frame to read (default the last).
    walls : (str, str)
        Names of the left and right side walls.
    floor : str
        Name of the floor wall.
    g : float
        Gravity (m/s²) for rho g.
    contacts_per_window : float
        Wall contacts per sliding window of the pressure profile (thesis: 10-20).
    slab_rows : float
        Height of the stress-tensor slabs, in mean grain diameters.
    floor_zone : float
        The fits leave out the lowest ``floor_zone`` silo widths (the floor restrains the grains there and the
        wall pressure drops below Janssen's, as in real flat-bottomed silos).
    mu : float, optional
        Grain-wall friction of the scene: gives ``wall_at_coulomb_limit``, the fraction of wall contacts with
        |F_t| >= 0.98 mu F_n (sliding or about to).

    Returns
    -------
    dict
        ``half_width_m``, ``fill_height_m``, ``rho_rel`` (hull-corrected), ``rho_rel_naive``, ``rho_g``,
        ``depth_m`` / ``wall_pressure`` / ``wall_running_mean`` (profile, both walls averaged), ``k_local``
        (per slab), ``slab_depth_m``, ``k``, ``k_std``, ``fit`` (k, mu_j free), ``fit_k_fixed``, ``floor_share``
        and ``wall_share`` (of the weight), ``mu_wall_mobilised`` (sum of the walls' upward traction over the sum of
        their normal forces: the mu_j that Janssen's tau_w = mu_j sigma_xx assumes), ``wall_at_coulomb_limit``, ``bounds`` (Rankine/Jaky for the scene's mu if given), ``n_particles``.
    """
    parts = M.frame_particles(tables, frame)
    contacts = M.frame_contacts(tables, frame)
    n = len(parts["centroid"])
    act = parts["active"]
    left_k, left_v = _wall(tables, walls[0])
    right_k, right_v = _wall(tables, walls[1])
    floor_k, floor_v = _wall(tables, floor)
    x0 = float(np.nanmax(left_v[:, 0]))
    x1 = float(np.nanmin(right_v[:, 0]))
    y0 = float(np.nanmax(floor_v[:, 1]))
    if not x1 > x0:
        raise PorepipeError(f"analyse_silo: walls {walls} do not enclose a gap (x0 = {x0}, x1 = {x1})")
    r = 0.5 * (x1 - x0)
    cen = parts["centroid"][act]
    d_grain = 2 * float(np.sqrt(np.mean(parts["area"][act]) / np.pi))
    top = _surface_height(cen, x0, x1, d_grain)
    bulk = (x0 + d_grain, y0 + 2 * d_grain, x1 - d_grain, top - 2 * d_grain)
    if bulk[3] <= bulk[1]:
        raise PorepipeError(f"analyse_silo: fill of {top - y0:.3g} m is too low for a bulk test area")
    pf = M.packing_fraction([p for p, a in zip(parts["polygons"], act, strict=True) if a], bulk)
    rho_p = float(np.median(tables["frames"]["mass_kg"].values / parts["area"]))
    rho_g = pf["corrected"] * rho_p * g

    lw = M.wall_contacts(contacts, n, left_k, left_v)
    rw = M.wall_contacts(contacts, n, right_k, right_v)
    depth = top - np.concatenate([lw["point"][:, 1], rw["point"][:, 1]])
    fn = np.concatenate([lw["normal_force"], rw["normal_force"]])
    centres = np.linspace(d_grain, top - y0 - d_grain, 40)
    prof = M.pressure_profile(
        depth,
        fn,
        2 * (top - y0),
        centres=centres,
        contacts_per_window=2 * contacts_per_window,
        extent=(0.0, top - y0),
    )
    wall_p = 0.5 * prof["pressure"]  # two walls pooled

    slab = slab_rows * d_grain
    k_loc, slab_depth = [], []
    for ya in np.arange(y0 + d_grain, top - slab - d_grain, slab):
        st = M.stress_tensor(
            contacts, parts["centroid"], members=act & _in_box(parts["centroid"], (x0, ya, x1, ya + slab))
        )
        k_loc.append(st["k"])
        slab_depth.append(top - ya - 0.5 * slab)
    k_loc = np.asarray(k_loc)
    k_mean = float(np.nanmean(k_loc)) if len(k_loc) else float("nan")

    zmax = top - y0 - floor_zone * 2 * r
    use = centres <= zmax
    weight = float(tables["frames"]["mass_kg"].values[act].sum() * g)
    on_floor = contacts["j"] == n + floor_k
    on_walls = (contacts["j"] == n + left_k) | (contacts["j"] == n + right_k)
    out = {
        "half_width_m": r,
        "fill_height_m": top - y0,
        "grain_diameter_m": d_grain,
        "rho_rel": pf["corrected"],
        "rho_rel_naive": pf["naive"],
        "rho_g": rho_g,
        "depth_m": centres,
        "wall_pressure": wall_p,
        "wall_running_mean": 0.5 * prof["running_mean"],
        "window_half_width_m": prof["half_width"],
        "k_local": k_loc,
        "slab_depth_m": np.asarray(slab_depth),
        "k": k_mean,
        "k_std": float(np.nanstd(k_loc)) if len(k_loc) else float("nan"),
        "fit_depth_max_m": zmax,
        "fit": T.fit_janssen(centres[use], wall_p[use], r, rho_g),
        "fit_k_fixed": T.fit_janssen(centres[use], wall_p[use], r, rho_g, k=k_mean),
        "floor_share": float(contacts["fy_N"][on_floor].sum() / weight),
        "wall_share": float(contacts["fy_N"][on_walls].sum() / weight),
        # mobilised wall friction: upward wall traction over wall pressure, summed over both walls
        "mu_wall_mobilised": float(contacts["fy_N"][on_walls].sum() / fn.sum()),
        "wall_at_coulomb_limit": _at_limit(contacts, on_walls, mu),
        "n_particles": int(act.sum()),
    }
    return out


def _at_limit(contacts, rows, mu):
    if mu is None or not rows.any():
        return float("nan")
    return float(np.mean(np.abs(contacts["ft_N"][rows]) >= 0.98 * mu * contacts["fn_N"][rows]))


def _in_box(xy, box):
    x0, y0, x1, y1 = box
    return (xy[:, 0] >= x0) & (xy[:, 0] < x1) & (xy[:, 1] >= y0) & (xy[:, 1] < y1)


def analyse_heap(
    tables: dict, frame: int = -1, *, floor: str = "box floor", g: float = 9.81, bins: int = 18
) -> dict:
    """Floor pressure and its dip, repose angles, packing fraction and fabric of a heap on a floor.

    The heap's foot is where the floor carries it: the x-range between the 1 % and 99 % quantiles of the floor
    load (grains that rolled away along the floor do not widen it). Repose fits, the integral method and the
    scaled profile use the foot; the floor-pressure profile covers every floor contact.

    Returns
    -------
    dict
        ``floor_x_m`` / ``floor_pressure`` (sliding windows of ~15 contacts) and ``floor_running_mean``,
        ``floor_mean``, ``apex_x_m``, ``height_m``, ``base_m`` (x-extent of the grains), ``foot_m`` (x0, x1),
        ``repose_left_rad`` / ``repose_right_rad`` (highest-centroid fits on the flanks' middle halves),
        ``repose_integral_rad`` (Eq. 2.42 on each half, averaged), ``rho_rel`` (hull-corrected, in the core),
        ``rho_g_h`` (bulk rho g h, the thesis's pressure scale), ``dip`` (:func:`pressure_dip` of the running mean:
        ``dip``, ``fluctuation``, ...), ``coordination``, ``directions`` (P(alpha)), ``magnitudes`` (P(F/<F>)),
        ``n_particles``, ``weight_N_m``, ``floor_load_N_m``.
    """
    parts = M.frame_particles(tables, frame)
    contacts = M.frame_contacts(tables, frame)
    n = len(parts["centroid"])
    act = parts["active"]
    fk, fv = _wall(tables, floor)
    y0 = float(np.nanmax(fv[:, 1]))
    cen = parts["centroid"][act]
    polys = [p for p, a in zip(parts["polygons"], act, strict=True) if a]
    allv = np.concatenate(polys)
    d_grain = 2 * float(np.sqrt(np.mean(parts["area"][act]) / np.pi))
    wc = M.wall_contacts(contacts, n, fk, fv)
    if len(wc["normal_force"]) < 3:
        raise PorepipeError(f"analyse_heap: fewer than 3 grains rest on {floor!r}")
    xa, xb = _foot(wc["point"][:, 0], wc["normal_force"])
    xs, tops = M.surface_profile(cen, np.linspace(xa, xb, max(int((xb - xa) / d_grain), 2) + 1))
    xc = float(xs[np.nanargmax(tops)])
    height = float(np.nanmax(allv[:, 1]) - y0)
    x_lo, x_hi = float(wc["point"][:, 0].min()), float(wc["point"][:, 0].max())
    prof = M.pressure_profile(
        wc["point"][:, 0], wc["normal_force"], xb - xa, centres=np.linspace(x_lo, x_hi, 80)
    )
    left = M.repose_angle_fit(
        cen, (xa + 0.25 * (xc - xa), xc - 0.25 * (xc - xa), max(int(0.5 * (xc - xa) / d_grain), 2))
    )
    right = M.repose_angle_fit(
        cen, (xc + 0.25 * (xb - xc), xb - 0.25 * (xb - xc), max(int(0.5 * (xb - xc) / d_grain), 2))
    )
    on_foot = (cen[:, 0] >= xa) & (cen[:, 0] <= xb)
    solid = sum(M.polygon_area(p) for p, keep in zip(polys, on_foot, strict=True) if keep)
    pf = M.packing_fraction(
        polys, (xc - 0.3 * (xc - xa), y0 + d_grain, xc + 0.3 * (xb - xc), y0 + 0.5 * height)
    )
    # Eq. 2.42 per half: the material's area (solid area / packing fraction) over half the base
    area = solid / pf["corrected"]
    integral = 0.5 * (
        M.repose_angle_integral(area * (xc - xa) / (xb - xa), xc - xa)
        + M.repose_angle_integral(area * (xb - xc) / (xb - xa), xb - xc)
    )
    rho_p = float(np.median(tables["frames"]["mass_kg"].values / parts["area"]))
    return {
        "floor_x_m": prof["centres"],
        "floor_pressure": prof["pressure"],
        "floor_running_mean": prof["running_mean"],
        "floor_mean": prof["mean"],
        "apex_x_m": xc,
        "height_m": height,
        "base_m": float(allv[:, 0].max() - allv[:, 0].min()),
        "foot_m": (xa, xb),
        "repose_left_rad": left["angle_rad"],
        "repose_right_rad": right["angle_rad"],
        "repose_integral_rad": integral,
        "rho_rel": pf["corrected"],
        "rho_g_h": pf["corrected"] * rho_p * g * height,
        "dip": M.pressure_dip(prof["centres"], prof["running_mean"], xc, noise=prof["pressure"]),
        "coordination": M.coordination(contacts, n, active=act),
        "directions": M.force_directions(contacts, bins=bins),
        "magnitudes": M.force_magnitudes(contacts),
        "n_particles": int(act.sum()),
        "weight_N_m": float(tables["frames"]["mass_kg"].values[act].sum() * g),
        "floor_load_N_m": float(wc["normal_force"].sum()),
    }


def _foot(x, load, tail: float = 0.01) -> tuple[float, float]:
    """x-range between the ``tail`` and ``1 - tail`` quantiles of the floor load."""
    order = np.argsort(x)
    cum = np.cumsum(np.asarray(load, dtype=np.float64)[order])
    cum /= cum[-1]
    xs = np.asarray(x, dtype=np.float64)[order]
    return float(xs[np.searchsorted(cum, tail)]), float(xs[min(np.searchsorted(cum, 1 - tail), len(xs) - 1)])


def heap_ensemble(heaps: list[dict], points: int = 81) -> dict:
    """Average the floor pressure of several heaps (realisations differing in the seed, as the thesis's 9).

    Each :func:`analyse_heap` result's running-mean profile is put on the thesis's axes (x from the apex in units
    of half the foot width, pressure over rho g h), the profiles are averaged where each covers, and the dip of the
    mean profile is measured.

    Returns
    -------
    dict
        ``s`` (grid on [-1.2, 1.2]), ``mean`` and ``std`` (scaled pressure), ``dip`` (:func:`pressure_dip` of the
        mean), ``dips`` (each heap's own dip), ``repose_deg`` (mean and std of the flank fits), ``n``.
    """
    if not heaps:
        raise PorepipeError("heap_ensemble: no heaps given")
    grid = np.linspace(-1.2, 1.2, points)
    rows = np.array(
        [
            M.scaled_profile(
                h["floor_x_m"],
                h["floor_running_mean"],
                h["apex_x_m"],
                0.5 * (h["foot_m"][1] - h["foot_m"][0]),
                h["rho_g_h"],
                grid,
            )
            for h in heaps
        ]
    )
    mean = np.nanmean(rows, axis=0)
    ok = ~np.isnan(mean)
    repose = np.degrees([[h["repose_left_rad"], h["repose_right_rad"]] for h in heaps]).ravel()
    return {
        "s": grid,
        "mean": mean,
        "std": np.nanstd(rows, axis=0),
        "dip": M.pressure_dip(grid[ok], mean[ok], 0.0),
        "dips": [h["dip"]["dip"] for h in heaps],
        "repose_deg": (float(repose.mean()), float(repose.std())),
        "n": len(heaps),
    }
