"""Measurements on the granular engine's output (Schinner 2001 §2.3, digest §1.10).

Every function works on plain arrays or on the tables of :func:`porepipe.granular.read_granular`; the helpers
:func:`frame_particles` and :func:`frame_contacts` pick one frame out of a result file's tables.

Conventions: forces ``fx_N, fy_N`` act on particle ``i`` at the application point ``sx_m, sy_m`` (-F on ``j``);
``j >= n_particles`` is wall ``j - n_particles``. Stresses are compressive positive. 2-D units: forces N/m,
pressures and stresses N/m (force per length), areas m².
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from porepipe._shared.errors import PorepipeError


# -- selecting a frame -------------------------------------------------------------------------------------------
def frame_particles(tables: dict, frame: int = -1) -> dict:
    """World-frame outlines and centroids of the active particles of one frame.

    Parameters
    ----------
    tables : dict
        Output of :func:`porepipe.granular.read_granular`.
    frame : int
        Frame index (negative counts from the end).

    Returns
    -------
    dict
        ``polygons`` (list of (n_i, 2) arrays, all particles, inactive ones included), ``centroid`` (N, 2),
        ``active`` (N,) bool, ``area`` (N,), ``index`` (the frame index used).
    """
    ds = tables["frames"]
    nf = ds.sizes["frame"]
    f = frame % nf if -nf <= frame < nf else None
    if f is None:
        raise PorepipeError(f"frame {frame} out of range: the result has {nf} frames")
    pos = np.concatenate([ds["position_m"].values[f], ds["angle_rad"].values[f][:, None]], axis=1)
    verts = ds["vertices_m"].values
    nc = ds["n_corners"].values
    polys = []
    for k in range(len(pos)):
        c, s = math.cos(pos[k, 2]), math.sin(pos[k, 2])
        body = verts[k, : nc[k]]
        polys.append(body @ np.array([[c, s], [-s, c]]) + pos[k, :2])
    return {
        "polygons": polys,
        "centroid": pos[:, :2].copy(),
        "active": ds["active"].values[f].astype(bool),
        "area": np.array([polygon_area(p) for p in polys]),
        "index": f,
    }


def require_grains(parts: dict, who: str) -> None:
    """One line naming ``who`` and the frame when :func:`frame_particles` found no active grain in it."""
    if not parts["active"].any():
        raise PorepipeError(
            f"{who}: frame {parts['index']} has no active grains (none inserted yet, or all removed); "
            "pick a frame with grains"
        )


def frame_contacts(tables: dict, frame: int = -1) -> dict:
    """The contact rows of one frame as a dict of arrays (keys as in the ``contacts`` table)."""
    nf = tables["frames"].sizes["frame"]
    if not -nf <= frame < nf:
        raise PorepipeError(f"frame {frame} out of range: the result has {nf} frames")
    f = frame % nf
    c = tables["contacts"]
    rows = c["frame"].values == f
    return {k: c[k].values[rows] for k in c.data_vars if k != "frame"}


# -- geometry helpers --------------------------------------------------------------------------------------------
def polygon_area(p) -> float:
    """Area of a simple polygon (shoelace), m²."""
    p = np.asarray(p, dtype=np.float64)
    x, y = p[:, 0], p[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _clip_box(poly: np.ndarray, box) -> tuple[np.ndarray, np.ndarray]:
    """Clip a convex polygon by an axis-aligned box (Sutherland-Hodgman); returns corners and an 'own corner' flag."""
    x0, y0, x1, y1 = box
    pts = [(float(a), float(b), True) for a, b in poly]
    for axis, bound, keep_low in ((0, x0, False), (0, x1, True), (1, y0, False), (1, y1, True)):
        if not pts:
            break
        out = []
        for m in range(len(pts)):
            p, q = pts[m], pts[(m + 1) % len(pts)]
            pin = p[axis] <= bound if keep_low else p[axis] >= bound
            qin = q[axis] <= bound if keep_low else q[axis] >= bound
            if pin:
                out.append(p)
            if pin != qin:
                t = (bound - p[axis]) / (q[axis] - p[axis])
                out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), False))
        pts = out
    if len(pts) < 3:
        return np.zeros((0, 2)), np.zeros(0, bool)
    arr = np.array(pts)
    return arr[:, :2], arr[:, 2].astype(bool)


def _hull_area(points) -> float:
    pts = np.unique(np.asarray(points, dtype=np.float64).reshape(-1, 2), axis=0)
    if len(pts) < 3:
        return 0.0
    try:
        return float(ConvexHull(pts).volume)
    except QhullError:  # collinear points: no area
        return 0.0


# -- packing fraction (Eqs. 2.43-2.45) -------------------------------------------------------------------------
def packing_fraction(polygons, box) -> dict[str, float]:
    """Local packing fraction in a rectangular test area, naive (Eq. 2.44) and hull-corrected (Eq. 2.45).

    Parameters
    ----------
    polygons : sequence of (n_i, 2) array_like
        World-frame particle outlines (convex).
    box : (x0, y0, x1, y1)
        The test area A.

    Returns
    -------
    dict
        ``naive`` = sum alpha_i a_i / A; ``corrected`` = sum alpha_i a_i / A_k with A_k the convex hull of the
        particles' corners inside A and the crossings of their outlines with A's boundary; ``solid_m2``,
        ``area_m2``, ``hull_m2``.
    """
    x0, y0, x1, y1 = (float(v) for v in box)
    if not (x1 > x0 and y1 > y0):
        raise PorepipeError(f"packing_fraction: the test area {box} is empty (need x1 > x0, y1 > y0)")
    solid, pts = 0.0, []
    for p in polygons:
        p = np.asarray(p, dtype=np.float64)
        if p[:, 0].max() <= x0 or p[:, 0].min() >= x1 or p[:, 1].max() <= y0 or p[:, 1].min() >= y1:
            continue
        clipped, own = _clip_box(p, (x0, y0, x1, y1))
        if len(clipped) == 0:
            continue
        solid += polygon_area(clipped)
        # E1 (own corners inside A) and E2 (outline crossings with A's boundary); box corners are neither
        pts.append(
            clipped[
                own | _on_boundary(clipped, (x0, y0, x1, y1)) & ~_is_box_corner(clipped, (x0, y0, x1, y1))
            ]
        )
    area = (x1 - x0) * (y1 - y0)
    hull = _hull_area(np.concatenate(pts)) if pts else 0.0
    return {
        "naive": solid / area,
        "corrected": solid / hull if hull > 0 else 0.0,
        "solid_m2": solid,
        "area_m2": area,
        "hull_m2": hull,
    }


def _on_boundary(p, box, rtol=1e-12):
    x0, y0, x1, y1 = box
    tol = rtol * max(x1 - x0, y1 - y0)
    return (
        (np.abs(p[:, 0] - x0) < tol)
        | (np.abs(p[:, 0] - x1) < tol)
        | (np.abs(p[:, 1] - y0) < tol)
        | (np.abs(p[:, 1] - y1) < tol)
    )


def _is_box_corner(p, box, rtol=1e-12):
    x0, y0, x1, y1 = box
    tol = rtol * max(x1 - x0, y1 - y0)
    onx = (np.abs(p[:, 0] - x0) < tol) | (np.abs(p[:, 0] - x1) < tol)
    ony = (np.abs(p[:, 1] - y0) < tol) | (np.abs(p[:, 1] - y1) < tol)
    return onx & ony


# -- wall and floor pressure (Eqs. 2.36-2.40) ---------------------------------------------------------------------
def wall_contacts(contacts: dict, n_particles: int, wall: int, wall_vertices) -> dict:
    """Contacts of one wall with the inward normal component of their force (the pressure contribution).

    Parameters
    ----------
    contacts : dict
        One frame's contacts (:func:`frame_contacts`).
    n_particles : int
        Number of particles (walls are ``j >= n_particles``).
    wall : int
        Wall index (order of ``wall_vertices_m`` in the result).
    wall_vertices : (M, 2) array_like
        World-frame corners of that wall (NaN padding allowed).

    Returns
    -------
    dict
        ``point`` (K, 2) application points, ``normal_force`` (K,) force pressing on the wall along its local
        outward normal (N/m), ``tangential_force`` (K,), ``normal`` (K, 2) the wall normal used (pointing out of the
        wall, towards the grains: the nearest edge's).
    """
    w = np.asarray(wall_vertices, dtype=np.float64)
    w = w[np.isfinite(w).all(axis=1)]
    rows = contacts["j"] == n_particles + wall
    pts = np.column_stack([contacts["sx_m"][rows], contacts["sy_m"][rows]])
    force = np.column_stack([contacts["fx_N"][rows], contacts["fy_N"][rows]])  # on the particle
    normal = _nearest_edge_normal(w, pts)
    fn = np.einsum(
        "ij,ij->i", force, normal
    )  # the wall pushes the grain out along n: = the pressure it takes
    tangent = np.column_stack([-normal[:, 1], normal[:, 0]])
    return {
        "point": pts,
        "normal_force": fn,
        "tangential_force": np.einsum("ij,ij->i", force, tangent),
        "normal": normal,
    }


def _nearest_edge_normal(w: np.ndarray, pts: np.ndarray) -> np.ndarray:
    ctr = w.mean(axis=0)
    a, b = w, np.roll(w, -1, axis=0)
    d = b - a
    length2 = np.einsum("ij,ij->i", d, d)
    t = np.clip(np.einsum("kij,ij->ki", pts[:, None, :] - a[None], d) / length2, 0, 1)
    near = a[None] + t[..., None] * d[None]
    dist = np.linalg.norm(pts[:, None, :] - near, axis=2)
    e = np.argmin(dist, axis=1) if len(pts) else np.zeros(0, np.int64)
    n = np.column_stack([d[e, 1], -d[e, 0]]) / np.sqrt(length2[e])[:, None]
    flip = np.einsum("ij,ij->i", n, a[e] - ctr) < 0
    n[flip] *= -1
    return n


def pressure_profile(
    coord,
    normal_force,
    length: float,
    centres=None,
    half_width: float | None = None,
    contacts_per_window: float = 15.0,
    extent: tuple[float, float] | None = None,
) -> dict[str, np.ndarray | float]:
    """Mean pressure and the sliding-window profile p(u) = (1/2b) sum F_n Theta(|u_i - u| <= b) (Eqs. 2.36-2.40).

    Parameters
    ----------
    coord : array_like
        Position of each contact along the wall (x for a floor, y or depth for a side wall), m.
    normal_force : array_like
        Force of each contact normal to the wall, N/m.
    length : float
        Wall length l of the mean pressure (1/l) sum F_n.
    centres : array_like, optional
        Window centres; default 200 points over the contacts' range.
    half_width : float, optional
        Window half-width b; default such that a window holds ``contacts_per_window`` contacts on average
        (the thesis's rule of thumb is 10-20).
    contacts_per_window : float
        Used when ``half_width`` is not given.
    extent : (float, float), optional
        Where the wall is in contact with grains (e.g. floor to fill height): a window reaching past it is
        divided by its length inside the extent only (else profiles droop within b of the ends).

    Returns
    -------
    dict
        ``mean`` (N/m per m = pressure), ``centres``, ``pressure``, ``count`` (contacts per window),
        ``running_mean`` (the profile averaged once more over a window, against lattice spikes), ``half_width``.
    """
    u = np.asarray(coord, dtype=np.float64)
    fn = np.asarray(normal_force, dtype=np.float64)
    length = float(length)
    if not length > 0:
        raise PorepipeError(f"pressure_profile: wall length must be positive, got {length}")
    if len(u) == 0:
        raise PorepipeError("pressure_profile: no contacts on this wall")
    if u.shape != fn.shape or not (np.all(np.isfinite(u)) and np.all(np.isfinite(fn))):
        raise PorepipeError(
            f"pressure_profile: coord and normal_force must be finite and of one shape, got {u.shape}, {fn.shape}"
        )
    span = float(u.max() - u.min())
    if half_width is None and not span > 0:
        raise PorepipeError(
            f"pressure_profile: all {len(u)} contacts lie at one coordinate {u[0]:g}, which sets no window width; "
            "give half_width"
        )
    if half_width is None:
        half_width = 0.5 * span * contacts_per_window / len(u)
    b = float(half_width)
    if not (b > 0 and np.isfinite(b)):
        raise PorepipeError(f"pressure_profile: half_width must be positive and finite, got {half_width}")
    if centres is None:
        centres = np.linspace(u.min(), u.max(), 200)
    centres = np.asarray(centres, dtype=np.float64)
    if centres.ndim != 1 or len(centres) == 0 or not np.all(np.isfinite(centres)):
        raise PorepipeError(
            "pressure_profile: centres must be a non-empty 1-D array of finite window centres, "
            f"got shape {centres.shape}"
        )
    inside = np.abs(u[None, :] - centres[:, None]) <= b
    width = np.full(len(centres), 2 * b)
    if extent is not None:
        width = np.minimum(centres + b, extent[1]) - np.maximum(centres - b, extent[0])
        width = np.where(width > 0, width, np.nan)
    p = (inside * fn[None, :]).sum(axis=1) / width
    step = np.median(np.diff(centres)) if len(centres) > 1 else b
    m = max(int(round(b / step)), 1) if step > 0 else 1
    kernel = np.ones(2 * m + 1) / (2 * m + 1)
    running = np.convolve(np.pad(p, m, mode="edge"), kernel, mode="valid")
    return {
        "mean": float(fn.sum() / length),
        "centres": centres,
        "pressure": p,
        "count": inside.sum(axis=1),
        "running_mean": running,
        "half_width": b,
    }


def pressure_dip(x, pressure, apex_x: float, noise=None) -> dict[str, float]:
    """Depth of the floor-pressure minimum under a heap's apex (the "dip", Schinner 2001 §4.2).

    ``dip = 1 - p(apex) / p_side`` with p_side the mean of the profile's maxima on the left and on the right of the
    apex (each half includes the apex). A profile that peaks under the apex (pressure ~ local height, a layered
    heap) gives 0; experiments on conical piles give up to 0.5 (the digest's §2.2).

    Parameters
    ----------
    x : array_like
        Window centres along the floor (sorted), m.
    pressure : array_like
        Smoothed floor pressure there (e.g. ``pressure_profile(...)["running_mean"]``), N/m.
    apex_x : float
        x of the heap's apex (inside the range of ``x``).
    noise : array_like, optional
        The unsmoothed window pressures at the same ``x``: their scatter about ``pressure`` over the central half
        of the heap, relative to p_side, is returned as ``fluctuation`` (a dip below it is not resolved; the thesis's
        criterion for its layered heaps).

    Returns
    -------
    dict
        ``dip``, ``p_apex``, ``p_side``, ``x_left_max``, ``x_right_max``, ``fluctuation`` (NaN without ``noise``).
    """
    x = np.asarray(x, dtype=np.float64)
    p = np.asarray(pressure, dtype=np.float64)
    if x.shape != p.shape or x.ndim != 1 or len(x) < 3:
        raise PorepipeError(
            f"pressure_dip: x and pressure must be 1-D of one length >= 3, got {x.shape}, {p.shape}"
        )
    if not x[0] <= apex_x <= x[-1]:
        raise PorepipeError(f"pressure_dip: apex x = {apex_x} outside the profile [{x[0]}, {x[-1]}]")
    p_apex = float(np.interp(apex_x, x, p))
    left, right = x <= apex_x, x >= apex_x
    if np.isinf(p).any() or math.isnan(p_apex) or np.isnan(p[left]).all() or np.isnan(p[right]).all():
        raise PorepipeError(
            f"pressure_dip: pressure must not be infinite, nor NaN at the apex x = {apex_x} or all along one side"
        )
    il = np.flatnonzero(left)[np.nanargmax(p[left])] if left.any() else None
    ir = np.flatnonzero(right)[np.nanargmax(p[right])] if right.any() else None
    sides = [max(p[k], p_apex) for k in (il, ir) if k is not None]
    p_side = float(np.mean(sides))
    if not p_side > 0:
        raise PorepipeError("pressure_dip: the profile has no positive pressure")
    fluct = float("nan")
    if noise is not None:
        q = np.asarray(noise, dtype=np.float64)
        half = 0.25 * (x[-1] - x[0])
        core = np.abs(x - apex_x) <= half
        fluct = float(np.nanstd(q[core] - p[core]) / p_side)
    return {
        "dip": 1.0 - p_apex / p_side,
        "p_apex": p_apex,
        "p_side": p_side,
        "x_left_max": float(x[il]) if il is not None else float("nan"),
        "x_right_max": float(x[ir]) if ir is not None else float("nan"),
        "fluctuation": fluct,
    }


def scaled_profile(x, pressure, apex_x: float, half_base: float, rho_g_h: float, grid) -> np.ndarray:
    """A floor-pressure profile on the thesis's axes: p / (rho g h) at s = (x - apex) / (base / 2), on ``grid``.

    Outside the profile's range the value is NaN, so :func:`numpy.nanmean` over realisations (an ensemble, as the
    thesis's 9 heaps) averages what each covers.
    """
    if not (half_base > 0 and rho_g_h > 0):
        raise PorepipeError(
            f"scaled_profile: half_base and rho_g_h must be positive, got {half_base}, {rho_g_h}"
        )
    s = (np.asarray(x, dtype=np.float64) - apex_x) / half_base
    return np.interp(
        np.asarray(grid, dtype=np.float64), s, np.asarray(pressure) / rho_g_h, left=np.nan, right=np.nan
    )


# -- contact statistics ------------------------------------------------------------------------------------------
def coordination(contacts: dict, n_particles: int, active=None, walls: bool = True) -> dict:
    """Contacts per particle K, its mean and the distribution P(K) (§2.3.2).

    ``walls`` counts wall contacts too; ``active`` (N,) bool restricts the statistics to present particles.
    """
    i = np.asarray(contacts["i"], dtype=np.int64)
    j = np.asarray(contacts["j"], dtype=np.int64)
    if not walls:
        keep = j < n_particles
        i, j = i[keep], j[keep]
    count = (
        np.bincount(i, minlength=n_particles)
        + np.bincount(j[j < n_particles], minlength=n_particles)[:n_particles]
    )
    sel = np.ones(n_particles, bool) if active is None else np.asarray(active, bool)
    k = count[sel]
    hist = np.bincount(k) / max(len(k), 1)
    return {
        "per_particle": count,
        "mean": float(k.mean()) if len(k) else 0.0,
        "P": hist,
        "K": np.arange(len(hist)),
    }


def force_directions(contacts: dict, bins: int = 36) -> dict:
    """Histogram P(alpha) of contact-force directions tan(alpha) = F_y/F_x (Eq. 2.41), folded so P(a) = P(a + pi).

    Returns ``edges`` (rad, on [0, pi)), ``density`` (normalised to integrate to 1 over [0, pi)) and ``alpha``.
    """
    f = np.column_stack([contacts["fx_N"], contacts["fy_N"]])
    if len(f) == 0:
        raise PorepipeError("force_directions: no contacts (a density of no directions is 0/0)")
    alpha = np.mod(np.arctan2(f[:, 1], f[:, 0]), np.pi)
    density, edges = np.histogram(alpha, bins=bins, range=(0.0, np.pi), density=True)
    return {"edges": edges, "density": density, "alpha": alpha}


def force_magnitudes(contacts: dict, bins: int = 30, max_ratio: float = 5.0) -> dict:
    """Distribution P(F/<F>) of the contact-force magnitudes (§2.3.2)."""
    f = np.hypot(contacts["fx_N"], contacts["fy_N"])
    if len(f) == 0 or f.mean() <= 0:
        raise PorepipeError("force_magnitudes: no loaded contacts")
    ratio = f / f.mean()
    density, edges = np.histogram(ratio, bins=bins, range=(0.0, max_ratio), density=True)
    return {"edges": edges, "density": density, "mean_N": float(f.mean()), "ratio": ratio}


# -- stress tensor (Eqs. 2.46-2.52) ------------------------------------------------------------------------------
def stress_tensor(contacts: dict, centroid, box=None, members=None, area: float | None = None) -> dict:
    """Coarse-grained stress of a test area from the contacts of the particles in it (Eq. 2.52).

    sigma_ij = -(1/2V) sum (x_i F_j + x_j F_i) over every contact of a member particle, F the force on that
    particle at the application point x (taken from the centroid of all application points; forces between two
    members cancel), sign chosen so that compression is positive.

    Parameters
    ----------
    contacts : dict
        One frame's contacts.
    centroid : (N, 2) array_like
        Particle centroids.
    box : (x0, y0, x1, y1), optional
        Members are the particles whose centroid lies in it (the thesis's procedure).
    members : (N,) bool array_like, optional
        Or give the members directly.
    area : float, optional
        V; default the area of the convex hull of the members' application points (the thesis's choice).

    Returns
    -------
    dict
        ``sigma`` (2, 2) in N/m (xx, xy; yx, yy; y upwards), ``area_m2``, ``principal`` (major, minor), ``psi_rad``
        (major axis from the vertical, in (-pi/2, pi/2], positive towards +x), ``k`` = sigma_xx/sigma_yy,
        ``members`` (count).
    """
    xy = np.asarray(centroid, dtype=np.float64)
    if members is None:
        if box is None:
            raise PorepipeError("stress_tensor: give a test area box or a members mask")
        x0, y0, x1, y1 = box
        members = (xy[:, 0] >= x0) & (xy[:, 0] < x1) & (xy[:, 1] >= y0) & (xy[:, 1] < y1)
    members = np.asarray(members, bool)
    i = np.asarray(contacts["i"], dtype=np.int64)
    j = np.asarray(contacts["j"], dtype=np.int64)
    n = len(members)
    pad = np.concatenate([members, np.zeros(max(int(j.max(initial=0)) + 1 - n, 0), bool)])
    on_i, on_j = pad[i], pad[j]
    pts = np.column_stack([contacts["sx_m"], contacts["sy_m"]])
    f = np.column_stack([contacts["fx_N"], contacts["fy_N"]])
    use_pts = np.concatenate([pts[on_i], pts[on_j]])
    forces = np.concatenate([f[on_i], -f[on_j]])
    if len(use_pts) == 0:
        raise PorepipeError("stress_tensor: the test area has no contacts")
    v = _hull_area(use_pts) if area is None else float(area)
    if not v > 0:
        raise PorepipeError("stress_tensor: zero test area (fewer than 3 non-collinear application points)")
    x = use_pts - use_pts.mean(axis=0)
    m = x.T @ forces
    sigma = -(m + m.T) / (2 * v)
    vals, vecs = np.linalg.eigh(sigma)
    major = vecs[:, 1]
    if major[1] < 0:
        major = -major
    psi = math.atan2(major[0], major[1])
    if psi <= -0.5 * math.pi:
        psi += math.pi
    return {
        "sigma": sigma,
        "area_m2": v,
        "principal": (float(vals[1]), float(vals[0])),
        "psi_rad": psi,
        "k": float(sigma[0, 0] / sigma[1, 1]) if sigma[1, 1] != 0 else float("nan"),
        "members": int(members.sum()),
    }


# -- angle of repose (§2.3, Eq. 2.42) ---------------------------------------------------------------------------
def surface_profile(points, bins) -> tuple[np.ndarray, np.ndarray]:
    """Highest point per x-interval: (its x, its height), both NaN where the interval is empty."""
    pts = np.asarray(points, dtype=np.float64)
    edges = np.asarray(bins, dtype=np.float64)
    idx = np.digitize(pts[:, 0], edges) - 1
    top = np.full((len(edges) - 1, 2), np.nan)
    for b in range(len(top)):
        sel = np.nonzero(idx == b)[0]
        if len(sel):
            top[b] = pts[sel[np.argmax(pts[sel, 1])]]
    return top[:, 0], top[:, 1]


def repose_angle_fit(centroid, x_range) -> dict[str, float]:
    """Angle of repose from a straight-line fit of the highest centroids in x-intervals over ``x_range`` (method a).

    ``x_range = (x0, x1, n_bins)``: fit interval and number of x-intervals (about one particle wide each). The
    line goes through the highest centroids themselves. Returns ``angle_rad`` (of |slope|), ``slope``,
    ``intercept``.
    """
    x0, x1, nb = x_range
    xc, top = surface_profile(centroid, np.linspace(x0, x1, int(nb) + 1))
    ok = np.isfinite(top)
    if ok.sum() < 2:
        raise PorepipeError(f"repose_angle_fit: fewer than 2 occupied intervals in [{x0}, {x1}]")
    slope, intercept = np.polyfit(xc[ok], top[ok], 1)
    return {"angle_rad": math.atan(abs(slope)), "slope": float(slope), "intercept": float(intercept)}


def repose_angle_integral(area_m2: float, base_m: float) -> float:
    """Angle of repose of a flank from tan(phi) = 2 a/b² (Eq. 2.42): a the material's area, b the flank's base.

    For a whole symmetric heap give half its area and half its base.
    """
    a, b = float(area_m2), float(base_m)
    if not (a > 0 and b > 0):
        raise PorepipeError(f"repose_angle_integral: area and base must be positive, got {a}, {b}")
    return math.atan(2 * a / b**2)


# -- contact persistence (§4.4) --------------------------------------------------------------------------------------
def contact_persistence(before: dict, after: dict, n_particles: int) -> float:
    """Fraction of the particle-particle contact pairs of ``before`` still in contact in ``after``."""

    def pairs(c):
        i, j = np.asarray(c["i"]), np.asarray(c["j"])
        keep = j < n_particles
        lo, hi = np.minimum(i[keep], j[keep]), np.maximum(i[keep], j[keep])
        return set(zip(lo.tolist(), hi.tolist(), strict=True))

    a = pairs(before)
    if not a:
        raise PorepipeError("contact_persistence: no particle-particle contacts in the first frame")
    return len(a & pairs(after)) / len(a)


# -- strain and plane-strain elastic constants (§4.3.3) -----------------------------------------------------------
def displacement_grid(before, after, x_edges, y_edges, active=None) -> dict[str, np.ndarray]:
    """Mean particle displacement in a grid of test areas (cells by the particles' positions ``before``).

    Parameters
    ----------
    before, after : (N, 2) array_like
        Centroids in the reference and the deformed state.
    x_edges, y_edges : array_like
        Cell edges.
    active : (N,) bool array_like, optional
        Particles to use.

    Returns
    -------
    dict
        ``u`` (ny, nx, 2) mean displacement, ``x`` (ny, nx, 2) mean reference position, ``count`` (ny, nx); cells
        without particles are NaN.
    """
    x0 = np.asarray(before, dtype=np.float64)
    du = np.asarray(after, dtype=np.float64) - x0
    if active is not None:
        keep = np.asarray(active, bool)
        x0, du = x0[keep], du[keep]
    xe, ye = np.asarray(x_edges, dtype=np.float64), np.asarray(y_edges, dtype=np.float64)
    ix = np.digitize(x0[:, 0], xe) - 1
    iy = np.digitize(x0[:, 1], ye) - 1
    ok = (ix >= 0) & (ix < len(xe) - 1) & (iy >= 0) & (iy < len(ye) - 1)
    shape = (len(ye) - 1, len(xe) - 1)
    flat = np.ravel_multi_index((iy[ok], ix[ok]), shape)
    count = np.bincount(flat, minlength=shape[0] * shape[1]).reshape(shape)
    u = np.full((*shape, 2), np.nan)
    x = np.full((*shape, 2), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        for c in range(2):
            u[..., c] = np.bincount(flat, du[ok, c], shape[0] * shape[1]).reshape(shape) / count
            x[..., c] = np.bincount(flat, x0[ok, c], shape[0] * shape[1]).reshape(shape) / count
    return {"u": u, "x": x, "count": count}


def diagonal_strain(grid: dict) -> tuple[np.ndarray, np.ndarray]:
    """u_xx = du_x/dx and u_zz = du_z/dz by central differences of the cell means (Eqs. 4.7-4.9).

    The differences are taken between the neighbouring cells' mean reference positions; edge cells are NaN.
    """
    u, x = grid["u"], grid["x"]
    uxx = np.full(u.shape[:2], np.nan)
    uzz = np.full(u.shape[:2], np.nan)
    uxx[:, 1:-1] = (u[:, 2:, 0] - u[:, :-2, 0]) / (x[:, 2:, 0] - x[:, :-2, 0])
    uzz[1:-1, :] = (u[2:, :, 1] - u[:-2, :, 1]) / (x[2:, :, 1] - x[:-2, :, 1])
    return uxx, uzz


def plane_strain_constants(sigma_xx, sigma_zz, u_xx, u_zz) -> dict[str, np.ndarray]:
    """Poisson ratio, Young's modulus and bulk modulus of an isotropic plane-strain medium (Eqs. 4.4, 4.5, 4.11).

    nu = (s_zz u_xx - s_xx u_zz)/((u_xx - u_zz)(s_xx + s_zz)), E = s_xx (1 + nu)(1 - 2 nu)/(u_xx (1 - nu) + nu u_zz),
    K = E/(2 (1 + nu)(1 - 2 nu)). Stress and strain must share a sign convention (e.g. both compression positive:
    the strain of loading, i.e. minus that of an unloading of g).
    """
    sxx, szz, uxx, uzz = (np.asarray(v, dtype=np.float64) for v in (sigma_xx, sigma_zz, u_xx, u_zz))
    with np.errstate(invalid="ignore", divide="ignore"):
        nu = (szz * uxx - sxx * uzz) / ((uxx - uzz) * (sxx + szz))
        young = sxx * (1 + nu) * (1 - 2 * nu) / (uxx * (1 - nu) + nu * uzz)
        bulk = 0.5 * young / ((1 + nu) * (1 - 2 * nu))
    return {"nu": nu, "E": young, "K": bulk}
