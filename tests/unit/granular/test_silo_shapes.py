"""Shaped silos (scene key ``granular.silo``): wall geometry, fill-relative theory, wall-contact resolution, input.

Truths: the wall slabs' inner faces against r(z) of Eqs. 3.14/3.16/3.19 (read back by an independent line-polygon
crossing, to 1e-12 m); the theory of a fill whose surface lies below the top against scipy's solve_ivp of Eq. 3.10
with r(z + z_s) written out here (1e-7 relative; the step of a stepped silo as a restart of the integration);
mu_j recovered from a noise-free synthetic profile (1e-6); a hand-built contact on a slanted wall resolved into
normal and tangential forces by hand (1e-12).
"""

import itertools

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from porepipe.granular import (
    check_convex,
    fit_shaped_mu_j,
    inner_extent,
    resolve_wall_contacts,
    shaped_sigma_zz,
    shifted_silo,
    silo_half_width,
    silo_wall_slabs,
)
from porepipe.granular._settings import Silo
from porepipe.scene import SceneError, parse_scene

RHO_G = 0.8 * 5000 * 9.81
SHAPES = {
    "straight": {"shape": "straight", "r_m": 0.01, "depth_m": 0.08},
    "stepped": {"shape": "stepped", "r1_m": 0.01, "r2_m": 0.005, "h0_m": 0.06, "depth_m": 0.1},
    "hopper": {"shape": "hopper", "slope": -0.1087, "b_m": 0.015, "depth_m": 0.09},
    "parabolic": {"shape": "parabolic", "a_per_m": 500.0, "b_m": 0.092, "depth_m": 0.078, "segments": 16},
}


def _silo(name, **extra):
    return Silo.model_validate({**SHAPES[name], "axis_x_m": 0.003, "bottom_m": -0.01, **extra})


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_wall_slabs_follow_r_of_z(name):
    """The inner faces read back from the wall polygons give 2 r(z) (at the parabola's corners, where the chords
    meet the curve) and the walls are valid convex bodies of a simulation."""
    silo = _silo(name)
    slabs = silo_wall_slabs(silo)
    walls = [v for n, v in slabs if n != "silo floor"]
    top = silo.bottom_m + silo.depth_m
    if name == "parabolic":
        z = np.linspace(0, silo.depth_m, silo.segments + 1)[:-1]
    else:
        z = np.linspace(0.0005, silo.depth_m - 0.0005, 23)
        z = z[np.abs(z - (silo.h0_m or -1)) > 0.005]  # not at the step's ledge
    for zz in z:
        xl, xr = inner_extent(walls, top - zz, silo.axis_x_m)
        r = float(silo_half_width(silo, zz))
        assert xl == pytest.approx(silo.axis_x_m - r, abs=1e-12)
        assert xr == pytest.approx(silo.axis_x_m + r, abs=1e-12)
    floor = dict(slabs)["silo floor"]
    assert floor[:, 1].max() == pytest.approx(silo.bottom_m, abs=1e-15)
    for wall_name, v in slabs:
        check_convex(v, wall_name)  # raises on a non-convex or degenerate slab


def _ode(silo, z_s, k, mu_j, z):
    """Eq. 3.10 for r(z + z_s), integrated by solve_ivp section by section (a stepped silo restarts at its step)."""

    def r(u):
        return float(silo_half_width(silo, u + z_s))

    def dr(u, h=1e-7):
        return (r(u + h) - r(u - h)) / (2 * h) if silo.shape.value in ("hopper", "parabolic") else 0.0

    def rhs(u, y):
        d2 = dr(u) ** 2
        return [RHO_G - mu_j * y[0] * (d2 + k) / (r(u) * (1 + d2) ** 1.5)]

    cuts = [0.0, z[-1]]
    if silo.shape.value == "stepped" and 0 < silo.h0_m - z_s < z[-1]:
        cuts = [0.0, silo.h0_m - z_s, z[-1]]
    out, y0 = np.empty(0), 0.0
    for a, b in itertools.pairwise(cuts):
        sol = solve_ivp(
            rhs, (a, b), [y0], method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True, max_step=1e-3
        )
        pts = z[(z > a) & (z <= b)] if a > 0 else z[z <= b]
        out = np.concatenate([out, sol.sol(pts)[0]])
        y0 = float(sol.y[0, -1])
    return out


@pytest.mark.parametrize("name", sorted(SHAPES))
@pytest.mark.parametrize("z_s", [0.0, 0.012])
def test_fill_relative_theory_matches_the_ode(name, z_s):
    silo = _silo(name)
    k, mu_j = 0.7, 0.33
    theory = shifted_silo(silo, z_s)
    z = np.linspace(0.002, silo.depth_m - z_s - 0.004, 9)
    np.testing.assert_allclose(
        shaped_sigma_zz(theory, z, k, mu_j, RHO_G), _ode(silo, z_s, k, mu_j, z), rtol=1e-7
    )


def test_stepped_fill_below_the_step_is_a_straight_silo():
    silo = _silo("stepped")
    below = shifted_silo(silo, 0.07)
    assert below.shape.value == "straight" and below.r_m == silo.r2_m


@pytest.mark.parametrize("name", ["stepped", "hopper", "parabolic"])
def test_fit_recovers_mu_j(name):
    silo = shifted_silo(_silo(name), 0.005)
    z = np.linspace(0.003, silo.depth_m - 0.01, 25)
    sxx = 0.7 * shaped_sigma_zz(silo, z, 0.7, 0.37, RHO_G)
    fit = fit_shaped_mu_j(silo, z, sxx, 0.7, RHO_G)
    assert fit["mu_j"] == pytest.approx(0.37, rel=1e-6)
    assert fit["rms"] < 1e-6 * sxx.max()


def test_contact_on_a_slanted_wall_resolves_into_normal_and_shear():
    """A contact on the hopper's left face: F = 2 n + 0.5 t_up on the grain gives F_n 2, F_t 0.5, a side face."""
    silo = _silo("hopper")
    slabs = silo_wall_slabs(silo)
    left = dict(slabs)["silo left"]
    p0, p1 = left[0], left[1]  # the inner face, top to bottom
    t_up = (p0 - p1) / np.linalg.norm(p0 - p1)
    n = np.array([t_up[1], -t_up[0]])  # pointing to +x, into the silo
    assert n[0] > 0 and abs(n[1] / n[0]) == pytest.approx(0.1087, rel=1e-12)
    point = p1 + 0.3 * (p0 - p1)
    f = 2.0 * n + 0.5 * t_up
    contacts = {
        "i": np.array([0]),
        "j": np.array([1]),  # one particle, wall 0
        "sx_m": np.array([point[0]]),
        "sy_m": np.array([point[1]]),
        "fx_N": np.array([f[0]]),
        "fy_N": np.array([f[1]]),
    }
    wc = resolve_wall_contacts(contacts, 1, [(0, left)])
    assert wc["fn"][0] == pytest.approx(2.0, rel=1e-12)
    assert wc["ft_up"][0] == pytest.approx(0.5, rel=1e-12)
    assert bool(wc["side"][0])
    np.testing.assert_allclose(wc["normal"][0], n, rtol=1e-12)


@pytest.mark.parametrize(
    ("silo", "words"),
    [
        ({"shape": "hopper", "b_m": 0.01, "depth_m": 0.05}, "needs slope"),
        (
            {"shape": "straight", "r_m": 0.01, "h0_m": 0.02, "depth_m": 0.05},
            "h0_m is not a key of shape straight",
        ),
        (
            {"shape": "stepped", "r1_m": 0.01, "r2_m": 0.02, "h0_m": 0.02, "depth_m": 0.05},
            "must be below r1_m",
        ),
        ({"shape": "hopper", "slope": -0.5, "b_m": 0.01, "depth_m": 0.05}, "must not meet above the floor"),
        ({"shape": "parabolic", "a_per_m": 100.0, "b_m": 0.05, "depth_m": 0.06}, "above the vertex"),
        ({"shape": "cone", "r_m": 0.01, "depth_m": 0.05}, "granular.silo.shape"),
    ],
)
def test_bad_silo_is_refused_in_one_line_naming_the_key(silo, words):
    with pytest.raises(SceneError) as err:
        parse_scene({"name": "s", "analyses": ["granular"], "granular": {"silo": silo}})
    msg = str(err.value)
    assert "granular.silo" in msg and words in msg


def _source(x, y, **extra):
    """A drop source of 1 mm grains (reach 1.15 mm with the 15 % spread), 1 mm wide, one grain every 10 ms."""
    grain = {"size_m": [0.001, 0.001], "size_spread": 0.15, "size_dist": "EQUAL", "corners": 9}
    return {"x_m": x, "y_m": y, "width_m": 0.001, "every_s": 0.01, "to_s": 0.5, "shape": grain, **extra}


def _scene_with(silo, *sources):
    return {"name": "s", "analyses": ["granular"], "granular": {"silo": silo, "drop_sources": list(sources)}}


# stepped: r1 10 mm above the step at y = 0.04 m, r2 5 mm below, floor at y = 0; a grain needs |x| + 1.65 mm
STEPPED = {**SHAPES["stepped"], "bottom_m": 0.0}
HOPPER = {**SHAPES["hopper"], "bottom_m": 0.0}  # r = 15 mm at the top (y = 0.09 m), 5.2 mm at the floor


@pytest.mark.parametrize(
    ("source", "when"),
    [
        (_source(0.007, 0.01, rise_m_s=0.1), "t = 0 s, y = 0.01 m"),  # 8.65 mm needed, 5 mm below the step
        (_source(0.002, 0.001), "t = 0 s, y = 0.001 m"),  # a grain would reach into the floor
        (
            _source(0.007, 0.01, rise_m_s=0.1, mode="REL"),
            None,
        ),  # REL: x alone, within the top's width: accepted
        (_source(0.009, 0.01, mode="REL"), "t = 0 s"),  # 10.65 mm needed, the top leaves 10 mm
    ],
)
def test_a_drop_source_that_starts_grains_outside_a_stepped_silo_is_refused_naming_it(source, when):
    ok = _source(0.0, 0.01, rise_m_s=0.1)
    if when is None:
        parse_scene(_scene_with(STEPPED, ok, source))
        return
    with pytest.raises(SceneError) as err:
        parse_scene(_scene_with(STEPPED, ok, source))
    msg = str(err.value)
    assert msg.count("\n") == 1 and "granular.drop_sources[1]" in msg and when in msg, msg
    assert "outside the silo" in msg


def test_a_rising_source_is_checked_at_every_insertion_height():
    """Started above the step (y 0.045 m, rising) the outer source of the stepped silo is accepted; the same
    source started 10 mm lower is refused; in the hopper a source that sinks (rise < 0) leaves the walls later."""
    parse_scene(_scene_with(STEPPED, _source(0.007, 0.045, rise_m_s=0.05)))
    with pytest.raises(SceneError, match=r"drop_sources\[0\].*y = 0.035 m"):
        parse_scene(_scene_with(STEPPED, _source(0.007, 0.035, rise_m_s=0.05)))
    # hopper source at x = 10 mm needs r >= 11.65 mm: z <= 30.8 mm, y >= 0.0592 m; it sinks from 0.08 m at 0.1 m/s,
    # its last grain (t = 0.3 s) starts at y = 0.05 m
    parse_scene(_scene_with(HOPPER, _source(0.010, 0.08, to_s=0.2, rise_m_s=-0.1)))
    with pytest.raises(SceneError, match=r"drop_sources\[0\].*t = 0.3 s, y = 0.05 m"):
        parse_scene(_scene_with(HOPPER, _source(0.010, 0.08, to_s=0.3, rise_m_s=-0.1)))
    # a source far outside the walls inserting 1e12 grains is refused as quickly (the path, not grain by grain)
    with pytest.raises(SceneError, match=r"drop_sources\[0\].*outside the silo"):
        parse_scene(_scene_with(HOPPER, _source(0.014, 0.08, every_s=1e-12, rise_m_s=-0.1)))


def test_inner_half_width_follows_the_parabola_chords():
    """Between two corners the walls as built are the chord: the mean of r at the corners (by hand), inside r(z)."""
    silo = Silo.model_validate(SHAPES["parabolic"])
    zc = np.linspace(0.0, silo.depth_m, silo.segments + 1)
    mid = 0.5 * (zc[3] + zc[4])
    chord = 0.5 * (np.sqrt((silo.b_m - zc[3]) / silo.a_per_m) + np.sqrt((silo.b_m - zc[4]) / silo.a_per_m))
    assert float(silo.inner_half_width(mid)) == pytest.approx(chord, rel=1e-12)
    assert float(silo.inner_half_width(mid)) < float(silo_half_width(silo, mid))
    np.testing.assert_allclose(silo.inner_half_width(zc), silo_half_width(silo, zc), rtol=1e-12)
