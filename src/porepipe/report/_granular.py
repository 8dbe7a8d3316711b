"""Granular section of the report: silo pressure profiles with Janssen fits, heap floor pressure, P(alpha), force
network, each figure with its data as CSV and the thesis's numbers beside ours (Schinner 2001, ch. 3-4).
"""

from __future__ import annotations

import html
import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure

from porepipe._shared.atomic import write_text_atomic
from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import read_attrs
from porepipe.granular import (
    THESIS_MIN_WIDTH_GRAINS,
    THESIS_SHAPES,
    THESIS_SILO,
    analyse_heap,
    analyse_silo,
    elastic_constants,
    floor_dip_ensemble,
    force_directions,
    frame_contacts,
    frame_particles,
    heap_stress_angles,
    janssen,
    lateral_pressure_bounds,
    read_granular,
    shaped_sigma_zz,
    unloading_frames,
    wittmer_angles,
)
from porepipe.report._figures import write_csv


def _fig(w=5.0, h=4.0, polar=False):
    fig = Figure(figsize=(w, h), layout="tight")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(111, projection="polar" if polar else None)
    return fig, ax


def _kind(tables) -> str:
    names = [str(v) for v in tables["frames"]["wall_name"].values]
    if "silo floor" in names:
        return "silo"
    if not {"box left", "box right", "box floor"} <= set(names):
        return "heap"
    wv = tables["frames"]["wall_vertices_m"].values
    x0 = np.nanmax(wv[names.index("box left")][:, 0])
    x1 = np.nanmin(wv[names.index("box right")][:, 0])
    pos = tables["frames"]["position_m"].values[-1]
    act = tables["frames"]["active"].values[-1].astype(bool)
    y0 = np.nanmax(wv[names.index("box floor")][:, 1])
    return "silo" if pos[act, 1].max() - y0 > 2 * (x1 - x0) else "heap"


def _theory_sxx(a: dict, z, k: float, mu_j: float):
    """sigma_xx = k sigma_zz of the silo's theory (Janssen, or its shape's) at depth z below the fill surface."""
    if a["theory"] is None:
        return janssen(z, a["half_width_m"], k, mu_j, a["rho_g"])[1]
    return k * shaped_sigma_zz(a["theory"], z, k, mu_j, a["rho_g"])


def thesis_values(a: dict, mu: float | None) -> dict | None:
    """The thesis's k and mu_j for this silo's shape and grain friction (``THESIS_SHAPES``), or None."""
    return THESIS_SHAPES.get((a["shape"], round(mu, 2) if mu is not None else 0.4))


def silo_pressure_figure(a: dict, path: Path, dpi: int = 110, mu: float | None = None) -> list[dict]:
    """Wall pressure and slab stresses against depth with the fitted theory and the thesis's (k, mu_j) beside."""
    fig, ax = _fig()
    z = a["depth_m"]
    ax.plot(a["wall_pressure"], z, "k.", ms=3, label="wall sigma_xx (windows)")
    ax.plot(a["wall_running_mean"], z, "k-", lw=0.8, label="running mean")
    ax.plot(a["slab_sigma_zz"], a["slab_depth_m"], "C0o", mfc="none", ms=4, label="sigma_zz (slab tensors)")
    zz = np.linspace(0, a["fill_height_m"] * 0.995, 120)
    name = "Janssen" if a["theory"] is None else f"{a['shape']} theory"
    fit = a["fit"]
    if a["theory"] is None:
        ax.plot(
            _theory_sxx(a, zz, fit["k"], fit["mu_j"]),
            zz,
            "C0-",
            label=f"Janssen fit k {fit['k']:.2f}, mu_j {fit['mu_j']:.3f}",
        )
    fk = a["fit_k_fixed"]
    sxx = _theory_sxx(a, zz, fk["k"], fk["mu_j"])
    ax.plot(sxx, zz, "C2--", label=f"{name}: k = {fk['k']:.2f} (stress), mu_j {fk['mu_j']:.3f}")
    ax.plot(sxx / fk["k"], zz, "C2:", lw=0.8, label="its sigma_zz")
    th = thesis_values(a, mu) or THESIS_SILO
    ax.plot(
        _theory_sxx(a, zz, th["k"], th["mu_j"]), zz, "C3:", label=f"thesis k {th['k']}, mu_j {th['mu_j']}"
    )
    ax.axhline(a["fit_depth_max_m"], color="0.6", lw=0.6)
    ax.invert_yaxis()
    ax.set_xlabel("stress [N/m²]")
    ax.set_ylabel("depth below the fill surface [m]")
    ax.legend(fontsize=6, loc="lower left")
    fig.savefig(path, dpi=dpi)
    return [
        {"depth_m": float(d), "wall_pressure_N_m2": float(p), "running_mean_N_m2": float(m)}
        for d, p, m in zip(z, a["wall_pressure"], a["wall_running_mean"], strict=True)
    ]


def _silo_rows(a: dict, th: dict) -> list[list[str]]:
    """The silo table: k, mu_j fits, wall friction, packing and the weight balance, the thesis's values beside."""
    janssen_fit = a["theory"] is None
    rows = [
        [
            "k = sigma_xx/sigma_zz (slab stress tensors)",
            f"{a['k']:.2f} ± {a['k_std']:.2f}",
            f"{th['k']} ± {th['k_err']}",
        ],
        [
            f"k, slabs ≥ {THESIS_MIN_WIDTH_GRAINS:g} grains across ({a['k_wide_slabs']} of {len(a['k_local'])})",
            "–" if a["k_wide_slabs"] == 0 else f"{a['k_wide']:.2f} ± {a['k_wide_std']:.2f}",
            f"{th['k']} ± {th['k_err']} (it cut silos narrower than 10 grains)",
        ],
        [
            "k in the upper / middle / lower third of the fill",
            " / ".join(f"{v:.2f}" for v in a["k_thirds"]),
            "– (local k independent of position, §3.3)",
        ],
        [
            "mobilised wall friction in the same thirds",
            " / ".join(f"{v:.2f}" for v in a["mu_wall_thirds"]),
            "–",
        ],
    ]
    if janssen_fit:
        # a fit pinned on a bound of its least squares: not a Janssen profile, its errors mean nothing
        pinned = " (on the fit's bound: not a Janssen profile)" if a["fit"].get("at_bound") else ""
        rows += [
            [
                "k (Janssen fit, k and mu_j free)",
                f"{a['fit']['k']:.2f} ± {a['fit']['k_err']:.2f}{pinned}",
                "–",
            ],
            [
                "mu_j (Janssen fit, k free)",
                f"{a['fit']['mu_j']:.3f} ± {a['fit']['mu_j_err']:.3f}{pinned}",
                f"{th['mu_j']}",
            ],
        ]
    rows += [
        [
            f"mu_j ({'Janssen' if janssen_fit else a['shape'] + ' theory'} fit, k fixed at the stress value)",
            f"{a['fit_k_fixed']['mu_j']:.3f}",
            f"{th['mu_j']}",
        ],
        ["mobilised wall friction (sum F_t / sum F_n, side walls)", f"{a['mu_wall_mobilised']:.3f}", "–"],
        ["wall contacts at the Coulomb limit", f"{a['wall_at_coulomb_limit']:.0%}", "–"],
        [
            "rho_rel (hull-corrected, Eq. 2.45)",
            f"{a['rho_rel']:.3f}",
            f"{th['rho_rel']} ± {th['rho_rel_err']}" if "rho_rel" in th else "–",
        ],
        [
            "weight carried by side walls / ledges / floor",
            f"{a['side_share']:.0%} / {a['ledge_share']:.0%} / {a['floor_share']:.0%}",
            "–",
        ],
        [
            "static balance (sum of wall forces F_y - weight) / weight",
            f"{a['force_balance']:.1e}",
            "0 (exact)",
        ],
    ]
    return rows


def direction_figure(directions: dict, path: Path, dpi: int = 110) -> list[dict]:
    """P(alpha) as a polar plot, mirrored to [0, 2 pi) (P(alpha) = P(alpha + pi))."""
    fig, ax = _fig(4.0, 4.0, polar=True)
    e, d = directions["edges"], directions["density"]
    centres = 0.5 * (e[:-1] + e[1:])
    ang = np.concatenate([centres, centres + np.pi, centres[:1]])
    val = np.concatenate([d, d, d[:1]])
    ax.plot(ang, val, "k-")
    ax.set_title("P(alpha): contact-force directions", fontsize=9)
    fig.savefig(path, dpi=dpi)
    return [
        {"alpha_deg": float(math.degrees(c)), "density_per_rad": float(v)}
        for c, v in zip(centres, d, strict=True)
    ]


def network_figure(tables: dict, path: Path, dpi: int = 130, frame: int = -1) -> list[dict]:
    """Force network: a line from each particle's centroid to each of its contacts' application points, width
    proportional to |F| (thesis §2.3.2); particles coloured by index (= age for poured scenes).
    """
    parts = frame_particles(tables, frame)
    c = frame_contacts(tables, frame)
    act = parts["active"]
    polys = [p for p, a in zip(parts["polygons"], act, strict=True) if a]
    allv = np.concatenate(polys)
    span = np.ptp(allv, axis=0)
    aspect = span[1] / max(span[0], 1e-300)
    fig = Figure(
        figsize=(8.0, min(max(1.2 + 8.0 * aspect, 2.5), 10.0))
        if aspect < 1
        else (min(max(1.5 + 7.0 / aspect, 2.5), 8.0), 7.0)
    )
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(111)
    ages = np.nonzero(act)[0]
    pc = PolyCollection(polys, array=ages, cmap="viridis", alpha=0.35, edgecolors="none")
    ax.add_collection(pc)
    cen = parts["centroid"]
    n = len(cen)
    f = np.hypot(c["fx_N"], c["fy_N"])
    s = np.column_stack([c["sx_m"], c["sy_m"]])
    segs = [np.array([cen[i], s[k]]) for k, i in enumerate(c["i"])]
    segs += [np.array([cen[j], s[k]]) for k, j in enumerate(c["j"]) if j < n]
    fw = np.concatenate([f, f[c["j"] < n]])
    width = 3.0 * fw / max(fw.max(), 1e-300)
    ax.add_collection(LineCollection(segs, linewidths=width, colors="k"))
    ax.set_xlim(allv[:, 0].min(), allv[:, 0].max())
    ax.set_ylim(allv[:, 1].min(), allv[:, 1].max())
    ax.set_aspect("equal")
    ax.set_title("force network (line width ∝ |F|), grains coloured by age", fontsize=9)
    fig.savefig(path, dpi=dpi)
    return [
        {"i": int(i), "j": int(j), "F_N_m": float(ff), "sx_m": float(p[0]), "sy_m": float(p[1])}
        for i, j, ff, p in zip(c["i"], c["j"], f, s, strict=True)
    ]


def heap_floor_figure(h: dict, path: Path, dpi: int = 110) -> list[dict]:
    """Floor pressure of a heap, scaled by rho g h, against (x - apex)/(foot width / 2) (thesis Figs. 4.9, 4.23).

    The flank maxima and the apex value that define the dip are marked.
    """
    fig, ax = _fig(5.0, 3.2)
    xa, xb = h["foot_m"]
    half, xc, rgh = 0.5 * (xb - xa), h["apex_x_m"], h["rho_g_h"]
    s = (h["floor_x_m"] - xc) / half
    ax.plot(s, h["floor_pressure"] / rgh, "k.", ms=3, label="windows (~15 contacts)")
    ax.plot(s, h["floor_running_mean"] / rgh, "k-", lw=0.8, label="running mean")
    d = h["dip"]
    ax.plot(
        [(d["x_left_max"] - xc) / half, 0.0, (d["x_right_max"] - xc) / half],
        [d["p_side"] / rgh, d["p_apex"] / rgh, d["p_side"] / rgh],
        "C3o--",
        ms=4,
        lw=0.7,
        label=f"dip {d['dip']:.2f} (scatter {d['fluctuation']:.2f})",
    )
    ax.set_xlabel("(x - apex) / (foot width / 2)")
    ax.set_ylabel("floor pressure / (rho g h)")
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=dpi)
    return [
        {"x_m": float(x), "s": float(u), "pressure_N_m2": float(p), "pressure_over_rho_g_h": float(p / rgh)}
        for x, u, p in zip(h["floor_x_m"], s, h["floor_pressure"], strict=True)
    ]


def stress_angle_figure(a: dict, path: Path, dpi: int = 110) -> list[dict]:
    """Folded principal-axis angle of each test area against S, with Wittmer's FPA and BCC (thesis Fig. 4.25)."""
    fig, ax = _fig(5.0, 3.2)
    ax.plot(a["S"], np.degrees(a["psi_folded_rad"]), "ko", ms=3, label="test areas (Eq. 2.52)")
    S = np.linspace(1e-4, 1.0, 200)
    model = wittmer_angles(S, a["phi_rad"])
    ax.plot(S, np.degrees(model["FPA"]), "C3-", label="FPA (fixed principal axes)")
    ax.plot(S, np.degrees(model["BCC"]), "C0--", label="BCC")
    ax.set_xlabel("S = |x - apex| tan(phi) / depth below the apex")
    ax.set_ylabel("Psi, leaning outwards [deg]")
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=dpi)
    return [
        {"x_m": float(x), "y_m": float(y), "S": float(u), "psi_folded_deg": float(math.degrees(p))}
        for x, y, u, p in zip(a["x_m"], a["y_m"], a["S"], a["psi_folded_rad"], strict=True)
    ]


def _stress_angle_part(
    tables, h: dict, mu: float | None, out_dir: Path, dpi: int, frame: int = -1
) -> list[str]:
    """The stress-angle comparison with Wittmer et al. for phi = atan(mu), when test areas of 30 grains fit."""
    if mu is None:
        return []
    phi = math.atan(mu)
    try:
        a = heap_stress_angles(tables, h, frame, phi=phi)
    except PorepipeError as err:
        return [f"<p class=note>Stress angles not measured: {html.escape(str(err))}.</p>"]
    write_csv(
        out_dir / "granular_stress_angles.csv",
        stress_angle_figure(a, out_dir / "granular_stress_angles.png", dpi),
    )
    surface = math.degrees(a["model"]["surface"][0])
    return [
        "<h2>Principal stress axes</h2>",
        f"<p>{len(a['S'])} test areas of ~30 grains (thesis: 100-200). Mean angle of the major axis, leaning "
        f"outwards: {math.degrees(a['mean_folded_rad']):.1f}° ± {math.degrees(a['sem_folded_rad']):.1f}°; Wittmer's "
        f"FPA predicts {surface:.1f}° everywhere for phi = atan({mu:g}) (rms deviation "
        f"{math.degrees(a['rms_from_fpa_rad']):.1f}°). Thesis (§4.2.2, Fig. 4.25): a preferred direction in each "
        "half, 'only poorly described' by the prediction for mu = 0.65 (28.5° at the surface); layered heaps: major "
        "axis vertical at the centre, FPA not satisfied.</p>",
        "<img src='granular_stress_angles.png' alt='stress angles'>",
        "<p class=note>Data: <a href='granular_stress_angles.csv'>granular_stress_angles.csv</a></p>",
    ]


def _heap_part(h: dict, cost: str, out_dir: Path, dpi: int) -> list[str]:
    """Floor pressure, repose angles and packing of a heap, with the thesis's findings in words."""
    write_csv(
        out_dir / "granular_floor_pressure.csv",
        heap_floor_figure(h, out_dir / "granular_floor_pressure.png", dpi),
    )
    rows = [
        [
            "repose angle, left / right flank fit [deg]",
            f"{math.degrees(h['repose_left_rad']):.1f} / {math.degrees(h['repose_right_rad']):.1f}",
        ],
        [
            "repose angle, integral method (Eq. 2.42) [deg]",
            f"{math.degrees(h['repose_integral_rad']):.1f}",
        ],
        [
            "repose angle from height and area, tan = h²/a [deg]",
            f"{math.degrees(h['repose_height_rad']):.1f}",
        ],
        ["height / foot width [m]", f"{h['height_m']:.3f} / {h['foot_m'][1] - h['foot_m'][0]:.3f}"],
        [
            "floor-pressure dip 1 - p(apex)/p(flank maxima), window scatter",
            f"{h['dip']['dip']:.2f}, {h['dip']['fluctuation']:.2f}",
        ],
        ["rho_rel in the core (Eq. 2.45)", f"{h['rho_rel']:.3f}"],
        ["mean coordination", f"{h['coordination']['mean']:.2f}"],
        ["floor load / weight", f"{h['floor_load_N_m'] / h['weight_N_m']:.3f}"],
    ]
    return [
        "<h2>Heap</h2>",
        f"<p>{h['n_particles']} grains. Cost: {html.escape(cost)}. Thesis (§4.2): poured 7-gons (2500 grains, "
        "9 seeds) have repose angle 26.8° ± 2.0° and a floor-pressure dip under the apex reaching up to half the "
        "heap's height; poured 13-gons and layered heaps (21° flanks) have none (the central lowering is "
        "smaller than the fluctuations); experiments on conical piles: dips up to 0.5.</p>",
        "<img src='granular_floor_pressure.png' alt='floor pressure'>",
        _table(["quantity", "this run"], rows),
        "<p class=note>Data: <a href='granular_floor_pressure.csv'>granular_floor_pressure.csv</a></p>",
    ]


def _elastic_part(tables, unload: tuple[int, int], young: float | None, out_dir: Path) -> list[str]:
    """Elastic constants of the adiabatic unloading (§4.3.3), the thesis's beside them; per-cell values as CSV."""
    try:
        e = elastic_constants(tables, *unload, grains_per_cell=9)
    except PorepipeError as err:
        return [f"<p class=note>Elastic constants not measured: {html.escape(str(err))}.</p>"]
    ratio = f"1/{young / e['E_median']:.0f}" if young else "–"
    rows = [
        [
            "nu (plane strain, Eq. 4.4), mean ± std",
            f"{e['nu_mean']:.2f} ± {e['nu_std']:.2f}",
            "0.446 ± 0.137",
        ],
        ["E (Eq. 4.5) [N/m], mean ± std", f"{e['E_mean']:.3g} ± {e['E_std']:.3g}", "1.48e5 ± 1.08e5"],
        ["E of the packing / E of its grains (median)", ratio, "1/68"],
        ["K (Eq. 4.11) [N/m], mean", f"{e['K_mean']:.3g}", "–"],
        ["test areas with -1 < nu < 1/2 and E > 0", f"{int(e['elastic'].sum())} of {e['cells']}", "–"],
        [
            "grain displacement, median / largest [diameters]",
            f"{e['u_median_over_d']:.3f} / {e['u_max_over_d']:.3f}",
            "< 0.01 (grains 1e7 N/m)",
        ],
    ]
    j, i = np.nonzero(e["elastic"])
    write_csv(
        out_dir / "granular_elastic.csv",
        [
            {"cell_x": int(a), "cell_y": int(b), "nu": float(e["nu"][b, a]), "E_N_m": float(e["E"][b, a])}
            for a, b in zip(i, j, strict=True)
        ],
    )
    return [
        "<h2>Elastic constants (adiabatic unloading)</h2>",
        f"<p>g lowered to ~0 between frames {unload[0]} and {unload[1]}; test areas of 9 grains. The contacts "
        "stiffen with load, so E is the secant modulus of the whole unloading.</p>",
        _table(["quantity", "this run", "thesis §4.3.3"], rows),
        "<p class=note>Data: <a href='granular_elastic.csv'>granular_elastic.csv</a></p>",
    ]


def thesis_dip_expectation(granular) -> str:
    """What the thesis found for a heap built like the scene's ``granular:`` section (§4.2), in words."""
    sources = granular.drop_sources if granular is not None else []
    if not sources:
        return "no thesis heap (no drop source)"
    if any(d.shrink for d in sources):
        return "layered: no dip (central lowering below the fluctuations, §4.2.1, Fig. 4.9)"
    corners = max(d.shape.corners for d in sources)
    if corners >= 12:
        return "poured, smooth grains (13-gons): no dip (hexagonal order, §4.2.2, Fig. 4.15)"
    return "poured, rough grains (7-gons): dip under the apex (§4.2.2, Figs. 4.14, 4.23)"


def dip_ensemble_figure(groups: list[dict], path: Path, dpi: int = 110) -> list[dict]:
    """Seed-averaged floor pressure p/p_max (± standard error) of each ensemble against (x - axis)/(foot / 2)."""
    fig, ax = _fig(5.0, 3.4)
    rows = []
    for c, g in enumerate(groups):
        e = g["ensemble"]
        ax.errorbar(
            e["s"],
            e["p_over_max"],
            yerr=e["p_over_max_se"],
            fmt="o-",
            ms=3,
            lw=0.8,
            capsize=2,
            color=f"C{c}",
            label=f"{g['label']} ({e['n']} seeds): p(0)/p_max {e['ratio']:.2f} ± {e['ratio_se']:.2f}",
        )
        rows += [
            {
                "ensemble": g["label"],
                "s": float(u),
                "p_over_max": float(q),
                "se": float(d),
                "p_over_rho_g_h": float(p),
                "sem_over_rho_g_h": float(m),
            }
            for u, q, d, p, m in zip(
                e["s"], e["p_over_max"], e["p_over_max_se"], e["p_over_rho_g_h"], e["sem"], strict=True
            )
        ]
    ax.axhline(1.0, color="0.6", lw=0.6)
    ax.set_xlabel("(x - axis) / (foot width / 2)")
    ax.set_ylabel("floor pressure / p_max (seed mean)")
    ax.legend(fontsize=6, loc="lower center")  # the profiles are high in the middle, low at the sides
    fig.savefig(path, dpi=dpi)
    return rows


def read_heap_ensemble(results, granular=None, label: str = "") -> dict:
    """:func:`analyse_heap` of each result (one per seed) and their :func:`floor_dip_ensemble`, labelled."""
    heaps = [analyse_heap(read_granular(r)) for r in results]
    return {
        "label": label,
        "heaps": heaps,
        "ensemble": floor_dip_ensemble(heaps),
        # the thesis's check (§2.3.3): vary the window width, so that a dip is not an artefact of one binning
        "other_widths": [floor_dip_ensemble(heaps, bin_width=w) for w in (0.1, 0.3)],
        "thesis": thesis_dip_expectation(granular),
    }


def dip_ensemble_part(groups: list[dict], out_dir: Path, dpi: int = 110) -> list[str]:
    """The floor-pressure dip over seeds: figure, table and the thesis's finding beside each ensemble."""
    write_csv(
        out_dir / "granular_dip_ensemble.csv",
        dip_ensemble_figure(groups, out_dir / "granular_dip_ensemble.png", dpi),
    )
    rows = []
    for g in groups:
        e, hs = g["ensemble"], g["heaps"]
        repose = np.degrees([[h["repose_left_rad"], h["repose_right_rad"]] for h in hs]).mean(axis=1)
        foot = np.array([h["foot_m"][1] - h["foot_m"][0] for h in hs])
        verdict = "dip resolved" if e["dip_resolved"] else "no dip resolved"
        rows.append(
            [
                g["label"],
                f"{e['n']} x {np.mean([h['n_particles'] for h in hs]):.0f}",
                f"{repose.mean():.1f} ± {repose.std(ddof=1):.1f}",
                f"{foot.mean():.3f} ± {foot.std(ddof=1):.3f}",
                f"{e['contacts_per_bin']:.1f}",
                f"{e['ratio']:.3f} ± {e['ratio_se']:.3f} ({verdict})",
                " / ".join(f"{o['ratio']:.2f} ± {o['ratio_se']:.2f}" for o in g["other_widths"]),
                f"{e['seed_ratio_mean']:.3f} ± {e['seed_ratio_sem']:.3f}",
                g["thesis"],
            ]
        )
    bw = groups[0]["ensemble"]["bin_width"]
    return [
        "<h2>Floor-pressure dip over seeds</h2>",
        f"<p>Each heap's floor contacts binned on s = (x - axis) / (foot width / 2), bins {bw:g} wide centred on "
        "the axis (the load-weighted mean x of the floor contacts), averaged over the seeds; p_max cross-fitted "
        "(each seed read where the other seeds' mirror-folded mean peaks, so the noise of a maximum does not fake "
        "a dip); errors: jackknife over seeds (conservative: 1.3-1.5x the scatter in constructed cases). A dip is "
        "resolved when 1 - p(0)/p_max exceeds 2 standard errors. Thesis (§4.2): 9 poured heaps of ~2500 rough "
        "7-gons show a dip reaching half the heap's height; layered heaps show none.</p>",
        "<img src='granular_dip_ensemble.png' alt='floor pressure over seeds'>",
        _table(
            [
                "ensemble",
                "seeds x grains",
                "repose angle [deg]",
                "foot width [m]",
                "floor contacts per bin and seed (centre)",
                f"p(0)/p_max ± s.e. (bins {bw:g})",
                "same, bins 0.1 / 0.3",
                "per-seed p(0)/own max (biased low)",
                "thesis",
            ],
            rows,
        ),
        "<p class=note>Data: <a href='granular_dip_ensemble.csv'>granular_dip_ensemble.csv</a>. The "
        "single-heap sections below read the first seed only.</p>",
    ]


def _table(columns, rows) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def granular_section(
    result,
    out_dir,
    *,
    mu: float | None = None,
    kind: str = "auto",
    dpi: int = 110,
    silo=None,
    gravity=None,
    young: float | None = None,
) -> str:
    """HTML of the granular section for one ``granular.h5`` (figures and CSVs written into ``out_dir``).

    Parameters
    ----------
    result : path-like
        The granular result file.
    out_dir : path-like
        Directory of the page.
    mu : float, optional
        Grain friction (for the Rankine/Jaky bounds).
    kind : {"auto", "silo", "heap"}
        Read-out; auto: a silo when the result has a ``silo floor`` or its fill is more than twice as tall as the
        box is wide.
    dpi : int
        Figure resolution.
    silo : porepipe.granular Silo settings, optional
        The scene's ``granular.silo`` (its shape's theory is fitted).
    gravity : porepipe.granular Gravity settings, optional
        The scene's ``granular.gravity``: a ramp of g to ~0 makes the heap read-out use the last frame before it
        and adds the elastic constants of the unloading (§4.3.3).
    young : float, optional
        The grains' Young's modulus (N/m), set beside the packing's.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    tables = read_granular(result)
    attrs = read_attrs(result)
    kind = _kind(tables) if kind == "auto" else kind
    parts, frame = [], -1
    cost = (
        f"{int(attrs.get('n_particles', 0))} particles, {int(attrs.get('steps', 0))} steps of "
        f"{float(attrs.get('dt_s', 0)):.3g} s, {float(attrs.get('particle_steps_per_s', 0)):.3g} particle-steps/s"
    )
    if kind == "silo":
        a = analyse_silo(tables, mu=mu, shape=silo)
        write_csv(
            out_dir / "granular_wall_pressure.csv",
            silo_pressure_figure(a, out_dir / "granular_wall_pressure.png", dpi, mu=mu),
        )
        th = thesis_values(a, mu) or {**THESIS_SILO, "section": "§3.1"}
        rows = _silo_rows(a, th)
        if mu is not None:
            b = lateral_pressure_bounds(mu)
            rows.append(
                [
                    f"bounds for mu = {mu:g}: Rankine active / Jaky / Rankine passive",
                    f"{b['rankine_active']:.2f} / {b['jaky']:.2f} / {b['rankine_passive']:.2f}",
                    "same",
                ]
            )
        parts += [
            f"<h2>{'Janssen' if a['theory'] is None else a['shape'].capitalize()} silo</h2>",
            f"<p>{a['n_particles']} grains in a silo {2 * a['half_width_m'] * 1e3:.0f} mm wide at the fill "
            f"surface and {2 * a['bottom_half_width_m'] * 1e3:.0f} mm at the floor, fill "
            f"{a['fill_height_m']:.3f} m; fits above the grey line (the lowest bottom width is the floor's zone). "
            f"Cost: {html.escape(cost)}.</p>",
            "<img src='granular_wall_pressure.png' alt='wall pressure'>",
            _table(["quantity", "this run", f"thesis {th['section']}"], rows),
            "<p class=note>Data: <a href='granular_wall_pressure.csv'>granular_wall_pressure.csv</a></p>",
        ]
        directions = force_directions(frame_contacts(tables, -1))
    else:
        unload = unloading_frames(tables, gravity)
        frame = -1 if unload is None else unload[0]
        try:
            h = analyse_heap(tables, frame)
        except PorepipeError as err:  # a heap of a few grains: the page still shows its fabric and network
            parts.append(f"<p class=note>Heap not measured: {html.escape(str(err))} (too few grains?).</p>")
            directions = force_directions(frame_contacts(tables, frame))
        else:
            parts += _heap_part(h, cost, out_dir, dpi)
            parts += _stress_angle_part(tables, h, mu, out_dir, dpi, frame)
            if unload is not None:
                parts += _elastic_part(tables, unload, young, out_dir)
            directions = h["directions"]
    write_csv(
        out_dir / "granular_directions.csv",
        direction_figure(directions, out_dir / "granular_directions.png", dpi),
    )
    write_csv(
        out_dir / "granular_network.csv", network_figure(tables, out_dir / "granular_network.png", dpi, frame)
    )
    parts += [
        "<h2>Fabric</h2>",
        "<img src='granular_directions.png' alt='P(alpha)'> <img src='granular_network.png' alt='force network'>",
        "<p class=note>Data: <a href='granular_directions.csv'>granular_directions.csv</a>, "
        "<a href='granular_network.csv'>granular_network.csv</a></p>",
    ]
    return "\n".join(parts)


def granular_report(
    result,
    out_html,
    *,
    scene_name: str = "",
    mu: float | None = None,
    kind: str = "auto",
    silo=None,
    gravity=None,
    young: float | None = None,
    ensembles: list[dict] | None = None,
) -> Path:
    """Write a stand-alone page with the granular section of ``result`` (a scene without a sweep).

    ``ensembles`` (:func:`read_heap_ensemble` results, e.g. poured and layered heaps over seeds) put the
    floor-pressure dip over seeds first; ``result`` (one of the seeds) then gives the single-heap section.
    """
    out_html = Path(out_html)
    out_html.parent.mkdir(parents=True, exist_ok=True)
    body = dip_ensemble_part(ensembles, out_html.parent) if ensembles else []
    body.append(
        granular_section(result, out_html.parent, mu=mu, kind=kind, silo=silo, gravity=gravity, young=young)
    )
    page = (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>porepipe granular report {html.escape(scene_name)}</title></head><body>"
        f"<h1>porepipe granular report: {html.escape(scene_name)}</h1>\n{chr(10).join(body)}</body></html>\n"
    )
    return write_text_atomic(out_html, page)
