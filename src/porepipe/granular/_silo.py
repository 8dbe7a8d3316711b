"""Silo read-out of a granular result: the measurements of §1.10 put together as the thesis did in ch. 3.

:func:`analyse_silo` turns a settled silo (a ``box``, a shaped ``silo`` of the scene, or any side walls and a
floor) into the wall stresses against depth, the bulk packing fraction, k = sigma_xx/sigma_zz and the principal
angle from stress tensors in horizontal slabs, the share of the weight each wall carries, and the fits of the
silo theory (Janssen for straight walls; Eqs. 3.15, 3.18, 3.24 for stepped, slanted and parabolic walls).

Walls may have any orientation. Each wall contact is resolved along the nearest face of its wall: the normal
force F_n and the tangential force F_t (wall-normal and wall-shear stress per wall length), and their horizontal
and vertical components (per unit height: the horizontal one is the thesis's wall pressure sigma_xx). A face is a
side wall where its normal is closer to horizontal than to vertical; the others (a step's ledge, the floor) are
ledges. The weight is carried by all walls together: sum of their vertical forces = weight, exactly in static
equilibrium (``force_balance``).
"""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.granular import _measure as M
from porepipe.granular import _silo_shape as S
from porepipe.granular import _theory as T
from porepipe.granular._settings import Silo, SiloShape

#: the thesis's Janssen silo (§3.1): k, its spread, fitted wall friction, bulk packing fraction and its spread
THESIS_SILO = {"k": 0.64, "k_err": 0.19, "mu_j": 0.33, "rho_rel": 0.78, "rho_rel_err": 0.03, "mu": 0.4}

#: the thesis's shaped silos (§3.3-3.5), keyed by (shape, grain friction mu): k ± spread and the fitted mu_j
THESIS_SHAPES = {
    ("straight", 0.4): {"k": 0.64, "k_err": 0.19, "mu_j": 0.33, "section": "§3.1"},
    ("stepped", 0.4): {"k": 0.64, "k_err": 0.19, "mu_j": 0.33, "section": "§3.3"},
    ("hopper", 0.4): {"k": 0.77, "k_err": 0.24, "mu_j": 0.30, "section": "§3.4"},
    ("hopper", 0.7): {"k": 0.76, "k_err": 0.12, "mu_j": 0.37, "section": "§3.4"},
    ("parabolic", 0.4): {"k": 0.86, "k_err": 0.14, "mu_j": 0.30, "section": "§3.5"},
    ("parabolic", 0.7): {"k": 0.89, "k_err": 0.11, "mu_j": 0.47, "section": "§3.5"},
}

#: the thesis's smallest meaningful silo width, in grains across (§3.4: "ein Silodurchmesser kleiner als 10 Teilchen
#: ist nicht sinnvoll": it cut its hopper's apex there; it also called the stresses unreliable below ~25 across)
THESIS_MIN_WIDTH_GRAINS = 10.0


def wall_by_name(tables, name):
    """(index, world corners) of the wall called ``name`` in a granular result; one clear error if absent."""
    names = [str(v) for v in tables["frames"]["wall_name"].values]
    if name not in names:
        raise PorepipeError(f"granular result has no wall {name!r} (walls: {', '.join(names) or 'none'})")
    k = names.index(name)
    v = tables["frames"]["wall_vertices_m"].values[k]
    return k, v[np.isfinite(v).all(axis=1)]


def _floor_name(tables) -> str:
    names = [str(v) for v in tables["frames"]["wall_name"].values]
    for name in ("box floor", "silo floor"):
        if name in names:
            return name
    raise PorepipeError(
        f"analyse_silo: give floor= (no 'box floor' or 'silo floor' among {', '.join(names)})"
    )


def inner_extent(polygons, y: float, x_axis: float) -> tuple[float, float]:
    """x-range free of walls at height y around ``x_axis``: the innermost crossing of the line with each side.

    Parameters
    ----------
    polygons : sequence of (n, 2) arrays
        Wall outlines.
    y : float
        Height of the horizontal line.
    x_axis : float
        A point between the walls (the silo's axis).
    """
    left, right = -np.inf, np.inf
    for w in polygons:
        xs = []
        for (xa, ya), (xb, yb) in zip(w, np.roll(w, -1, axis=0), strict=True):
            if ya == yb == y:
                xs += [xa, xb]
            elif min(ya, yb) <= y <= max(ya, yb) and ya != yb:
                xs.append(xa + (y - ya) / (yb - ya) * (xb - xa))
        if not xs:
            continue
        if max(xs) <= x_axis:
            left = max(left, float(max(xs)))
        elif min(xs) >= x_axis:
            right = min(right, float(min(xs)))
    return left, right


def _rim(polygons, x_axis: float) -> float:
    """Height of the lower of the two sides' highest wall tops (the left and right walls by their mean x)."""
    tops = {True: -np.inf, False: -np.inf}
    for w in polygons:
        left = bool(w[:, 0].mean() < x_axis)
        tops[left] = max(tops[left], float(w[:, 1].max()))
    return min(tops.values())


def _surface_height(centroid, x0, x1, width):
    nb = max(int((x1 - x0) / width), 1)
    _, top = M.surface_profile(centroid, np.linspace(x0, x1, nb + 1))
    return float(np.nanmean(top))


def resolve_wall_contacts(contacts: dict, n_particles: int, walls: list[tuple[int, np.ndarray]]) -> dict:
    """Every contact of the given walls resolved along its wall face (see the module text).

    Returns
    -------
    dict of arrays over the contacts
        ``wall`` (wall index), ``point`` (K, 2), ``normal`` (K, 2, towards the grains), ``fn`` (normal force, >0
        pressing), ``ft_up`` (tangential force on the grain along the face's upward tangent; a horizontal face's
        tangent points to +x), ``fx``, ``fy`` (force on the grain), ``side`` (bool: a side-wall face).
    """
    rows = []
    for k, v in walls:
        w = M.wall_contacts(contacts, n_particles, k, v)
        sel = contacts["j"] == n_particles + k
        n = w["normal"]
        up = np.column_stack([-n[:, 1], n[:, 0]])
        flip = (up[:, 1] < 0) | ((up[:, 1] == 0) & (up[:, 0] < 0))
        up[flip] *= -1
        f = np.column_stack([contacts["fx_N"][sel], contacts["fy_N"][sel]])
        rows.append(
            {
                "wall": np.full(len(n), k),
                "point": w["point"],
                "normal": n,
                "fn": w["normal_force"],
                "ft_up": np.einsum("ij,ij->i", f, up),
                "fx": f[:, 0],
                "fy": f[:, 1],
                "side": np.abs(n[:, 0]) > np.abs(n[:, 1]),
            }
        )
    return {key: np.concatenate([r[key] for r in rows]) for key in rows[0]}


def wall_profiles(wc: dict, depth, centres, fill: float, contacts_per_window: float) -> dict:
    """Side-wall stresses against depth, both sides pooled (divided by 2), sliding windows of the thesis (2.36-2.40).

    Per unit height: ``sigma_xx`` (horizontal force pressing on the walls: the thesis's wall pressure) and
    ``vertical`` (the walls' upward traction); per wall length (ds = dz/|n_x|): ``normal`` (wall-normal stress) and
    ``shear`` (wall-shear stress, upward along the wall). ``running_mean`` smooths ``sigma_xx`` once more.
    """
    side = wc["side"]
    z = np.asarray(depth)[side]
    nx = np.abs(wc["normal"][side, 0])
    press = wc["fx"][side] * np.sign(wc["normal"][side, 0])
    out = {}
    for key, values in (
        ("sigma_xx", press),
        ("vertical", wc["fy"][side]),
        ("normal", wc["fn"][side] * nx),
        ("shear", wc["ft_up"][side] * nx),
    ):
        prof = M.pressure_profile(
            z,
            values,
            2 * fill,
            centres=centres,
            contacts_per_window=2 * contacts_per_window,
            extent=(0.0, fill),
        )
        out[key] = 0.5 * prof["pressure"]
        if key == "sigma_xx":
            out["running_mean"] = 0.5 * prof["running_mean"]
            out["half_width"] = prof["half_width"]
    return out


def analyse_silo(
    tables: dict,
    frame: int = -1,
    *,
    shape: Silo | None = None,
    walls: tuple[str, ...] | None = None,
    floor: str | None = None,
    g: float = 9.81,
    contacts_per_window: float = 15.0,
    slab_rows: float = 4.0,
    floor_zone: float = 1.0,
    mu: float | None = None,
    min_width_grains: float = THESIS_MIN_WIDTH_GRAINS,
) -> dict:
    """Read-out of a settled 2-D silo of any shape (thesis ch. 3).

    Parameters
    ----------
    tables : dict
        :func:`porepipe.granular.read_granular` output.
    frame : int
        Frame to read (default the last).
    shape : Silo, optional
        The scene's ``granular.silo``: the theory of its shape is fitted (mu_j, k fixed at the stress tensors'
        mean). Without it the side walls are taken as straight and Janssen (Eq. 3.4) is fitted.
    walls : tuple of str, optional
        Names of the side walls (default: every wall but the floor).
    floor : str, optional
        Name of the floor (default ``box floor`` or ``silo floor``).
    g : float
        Gravity (m/s²) for rho g.
    contacts_per_window : float
        Wall contacts per sliding window of the pressure profile (thesis: 10-20).
    slab_rows : float
        Height of the stress-tensor slabs, in mean grain diameters.
    floor_zone : float
        The fits leave out the lowest ``floor_zone`` bottom widths (the floor restrains the grains there).
    mu : float, optional
        Grain-wall friction of the scene: gives ``wall_at_coulomb_limit`` and the Rankine/Jaky ``bounds``.
    min_width_grains : float
        ``k_wide`` averages only the slabs at least this many mean grain diameters wide (default: the thesis's
        smallest meaningful silo width, 10). ``k`` averages all slabs.

    Returns
    -------
    dict
        ``shape`` (name), ``half_width_m`` (at the fill surface), ``bottom_half_width_m``, ``fill_height_m``,
        ``grain_diameter_m``, ``rho_rel`` (hull-corrected, slabs of the bulk), ``rho_rel_naive``, ``rho_g``;
        profiles over ``depth_m``: ``wall_pressure`` (sigma_xx per unit height), ``wall_running_mean``,
        ``wall_normal_stress``, ``wall_shear_stress``, ``wall_vertical_traction``; slabs over ``slab_depth_m``:
        ``k_local``, ``slab_sigma_xx``, ``slab_sigma_zz``, ``slab_psi_rad`` (major axis from the vertical);
        ``slab_width_grains``; ``k``, ``k_std`` (all slabs), ``k_wide``, ``k_wide_std``, ``k_wide_slabs`` (slabs
        at least ``min_width_grains`` wide; NaN if none), ``k_thirds`` (mean k of the slabs in the upper, middle
        and lower third of the fill), ``mu_wall_thirds`` (the side walls' mobilised friction, upward shear over
        normal force, in the same thirds: where it is low the grains have not slid along the walls since they
        landed), ``fit`` (k and mu_j: Janssen with both free, or the shape's theory with k fixed),
        ``fit_k_fixed``, ``theory`` (the fill-relative :class:`Silo`, or None for Janssen); ``segments`` (per wall:
        name, contacts, sums of F_n, F_t, F_x, F_y); ``floor_share``, ``wall_share``, ``ledge_share`` (of the
        weight), ``force_balance`` ((sum of all walls' F_y - weight)/weight), ``horizontal_balance`` (sum F_x /
        weight), ``mu_wall_mobilised`` (side walls' upward shear over their normal force: Janssen's mu_j),
        ``wall_at_coulomb_limit``, ``bounds``, ``n_particles``, ``weight_N_m``.
    """
    parts = M.frame_particles(tables, frame)
    M.require_grains(parts, "analyse_silo")
    contacts = M.frame_contacts(tables, frame)
    n = len(parts["centroid"])
    act = parts["active"]
    names = [str(v) for v in tables["frames"]["wall_name"].values]
    floor = _floor_name(tables) if floor is None else floor
    floor_k, floor_v = wall_by_name(tables, floor)
    side_names = [w for w in names if w != floor] if walls is None else list(walls)
    sides = [wall_by_name(tables, w) for w in side_names]
    y0 = float(floor_v[:, 1].max())
    cen = parts["centroid"][act]
    x_axis = float(shape.axis_x_m) if shape is not None else float(np.median(cen[:, 0]))
    polys_w = [v for _, v in sides]
    d_grain = 2 * float(np.sqrt(np.mean(parts["area"][act]) / np.pi))
    rim = _rim(polys_w, x_axis) - 0.5 * d_grain  # a fill heaped over the rim: probe the walls below it
    xl, xr = inner_extent(polys_w, min(float(cen[:, 1].max()) - d_grain, rim), x_axis)
    if not (np.isfinite(xl) and np.isfinite(xr) and xr > xl):
        raise PorepipeError(f"analyse_silo: walls {side_names} do not enclose the fill on both sides")
    top = _surface_height(cen, xl, xr, d_grain)
    fill = top - y0
    xb0, xb1 = inner_extent(polys_w, y0 + 0.5 * d_grain, x_axis)
    r_bottom = 0.5 * (xb1 - xb0)
    if fill < (slab_rows + 2) * d_grain:
        raise PorepipeError(f"analyse_silo: fill of {fill:.3g} m is too low for a bulk test area")
    polys = [p for p, a in zip(parts["polygons"], act, strict=True) if a]
    slab = slab_rows * d_grain
    slab_lo = np.arange(y0 + d_grain, top - slab - d_grain, slab)
    pf = _bulk_packing(polys, polys_w, slab_lo, slab, x_axis, d_grain)
    rho_p = float(np.median(tables["frames"]["mass_kg"].values / parts["area"]))
    rho_g = pf["corrected"] * rho_p * g

    wc = resolve_wall_contacts(contacts, n, sides)
    centres = np.linspace(d_grain, fill - d_grain, 40)
    prof = wall_profiles(wc, top - wc["point"][:, 1], centres, fill, contacts_per_window)
    slabs = _slab_stresses(contacts, parts["centroid"], act, slab_lo, slab, top)
    slabs["width"] = (
        np.array([np.diff(inner_extent(polys_w, min(top - z, rim), x_axis))[0] for z in slabs["depth"]])
        / d_grain
    )
    k_mean = float(np.nanmean(slabs["k"])) if len(slabs["k"]) else float("nan")

    xt0, xt1 = inner_extent(polys_w, min(top - 0.5 * d_grain, rim), x_axis)
    r_top = 0.5 * (xt1 - xt0)
    zmax = fill - floor_zone * 2 * r_bottom
    use = centres <= zmax
    theory = (
        None
        if shape is None or shape.shape is SiloShape.straight
        else S.shifted_silo(shape, shape.depth_m - fill)
    )
    if theory is None:
        fit = T.fit_janssen(centres[use], prof["sigma_xx"][use], r_top, rho_g)
        fit_k = T.fit_janssen(centres[use], prof["sigma_xx"][use], r_top, rho_g, k=k_mean)
    else:
        fit_k = {"k": k_mean, **S.fit_shaped_mu_j(theory, centres[use], prof["sigma_xx"][use], k_mean, rho_g)}
        fit = fit_k
    balance = _balance(wc, contacts, n, floor_k, tables["frames"]["mass_kg"].values[act].sum() * g)
    side = wc["side"]
    return {
        "shape": "straight" if shape is None else shape.shape.value,
        "half_width_m": r_top,
        "bottom_half_width_m": r_bottom,
        "fill_height_m": fill,
        "grain_diameter_m": d_grain,
        "rho_rel": pf["corrected"],
        "rho_rel_naive": pf["naive"],
        "rho_g": rho_g,
        "depth_m": centres,
        "wall_pressure": prof["sigma_xx"],
        "wall_running_mean": prof["running_mean"],
        "wall_normal_stress": prof["normal"],
        "wall_shear_stress": prof["shear"],
        "wall_vertical_traction": prof["vertical"],
        "window_half_width_m": prof["half_width"],
        "k_local": slabs["k"],
        "slab_depth_m": slabs["depth"],
        "slab_sigma_xx": slabs["xx"],
        "slab_sigma_zz": slabs["zz"],
        "slab_psi_rad": slabs["psi"],
        "slab_width_grains": slabs["width"],
        "k": k_mean,
        "k_std": float(np.nanstd(slabs["k"])) if len(slabs["k"]) else float("nan"),
        **_k_by_region(slabs, fill, min_width_grains),
        "fit_depth_max_m": zmax,
        "fit": fit,
        "fit_k_fixed": fit_k,
        "theory": theory,
        "segments": _segments(wc, sides, names),
        **balance,
        "mu_wall_mobilised": float(wc["ft_up"][side].sum() / wc["fn"][side].sum()),
        "mu_wall_thirds": _mu_by_third(wc, top, fill),
        "wall_at_coulomb_limit": _at_limit(contacts, np.isin(contacts["j"], [n + k for k, _ in sides]), mu),
        "bounds": T.lateral_pressure_bounds(mu) if mu is not None else None,
        "n_particles": int(act.sum()),
    }


def _bulk_packing(polys, walls, slab_lo, slab, x_axis, d_grain) -> dict:
    """Hull-corrected packing fraction of the bulk: slabs one grain inside the walls, pooled by solid area."""
    solid, hull, area = 0.0, 0.0, 0.0
    for ya in slab_lo[1:]:
        e0, e1 = inner_extent(walls, ya, x_axis), inner_extent(walls, ya + slab, x_axis)
        box = (max(e0[0], e1[0]) + d_grain, ya, min(e0[1], e1[1]) - d_grain, ya + slab)
        if box[2] <= box[0]:
            continue
        pf = M.packing_fraction(polys, box)
        solid, hull, area = solid + pf["solid_m2"], hull + pf["hull_m2"], area + pf["area_m2"]
    if not area > 0:
        raise PorepipeError("analyse_silo: no bulk test area fits between the walls")
    return {"corrected": solid / hull, "naive": solid / area}


def _slab_stresses(contacts, centroid, active, slab_lo, slab, top) -> dict:
    """Stress tensor (Eq. 2.52) of every horizontal slab of grains: k, sigma_xx, sigma_zz, principal angle."""
    out = {"k": [], "xx": [], "zz": [], "psi": [], "depth": []}
    for ya in slab_lo:
        inside = active & (centroid[:, 1] >= ya) & (centroid[:, 1] < ya + slab)
        if inside.sum() < 3:
            continue
        st = M.stress_tensor(contacts, centroid, members=inside)
        out["k"].append(st["k"])
        out["xx"].append(st["sigma"][0, 0])
        out["zz"].append(st["sigma"][1, 1])
        out["psi"].append(st["psi_rad"])
        out["depth"].append(top - ya - 0.5 * slab)
    return {key: np.asarray(v, dtype=np.float64) for key, v in out.items()}


def _k_by_region(slabs: dict, fill: float, min_width_grains: float) -> dict:
    """Mean k of the slabs wide enough for the thesis (``k_wide``) and of the upper, middle, lower third of the fill."""
    k = slabs["k"]
    wide = slabs["width"] >= min_width_grains
    third = np.minimum((3 * slabs["depth"] / fill).astype(int), 2)
    return {
        "k_wide": float(np.nanmean(k[wide])) if wide.any() else float("nan"),
        "k_wide_std": float(np.nanstd(k[wide])) if wide.any() else float("nan"),
        "k_wide_slabs": int(wide.sum()),
        "k_thirds": tuple(
            float(np.nanmean(k[third == t])) if (third == t).any() else float("nan") for t in range(3)
        ),
    }


def _mu_by_third(wc, top: float, fill: float) -> tuple[float, float, float]:
    """Side walls' sum of upward shear over sum of normal force in the upper, middle and lower third of the fill."""
    side = wc["side"]
    third = np.minimum((3 * (top - wc["point"][side, 1]) / fill).astype(int), 2)
    ft, fn = wc["ft_up"][side], wc["fn"][side]
    return tuple(
        float(ft[third == t].sum() / fn[third == t].sum()) if (third == t).any() else float("nan")
        for t in range(3)
    )


def _balance(wc, contacts, n, floor_k, weight) -> dict:
    """Shares of the weight carried by floor, side walls and ledges; the static balance of all wall forces."""
    on_floor = contacts["j"] == n + floor_k
    floor_fy = float(contacts["fy_N"][on_floor].sum())
    floor_fx = float(contacts["fx_N"][on_floor].sum())
    side, ledge = wc["side"], ~wc["side"]
    return {
        "floor_share": floor_fy / weight,
        "wall_share": float(wc["fy"].sum()) / weight,
        "ledge_share": float(wc["fy"][ledge].sum()) / weight,
        "side_share": float(wc["fy"][side].sum()) / weight,
        "force_balance": (floor_fy + float(wc["fy"].sum()) - weight) / weight,
        "horizontal_balance": (floor_fx + float(wc["fx"].sum())) / weight,
        "weight_N_m": float(weight),
    }


def _segments(wc, sides, names) -> list[dict]:
    rows = []
    for k, _ in sides:
        on = wc["wall"] == k
        rows.append(
            {
                "name": names[k],
                "contacts": int(on.sum()),
                "fn_N_m": float(wc["fn"][on].sum()),
                "ft_up_N_m": float(wc["ft_up"][on].sum()),
                "fx_N_m": float(wc["fx"][on].sum()),
                "fy_N_m": float(wc["fy"][on].sum()),
            }
        )
    return rows


def _at_limit(contacts, rows, mu):
    if mu is None or not rows.any():
        return float("nan")
    return float(np.mean(np.abs(contacts["ft_N"][rows]) >= 0.98 * mu * contacts["fn_N"][rows]))
