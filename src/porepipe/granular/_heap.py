"""Heap read-outs of a granular result: floor pressure and its dip, repose angles, packing and fabric (ch. 4).

:func:`analyse_heap` gives the floor-pressure profile, repose angles, packing fraction and fabric of a heap;
:func:`heap_ensemble` averages several heaps on the thesis's scaled axes; :func:`floor_dip_ensemble` bins the floor
forces of several heaps (seeds) into one profile p(x)/p_max with standard errors and the dip ratio
p(centre)/p_max; :func:`heap_stress_angles` compares the principal axes of the stress with Wittmer, Cates and
Claudin's closures.
"""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.granular import _measure as M
from porepipe.granular import _theory as T
from porepipe.granular._silo import wall_by_name


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
        ``repose_integral_rad`` (Eq. 2.42 on each half, averaged), ``repose_height_rad`` (tan phi = h^2 / a: Eq.
        2.42's triangle with the base 2 h / tan phi eliminated, so grains or clusters thrown far along the floor do
        not enter; a = solid area on the foot / packing fraction), ``rho_rel`` (hull-corrected, in the core),
        ``rho_g_h`` (bulk rho g h, the thesis's pressure scale), ``dip`` (:func:`pressure_dip` of the running mean:
        ``dip``, ``fluctuation``, ...), ``coordination``, ``directions`` (P(alpha)), ``magnitudes`` (P(F/<F>)),
        ``n_particles``, ``floor_y_m``, ``weight_N_m``, ``floor_load_N_m``; ``floor_contact_x_m`` and
        ``floor_contact_N_m`` (each floor contact's x and normal force) and ``floor_centre_m`` (their load-weighted
        mean x, the heap's axis for :func:`floor_dip_ensemble`).
    """
    parts = M.frame_particles(tables, frame)
    M.require_grains(parts, "analyse_heap")
    contacts = M.frame_contacts(tables, frame)
    n = len(parts["centroid"])
    act = parts["active"]
    fk, fv = wall_by_name(tables, floor)
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
        "repose_height_rad": float(np.arctan(height**2 / area)),
        "rho_rel": pf["corrected"],
        "rho_g_h": pf["corrected"] * rho_p * g * height,
        "dip": M.pressure_dip(prof["centres"], prof["running_mean"], xc, noise=prof["pressure"]),
        "coordination": M.coordination(contacts, n, active=act),
        "directions": M.force_directions(contacts, bins=bins),
        "magnitudes": M.force_magnitudes(contacts),
        "n_particles": int(act.sum()),
        "floor_y_m": y0,
        "weight_N_m": float(tables["frames"]["mass_kg"].values[act].sum() * g),
        "floor_load_N_m": float(wc["normal_force"].sum()),
        "floor_contact_x_m": wc["point"][:, 0].copy(),
        "floor_contact_N_m": np.asarray(wc["normal_force"], dtype=np.float64).copy(),
        "floor_centre_m": float(np.average(wc["point"][:, 0], weights=wc["normal_force"])),
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


def floor_dip_ensemble(heaps: list[dict], *, bin_width: float = 0.2, reach: float = 1.2) -> dict:
    """Seed-averaged floor pressure p(s)/p_max with standard errors and the dip ratio p(centre)/p_max (§4.2).

    Each heap's floor contacts are binned on s = (x - axis) / (foot width / 2), the axis being the load-weighted
    mean x of its floor contacts (``floor_centre_m``; the apex of a noisy surface is a poorer centre); a bin's
    pressure is its summed normal force over its width in m, scaled by the heap's rho g h as in the thesis. The
    bins are centred on s = 0, so the centre bin is |s| <= bin_width / 2. The profiles are averaged over the heaps
    (the thesis averaged 9 seeds).

    The dip statistic is ``ratio = p(0) / p_max`` (1: no dip; the thesis's "dip" is 1 - ratio). The maximum of a
    noisy mean profile lies above the true one (on a flat top by about the bins' standard error, which would show
    a dip where there is none), so p_max is cross-fitted: heap i's pressure m_i is read in the bin where the
    *other* heaps' mean peaks (on the profile folded about the axis, s and -s averaged, as the heaps are
    mirror-symmetric on average), and p_max is the mean of the m_i. The noise of m_i is then independent of the
    choice of bin, so p_max is not biased upwards (at most downwards, when the other heaps pick a lower bin:
    ``ratio`` errs towards no dip). ``ratio`` is the mean profile's centre bin over p_max; its standard error,
    and each bin's of ``p_over_max``, is the jackknife's from the seed-to-seed scatter (each heap left out in
    turn, the cross-fit redone). ``dip_resolved`` is True when 1 - ratio exceeds 2 standard errors. Where every heap's cross-fit picks the centre bin itself (the others' mean peaks under the axis),
    ``ratio`` is 1 with zero error: no dip, by construction. The jackknife error is conservative: on constructed
    floor forces (tests/unit/granular/test_heap_dip_ensemble.py) it is 1.3-1.5 times the actual scatter.

    Parameters
    ----------
    heaps : list of dict
        :func:`analyse_heap` results (at least 3), or dicts with its keys ``floor_contact_x_m``,
        ``floor_contact_N_m``, ``floor_centre_m``, ``foot_m`` and ``rho_g_h``.
    bin_width : float
        Bin width in s (0.2: a tenth of the foot; the thesis's poured dip is ~0.2 wide, 4.5 cm of a 46 cm heap).
    reach : float
        Bins cover |s| <= reach.

    Returns
    -------
    dict
        ``s`` (bin centres), ``p_over_rho_g_h`` and its ``sem`` (mean profile), ``p_max`` (cross-fitted, over rho
        g h), ``p_over_max`` and ``p_over_max_se``, ``ratio``, ``ratio_se``, ``dip_resolved``, ``seed_ratios``
        (each heap's own p(0) / its own folded maximum: noisier, biased towards a dip) with ``seed_ratio_mean``
        and ``seed_ratio_sem``, ``contacts_per_bin`` (mean floor contacts per heap in the centre bin), ``n``,
        ``bin_width``.
    """
    if len(heaps) < 3:
        raise PorepipeError(f"floor_dip_ensemble: need at least 3 heaps (seeds), got {len(heaps)}")
    if not (0 < bin_width <= reach):
        raise PorepipeError(f"floor_dip_ensemble: need 0 < bin_width <= reach, got {bin_width}, {reach}")
    k = int(np.floor(reach / bin_width + 0.5 + 1e-9))
    s = bin_width * np.arange(-k, k + 1)
    rows, counts = np.empty((len(heaps), len(s))), np.empty(len(heaps))
    for i, h in enumerate(heaps):
        rows[i], counts[i] = _binned_floor(h, bin_width, k)
    n = len(heaps)
    top = _cross_fitted_max(rows, k)
    q = rows.mean(axis=0) / top
    keep = ~np.eye(n, dtype=bool)
    q_loo = np.array([rows[keep[j]].mean(axis=0) / _cross_fitted_max(rows[keep[j]], k) for j in range(n)])
    q_se = np.sqrt((n - 1) / n * np.sum((q_loo - q_loo.mean(axis=0)) ** 2, axis=0))
    seed = rows[:, k] / _positive(_folded(rows, k).max(axis=1))
    return {
        "s": s,
        "p_over_rho_g_h": rows.mean(axis=0),
        "sem": rows.std(axis=0, ddof=1) / np.sqrt(n),
        "p_max": top,
        "p_over_max": q,
        "p_over_max_se": q_se,
        "ratio": float(q[k]),
        "ratio_se": float(q_se[k]),
        "dip_resolved": bool(1.0 - q[k] > 2.0 * q_se[k]),
        "seed_ratios": seed,
        "seed_ratio_mean": float(seed.mean()),
        "seed_ratio_sem": float(seed.std(ddof=1) / np.sqrt(n)),
        "contacts_per_bin": float(counts.mean()),
        "n": n,
        "bin_width": float(bin_width),
    }


def _binned_floor(h: dict, bin_width: float, k: int) -> tuple[np.ndarray, int]:
    """One heap's floor pressure / (rho g h) in the 2k+1 bins of s centred on 0, and its contacts in the centre bin."""
    half = 0.5 * (h["foot_m"][1] - h["foot_m"][0])
    if not (half > 0 and h["rho_g_h"] > 0):
        raise PorepipeError(
            f"floor_dip_ensemble: a heap's foot half-width and rho g h must be positive, got {half}, {h['rho_g_h']}"
        )
    x = np.asarray(h["floor_contact_x_m"], dtype=np.float64)
    f = np.asarray(h["floor_contact_N_m"], dtype=np.float64)
    if x.shape != f.shape or x.ndim != 1:
        raise PorepipeError(
            f"floor_dip_ensemble: floor_contact_x_m and floor_contact_N_m differ in shape, {x.shape} != {f.shape}"
        )
    idx = np.floor((x - h["floor_centre_m"]) / (half * bin_width) + 0.5).astype(np.int64) + k
    inside = (idx >= 0) & (idx <= 2 * k)
    load = np.bincount(idx[inside], weights=f[inside], minlength=2 * k + 1)
    return load / (bin_width * half) / h["rho_g_h"], int(np.sum(idx == k))


def _cross_fitted_max(rows: np.ndarray, k: int) -> float:
    """Mean over heaps i of heap i's folded pressure in the bin where the other heaps' folded mean peaks."""
    n = len(rows)
    folded = _folded(rows, k)
    others = (folded.sum(axis=0)[None, :] - folded) / (n - 1)
    return float(_positive(np.mean(folded[np.arange(n), np.argmax(others, axis=1)])))


def _folded(rows: np.ndarray, k: int) -> np.ndarray:
    """Each heap's profile mirrored about the centre bin k and averaged: column j holds |s| = j bin widths."""
    return 0.5 * (rows[:, k:] + rows[:, k::-1])


def _positive(p):
    if not np.all(np.asarray(p) > 0):
        raise PorepipeError("floor_dip_ensemble: a floor-pressure profile has no positive pressure")
    return p


def wittmer_angles(S, phi: float) -> dict[str, np.ndarray]:
    """Principal-axis angle Psi(S) of the Wittmer-Cates-Claudin wedge for the FPA and BCC closures (Eqs. 1.19-1.31).

    Psi is the major axis's angle from the vertical, positive when it leans away from the heap's axis going down
    (the sign of the right flank; the left is its mirror image). Both meet the IFS surface value (pi/2 - phi)/2 in
    the outer region; FPA keeps it everywhere ("fixed principal axes"), BCC turns to vertical at the axis.
    """
    S = np.abs(np.asarray(S, dtype=np.float64))
    out = {}
    # beyond the wedge's surface (S >= 1, an area on a flank flatter than phi) the IFS limit S -> 1 is used
    for model in ("FPA", "BCC"):
        eta, mu = T.closure_linear(model, phi)
        s = T.wedge_stress(np.minimum(S, 1.0 - 1e-9), phi, eta, mu)
        out[model] = T.principal_angle(s["xx"], s["zz"], s["xz"])
    out["surface"] = np.full(S.shape, 0.5 * (0.5 * np.pi - phi))
    return out


def heap_stress_angles(
    tables: dict, heap: dict, frame: int = -1, *, phi: float, grains_per_area: float = 30.0, fill: float = 0.7
) -> dict:
    """Principal-axis angles of the coarse-grained stress (Eq. 2.52) over a heap, against Wittmer's FPA/BCC (§4.2).

    Test areas: a grid of squares holding ``grains_per_area`` grains each at the heap's packing (the thesis used
    100-200), its columns centred on the apex; a square is kept when it holds at least ``fill`` of that, so squares cut by the surface drop out
    (the thesis fitted its test areas to the contour). Each area's stress gives Psi (major axis from the vertical);
    ``psi_folded`` mirrors the left half onto the right (positive: leaning away from the axis going down).

    Parameters
    ----------
    tables : dict
        :func:`porepipe.granular.read_granular` output.
    heap : dict
        :func:`analyse_heap` of the same frame (apex, foot, height, packing fraction).
    phi : float
        Wittmer's angle (rad): the thesis used the friction angle atan(0.65) = 33° (Psi at the surface 28.5°).

    Returns
    -------
    dict
        Per area: ``x_m``, ``y_m`` (members' mean centroid), ``S`` (= |x - apex| tan(phi)/(depth below the apex)),
        ``x_scaled`` ((x - apex)/half the foot), ``psi_rad``, ``psi_folded_rad``, ``members``; ``model`` (FPA, BCC,
        surface: Psi at each area's S); ``S_c_fpa`` (inner/outer boundary of FPA); ``mean_folded_rad`` and
        ``sem_folded_rad`` (mean and standard error over areas), ``rms_from_fpa_rad``.
    """
    parts = M.frame_particles(tables, frame)
    contacts = M.frame_contacts(tables, frame)
    act = parts["active"]
    cen = parts["centroid"]
    grain = float(np.mean(parts["area"][act]))
    side = float(np.sqrt(grains_per_area * grain / heap["rho_rel"]))
    xa, xb = heap["foot_m"]
    y0 = heap["floor_y_m"]
    apex_y = y0 + heap["height_m"]
    xc = heap["apex_x_m"]
    # columns centred on the apex (column 0 on the axis): the grid is its own mirror image about the axis
    cols = np.arange(np.ceil((xa - xc) / side + 0.5), np.floor((xb - xc) / side - 0.5) + 1)
    rows = []
    for ya in np.arange(y0, apex_y - side, side):
        for m in cols:
            xlo = xc + (m - 0.5) * side
            inside = act & (np.abs(cen[:, 0] - (xlo + 0.5 * side)) < 0.5 * side)
            inside &= (cen[:, 1] >= ya) & (cen[:, 1] < ya + side)
            if inside.sum() < fill * grains_per_area:
                continue
            st = M.stress_tensor(contacts, cen, members=inside)
            x, y = cen[inside].mean(axis=0)
            rows.append((x, y, st["psi_rad"], int(inside.sum())))
    if len(rows) < 2:
        raise PorepipeError(
            f"heap_stress_angles: fewer than 2 test areas of {grains_per_area:g} grains fit in the heap"
        )
    x, y, psi, members = (np.array(v) for v in zip(*rows, strict=True))
    S = np.abs(x - xc) * np.tan(phi) / np.maximum(apex_y - y, 1e-300)
    folded = -psi * np.sign(x - xc)
    model = wittmer_angles(S, phi)
    return {
        "x_m": x,
        "y_m": y,
        "S": S,
        "x_scaled": (x - xc) / (0.5 * (xb - xa)),
        "psi_rad": psi,
        "psi_folded_rad": folded,
        "members": members,
        "model": model,
        "S_c_fpa": T.wedge_stress(0.0, phi, *T.closure_linear("FPA", phi))["S_c"],
        "mean_folded_rad": float(folded.mean()),
        "sem_folded_rad": float(folded.std(ddof=1) / np.sqrt(len(folded))),
        "rms_from_fpa_rad": float(np.sqrt(np.mean((folded - model["FPA"]) ** 2))),
        "phi_rad": phi,
        "side_m": side,
    }
