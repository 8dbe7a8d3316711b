"""Measurements (porepipe.granular._measure) on constructed cases with answers known by hand or by symmetry."""

import math

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.granular import Settings, Simulation, regular_polygon
from porepipe.granular import _measure as M


def _square(cx, cy, a):
    h = 0.5 * a
    return np.array([(cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)])


@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.37, 0.81), (0.93, 0.05)])
def test_packing_fraction_square_lattice_exact(offset):
    """Squares of side a on a square lattice of spacing d: any window of whole periods holds a²/d² (to rounding)."""
    a, d = 1.0, 1.25
    polys = [_square(m * d, n * d, a) for m in range(-2, 12) for n in range(-2, 12)]
    x0, y0 = offset[0] * d, offset[1] * d
    out = M.packing_fraction(polys, (x0, y0, x0 + 7 * d, y0 + 5 * d))
    assert out["naive"] == pytest.approx(a * a / (d * d), rel=1e-12)


def test_packing_fraction_hexagon_lattice_exact():
    """Regular hexagons of a honeycomb tiling shrunk by s about their centres: fraction s² in any whole period."""
    d, s = 1.0, 0.8  # centre spacing d (flat-to-flat width), hexagon circumradius d/sqrt(3) for the tiling
    hexagon = regular_polygon(6, s * d / math.sqrt(3), math.pi / 6)  # pointy top: rows are horizontal
    polys = []
    for n in range(-2, 14):
        for m in range(-2, 14):
            polys.append(hexagon + [m * d + 0.5 * d * (n % 2), n * d * math.sqrt(3) / 2])
    x0, y0 = 0.31, 0.17
    out = M.packing_fraction(polys, (x0, y0, x0 + 6 * d, y0 + 4 * math.sqrt(3) * d))
    assert out["naive"] == pytest.approx(s * s, rel=1e-12)


def test_packing_fraction_hull_correction_at_free_surface():
    """A 4 x 3 block of squares in a much larger window: the hull is the block's outline, so Eq. 2.45 is exact."""
    a, d = 1.0, 1.25
    polys = [_square(m * d, n * d, a) for m in range(4) for n in range(3)]
    out = M.packing_fraction(polys, (-5.0, -5.0, 10.0, 10.0))
    block = (3 * d + a) * (2 * d + a)
    assert out["naive"] == pytest.approx(12 * a * a / 225.0, rel=1e-12)
    assert out["corrected"] == pytest.approx(12 * a * a / block, rel=1e-12)
    with pytest.raises(PorepipeError, match="empty"):
        M.packing_fraction(polys, (1, 1, 1, 2))


def test_column_of_squares_floor_pressure_is_weight_over_width():
    """Three free-standing columns of five squares settle on the floor of a box: the mean floor pressure is the
    total weight over the floor length and a window around one column gives its weight over the window.

    The squares are placed touching, every other one shifted by a/20 sideways (exactly aligned equal squares have
    collinear sides, a degenerate overlap). Verlet integrator: with the Gear integrator such a column kept
    rattling (floor force off by up to 100 % after 0.5 s, reported to the engine's owner). Truth: static force
    balance. Tolerance 1e-3: the residual vibration at 0.25 s (measured deviation 2e-4)."""
    a, pitch = 0.01, 0.02
    parts = []
    for c in range(3):
        for n in range(5):
            v = _square(0.0, 0.0, a)
            parts.append(
                {
                    "vertices_m": v.tolist(),
                    "position_m": [0.01 + c * pitch + 0.05 * a * (-1) ** n, 0.5 * a + n * a],
                }
            )
    s = Settings.model_validate(
        {
            "duration_s": 0.25,
            "integrator": "verlet",
            "material": {"young_N_m": 1e6, "density_kg_m2": 1000.0, "damping": 1.0, "friction": 0.4},
            "box": {"lower_m": [0.0, 0.0], "upper_m": [3 * pitch, 0.1], "thickness_m": 0.01},
            "particles": parts,
        }
    )
    sim = Simulation(s, 0)
    sim.advance(round(0.25 / sim.dt))
    c = sim.contacts()
    floor = sim.wall_names.index("box floor")
    wv = sim.body[sim.n_mob + floor, : sim.nc[sim.n_mob + floor]] + sim.G[0, sim.n_mob + floor, :2]
    wc = M.wall_contacts(c, sim.n_mob, floor, wv)
    np.testing.assert_allclose(wc["normal"], np.tile([0.0, 1.0], (len(wc["normal"]), 1)), atol=1e-12)
    weight = sim.mass.sum() * 9.81
    prof = M.pressure_profile(
        wc["point"][:, 0], wc["normal_force"], 3 * pitch, centres=[0.01, 0.03], half_width=0.5 * pitch
    )
    assert prof["mean"] == pytest.approx(weight / (3 * pitch), rel=1e-3)
    np.testing.assert_allclose(prof["pressure"], weight / 3 / pitch, rtol=1e-3)
    # no side-wall load: the columns stand free
    left = M.wall_contacts(c, sim.n_mob, sim.wall_names.index("box left"), wv)
    assert len(left["point"]) == 0
    # one column of squares: every particle has two contacts except the top one (thesis §4.1: coordination 2, 1 on top)
    k = M.coordination(c, sim.n_mob)["per_particle"]
    np.testing.assert_array_equal(k.reshape(3, 5), np.tile([2, 2, 2, 2, 1], (3, 1)))


def _contacts(rows):
    keys = ("i", "j", "fx_N", "fy_N", "sx_m", "sy_m")
    arr = np.array(rows, dtype=np.float64).reshape(-1, 6)
    out = {k: arr[:, c] for c, k in enumerate(keys)}
    out["i"] = out["i"].astype(np.int64)
    out["j"] = out["j"].astype(np.int64)
    return out


def test_stress_tensor_single_loaded_contact_by_hand():
    """A square of side 2h (particle 0) pressed between a wall below (j = 2, walls start at n = 2) and particle 1
    above, each contact carrying F = (fx, fy). By hand, with x from the application points' centroid (0.3, 0):
    sum x (x) F = [[0, 0], [-2 h fx, -2 h fy]] (forces on particle 0: (-fx, -fy) at (0, h), (fx, fy) at (0, -h));
    sigma = -(m + m^T)/(2V): sigma_yy = 2 h fy/V, sigma_xy = h fx/V, sigma_xx = 0."""
    h, fx, fy = 0.002, 0.3, 1.7
    c = _contacts([(0, 2, fx, fy, 0.3, -h), (1, 0, fx, fy, 0.3, h)])
    centroid = np.array([[0.3, 0.0], [0.3, 2 * h]])
    v = 4 * h * h
    st = M.stress_tensor(c, centroid, members=[True, False], area=v)
    np.testing.assert_allclose(
        st["sigma"], [[0.0, h * fx / v], [h * fx / v, 2 * h * fy / v]], rtol=1e-12, atol=1e-12
    )
    sxy, syy = h * fx / v, 2 * h * fy / v
    assert st["psi_rad"] == pytest.approx(0.5 * math.atan2(2 * sxy, syy), rel=1e-12)
    # an internal contact (both ends members) cancels: adding particle 1 and its wall contact above changes
    # nothing but the sum over the new boundary
    c2 = _contacts([(0, 2, fx, fy, 0.3, -h), (1, 0, fx, fy, 0.3, h), (1, 3, -fx, -fy, 0.3, 3 * h)])
    both = M.stress_tensor(c2, centroid, members=[True, True], area=2 * v)
    # boundary forces now at (0.3, -h) and (0.3, 3h), centroid (0.3, h): arm 2h each, V doubled -> same sigma
    np.testing.assert_allclose(both["sigma"], st["sigma"], rtol=1e-12, atol=1e-12)


def test_stress_tensor_default_area_is_hull_of_application_points():
    h, f = 0.5, 2.0
    # a square compressed on all four sides by |f| at edge midpoints and sheared nowhere: sigma = f/(2h) I * ...
    c = _contacts([(0, 1, 0, f, 0, -h), (0, 1, 0, -f, 0, h), (0, 1, f, 0, -h, 0), (0, 1, -f, 0, h, 0)])
    st = M.stress_tensor(c, np.array([[0.0, 0.0]]), members=[True])
    # hull of the four edge midpoints: a diamond of area 2 h²; sum x F: xx = -2 h f, yy = -2 h f
    np.testing.assert_allclose(st["sigma"], np.eye(2) * (2 * h * f) / (2 * h * h), rtol=1e-12)
    assert st["area_m2"] == pytest.approx(2 * h * h, rel=1e-12)


def test_contact_statistics_by_hand():
    c = _contacts([(0, 1, 1, 1, 0, 0), (1, 2, -1, -1, 0, 0), (0, 3, 0, 2, 0, 0), (2, 4, 3, 0, 0, 0)])
    co = M.coordination(c, 3)
    np.testing.assert_array_equal(co["per_particle"], [2, 2, 2])  # walls are j = 3, 4
    np.testing.assert_array_equal(M.coordination(c, 3, walls=False)["per_particle"], [1, 2, 1])
    d = M.force_directions(c, bins=4)
    # (1,1) and (-1,-1) fold onto 45°, (0,2) is 90°, (3,0) is 0°: bins [0,45), [45,90), [90,135), [135,180)
    np.testing.assert_allclose(d["density"] * (math.pi / 4), [0.25, 0.5, 0.25, 0.0])
    fm = M.force_magnitudes(c)
    assert fm["mean_N"] == pytest.approx((2 * math.sqrt(2) + 2 + 3) / 4)
    after = _contacts([(1, 0, 0, 0, 0, 0), (2, 1, 0, 0, 0, 0)])
    assert M.contact_persistence(c, after, 3) == pytest.approx(1.0)  # both particle pairs survive
    assert M.contact_persistence(c, _contacts([(0, 2, 0, 0, 0, 0)]), 3) == 0.0


def test_repose_angle_on_a_triangular_heap():
    """Points filling a triangle of base 2 L and slope 30°: the fit and the integral method (on one flank: area
    L² tan(phi)/2, base L) both return 30°."""
    phi, L = math.radians(30.0), 1.0
    xs = np.linspace(-L, L, 4001)
    top = (L - np.abs(xs)) * math.tan(phi)
    pts = np.column_stack([xs, top])
    right = M.repose_angle_fit(pts, (0.1, 0.9, 40))
    assert right["angle_rad"] == pytest.approx(phi, rel=1e-6)
    assert right["slope"] < 0
    assert M.repose_angle_integral(0.5 * L * L * math.tan(phi), L) == pytest.approx(phi, rel=1e-12)


def test_pressure_profile_windows():
    """Equal forces 1 N at unit spacing: a window of half-width b holds 2b contacts, so p = 1 N/m everywhere."""
    u = np.arange(100.0)
    prof = M.pressure_profile(u, np.ones(100), 100.0, centres=np.arange(10.5, 90.0), half_width=5.0)
    np.testing.assert_allclose(prof["pressure"], 1.0)
    assert prof["mean"] == pytest.approx(1.0)
    auto = M.pressure_profile(u, np.ones(100), 100.0, contacts_per_window=15)
    assert np.median(auto["count"]) == pytest.approx(15, abs=1)


def test_strain_of_an_affine_field_and_plane_strain_constants():
    """Points on a regular lattice displaced by u = G x: the cell-mean central differences return G's diagonal
    exactly (affine field, aligned cell means); Hooke's plane-strain law with E = 2.5, nu = 0.3 inverted by
    Eqs. 4.4/4.5/4.11 returns them to rounding."""
    g = np.array([[-2e-3, 5e-4], [3e-4, -4e-3]])
    xs, ys = np.meshgrid(np.arange(0.25, 10, 0.5), np.arange(0.25, 8, 0.5))
    x0 = np.column_stack([xs.ravel(), ys.ravel()])
    grid = M.displacement_grid(x0, x0 + x0 @ g.T, np.arange(0, 10.1, 1.0), np.arange(0, 8.1, 1.0))
    assert (grid["count"] == 4).all()
    uxx, uzz = M.diagonal_strain(grid)
    np.testing.assert_allclose(uxx[:, 1:-1], g[0, 0], rtol=1e-9)
    np.testing.assert_allclose(uzz[1:-1, :], g[1, 1], rtol=1e-9)
    young, nu, exx, ezz = 2.5, 0.3, 1e-3, 3e-3
    c = young / ((1 + nu) * (1 - 2 * nu))
    sxx, szz = c * ((1 - nu) * exx + nu * ezz), c * ((1 - nu) * ezz + nu * exx)
    out = M.plane_strain_constants(sxx, szz, exx, ezz)
    assert float(out["nu"]) == pytest.approx(nu, rel=1e-12)
    assert float(out["E"]) == pytest.approx(young, rel=1e-12)
    # Eq. 4.10: u_ii = sigma_ii/(2K) in plane strain
    assert float(out["K"]) == pytest.approx((sxx + szz) / (2 * (exx + ezz)), rel=1e-12)


# -- the floor-pressure dip (Schinner 2001 §4.2) -------------------------------------------------------------------
def _piecewise(x, nodes):
    """Piecewise-linear profile through (x, p) nodes."""
    xs, ps = zip(*nodes, strict=True)
    return np.interp(x, xs, ps)


def test_pressure_dip_is_zero_for_pressure_proportional_to_height():
    """A wedge heap whose floor pressure follows the local height (columns, layered heaps): no dip."""
    x = np.linspace(-1.0, 1.0, 201)
    p = _piecewise(x, [(-1, 0), (0, 1), (1, 0)])
    out = M.pressure_dip(x, p, 0.0)
    assert out["dip"] == pytest.approx(0.0, abs=1e-12)
    assert out["p_side"] == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize(
    ("nodes", "dip"),
    [
        ([(-1, 0), (-0.2, 1), (0, 0.6), (0.2, 1), (1, 0)], 0.4),  # symmetric "M": 1 - 0.6/1
        ([(-1, 0), (-0.3, 1), (0, 0.45), (0.25, 0.8), (1, 0)], 0.5),  # asymmetric: 1 - 0.45/((1 + 0.8)/2)
    ],
)
def test_pressure_dip_of_a_constructed_minimum(nodes, dip):
    x = np.linspace(-1.0, 1.0, 401)  # holds every node exactly
    out = M.pressure_dip(x, _piecewise(x, nodes), 0.0)
    assert out["dip"] == pytest.approx(dip, rel=1e-12)
    assert out["x_left_max"] == pytest.approx(nodes[1][0], abs=1e-12)
    assert out["x_right_max"] == pytest.approx(nodes[3][0], abs=1e-12)


def test_pressure_dip_fluctuation_is_the_window_scatter():
    """Windows alternating +-delta about the smoothed profile: scatter delta, relative to p_side."""
    x = np.linspace(-1.0, 1.0, 200)
    p = _piecewise(x, [(-1, 0), (0, 2), (1, 0)])
    delta = 0.1
    noisy = p + delta * np.where(np.arange(len(x)) % 2 == 0, 1.0, -1.0)
    out = M.pressure_dip(x, p, 0.0, noise=noisy)
    assert out["fluctuation"] == pytest.approx(delta / out["p_side"], rel=1e-12)


def test_pressure_dip_rejects_bad_input():
    x = np.linspace(0.0, 1.0, 10)
    with pytest.raises(PorepipeError, match="apex x = 2.0 outside"):
        M.pressure_dip(x, x, 2.0)
    with pytest.raises(PorepipeError, match="one length"):
        M.pressure_dip(x, x[:-1], 0.5)


def test_scaled_profile_maps_to_the_thesis_axes():
    """s = (x - apex) / (base/2), p / (rho g h); NaN outside the measured range (ensemble averages skip it)."""
    x = np.linspace(0.1, 0.5, 41)  # apex 0.3, half base 0.2
    p = 50.0 * (1.0 - np.abs(x - 0.3) / 0.2)
    grid = np.array([-1.2, -0.95, -0.5, 0.0, 0.5, 0.95, 1.2])
    out = M.scaled_profile(x, p, 0.3, 0.2, 50.0, grid)
    np.testing.assert_allclose(out[1:-1], 1.0 - np.abs(grid[1:-1]), atol=1e-12)
    assert np.isnan(out[0]) and np.isnan(out[-1])
    with pytest.raises(PorepipeError, match="must be positive"):
        M.scaled_profile(x, p, 0.3, 0.0, 50.0, grid)


def _fake_heap(apex, half, rgh, nodes, repose_deg):
    x = np.linspace(apex - 1.5 * half, apex + 1.5 * half, 301)
    return {
        "floor_x_m": x,
        "floor_running_mean": rgh * _piecewise((x - apex) / half, nodes),
        "apex_x_m": apex,
        "foot_m": (apex - half, apex + half),
        "rho_g_h": rgh,
        "repose_left_rad": math.radians(repose_deg[0]),
        "repose_right_rad": math.radians(repose_deg[1]),
        "dip": {"dip": 0.0},
    }


def test_heap_ensemble_averages_on_the_thesis_axes():
    """Two heaps of different size, place and weight with the same scaled "M" profile, and a third with a triangle:
    the mean is their average on s = (x - apex)/(foot/2), p/(rho g h); its dip is that of the averaged nodes."""
    from porepipe.granular import heap_ensemble

    m = [(-1.5, 0), (-1, 0), (-0.2, 1), (0, 0.4), (0.2, 1), (1, 0), (1.5, 0)]
    tri = [(-1.5, 0), (-1, 0), (0, 1), (1, 0), (1.5, 0)]
    heaps = [
        _fake_heap(0.1, 0.2, 500.0, m, (20, 22)),
        _fake_heap(-0.3, 0.05, 80.0, m, (24, 26)),
        _fake_heap(0.0, 1.0, 1.0, tri, (22, 24)),
    ]
    e = heap_ensemble(heaps, points=121)  # grid step 0.02 holds s = 0, +-0.2
    # mean at s = 0: (0.4 + 0.4 + 1)/3 = 0.6; at s = +-0.2: (1 + 1 + 0.8)/3 = 0.9333 (the maxima of the mean)
    assert e["mean"][60] == pytest.approx(0.6, rel=1e-9)
    assert e["dip"]["dip"] == pytest.approx(1 - 0.6 / (2.8 / 3), rel=1e-9)
    assert e["repose_deg"] == pytest.approx((23.0, np.std([20, 22, 24, 26, 22, 24])), rel=1e-12)
    assert e["n"] == 3
    with pytest.raises(PorepipeError, match="no heaps"):
        heap_ensemble([])
