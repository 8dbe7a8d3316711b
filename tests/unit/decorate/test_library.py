"""Grain types: exact measures against closed forms (cube, regular tetrahedron, octahedron, unperturbed quartz)."""

import numpy as np
import pytest

from porepipe.decorate import polyhedron, quartz_type, random_type, read_plane_file, uniform_rotations
from porepipe.decorate._library import QUARTZ_CAP_ANGLE_DEG

# measures come from Qhull vertex enumeration of exact plane sets: rounding only, so 1e-9 relative
RTOL = 1e-9


def cube(side=2.0):
    return np.vstack([np.eye(3), -np.eye(3)]), np.full(6, side / 2)


def tetrahedron():
    """Regular tetrahedron with vertices (1,1,1), (1,-1,-1), (-1,1,-1), (-1,-1,1): edge 2√2."""
    verts = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    return -verts / np.sqrt(3.0), np.full(4, 1.0 / np.sqrt(3.0))


def octahedron():
    """|x| + |y| + |z| <= 1: edge √2."""
    normals = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return normals / np.sqrt(3.0), np.full(8, 1.0 / np.sqrt(3.0))


def _closed_forms():
    a_t = 2 * np.sqrt(2.0)
    a_o = np.sqrt(2.0)
    return {
        # V, S, M = ½ Σ L ψ, inradius, circumradius
        "cube": (cube(), (8.0, 24.0, 0.5 * 12 * 2 * np.pi / 2, 1.0, np.sqrt(3.0))),
        "tetrahedron": (
            tetrahedron(),
            (
                a_t**3 / (6 * np.sqrt(2)),
                np.sqrt(3) * a_t**2,
                0.5 * 6 * a_t * (np.pi - np.arccos(1 / 3)),
                a_t / (2 * np.sqrt(6)),
                a_t * np.sqrt(6) / 4,
            ),
        ),
        "octahedron": (
            octahedron(),
            (
                np.sqrt(2) / 3 * a_o**3,
                2 * np.sqrt(3) * a_o**2,
                0.5 * 12 * a_o * (np.pi - np.arccos(-1 / 3)),
                1 / np.sqrt(3),
                1.0,
            ),
        ),
    }


@pytest.mark.parametrize("name", ["cube", "tetrahedron", "octahedron"])
def test_platonic_measures(name):
    (normals, offsets), (v, s, m, r_in, r_circ) = _closed_forms()[name]
    t = polyhedron(name, normals, offsets)
    assert t.volume == pytest.approx(v, rel=RTOL)
    assert t.area == pytest.approx(s, rel=RTOL)
    assert t.mean_curvature == pytest.approx(m, rel=RTOL)
    assert t.inradius == pytest.approx(r_in, rel=1e-7)  # LP (HiGHS) optimality tolerance
    assert t.centre_inradius == pytest.approx(r_in, rel=RTOL)
    assert t.circumradius == pytest.approx(r_circ, rel=RTOL)
    assert t.n_faces == len(offsets)


@pytest.mark.parametrize("name", ["cube", "tetrahedron", "octahedron"])
def test_measures_invariant_under_motion_and_centred(name):
    """Rotating and translating the planes changes no measure; the type is re-centred at its centroid."""
    (normals, offsets), _ = _closed_forms()[name]
    ref = polyhedron(name, normals, offsets)
    rot = uniform_rotations(np.random.default_rng(3), 1)[0]
    shift = np.array([3.0, -1.5, 0.25])
    n2 = normals @ rot.T
    moved = polyhedron(name, n2, offsets + n2 @ shift)
    for attr in ("volume", "area", "mean_curvature", "circumradius", "centre_inradius"):
        assert getattr(moved, attr) == pytest.approx(getattr(ref, attr), rel=1e-9)
    # centroid at the origin: the vertex average of a centrally symmetric or regular body is its centroid
    assert np.abs(moved.vertices.mean(axis=0)).max() < 1e-9


def test_redundant_and_duplicate_planes_dropped():
    normals, offsets = cube()
    extra_n = np.vstack([normals, [[1, 1, 0]] / np.sqrt(2.0), [[1, 0, 0]]])
    extra_d = np.concatenate([offsets, [np.sqrt(2.0)], [1.0]])  # touches an edge only; duplicate of x <= 1
    t = polyhedron("cube+", extra_n, extra_d)
    assert t.n_faces == 6
    assert t.mean_curvature == pytest.approx(6 * np.pi, rel=RTOL)


def test_quartz_unperturbed_closed_form():
    """Hexagonal prism (inradius 1, half-length h) with hexagonal pyramid caps whose faces are 51.8° off the c axis."""
    e = 0.3
    t = quartz_type("q", np.random.default_rng(0), elongation=e, perturbation=0.0)
    h = 1.0 + e
    alpha = np.deg2rad(QUARTZ_CAP_ANGLE_DEG)
    side = 2 / np.sqrt(3)  # hexagon edge for inradius 1
    hex_area = 2 * np.sqrt(3)
    cap_height = np.tan(alpha)
    volume = hex_area * 2 * h + 2 * hex_area * cap_height / 3
    area = 6 * side * 2 * h + 12 * 0.5 * side / np.cos(alpha)
    slant_edge = np.hypot(side, cap_height)  # hexagon vertex (radius = side) to apex
    cap_cap = np.arccos(np.sin(alpha) ** 2 * np.cos(np.pi / 3) + np.cos(alpha) ** 2)
    m = 0.5 * (6 * 2 * h * np.pi / 3 + 12 * side * (np.pi / 2 - alpha) + 12 * slant_edge * cap_cap)
    assert t.n_faces == 18
    assert t.volume == pytest.approx(volume, rel=RTOL)
    assert t.area == pytest.approx(area, rel=RTOL)
    assert t.mean_curvature == pytest.approx(m, rel=RTOL)
    assert t.circumradius == pytest.approx(h + cap_height, rel=RTOL)


def test_perturbed_quartz_volume_by_monte_carlo():
    """Exact volume of a perturbed quartz type vs the hit fraction of 200 000 uniform points in its bounding box."""
    rng = np.random.default_rng(11)
    t = quartz_type("q", rng, elongation=0.5, perturbation=0.2)
    assert t.n_faces == 18
    lo, hi = t.vertices.min(axis=0), t.vertices.max(axis=0)
    n = 200_000
    pts = rng.uniform(lo, hi, size=(n, 3))
    frac = np.all(pts @ t.normals.T <= t.offsets, axis=1).mean()
    box = np.prod(hi - lo)
    sigma = box * np.sqrt(frac * (1 - frac) / n)
    assert abs(frac * box - t.volume) < 4 * sigma  # 4σ: false alarm 6e-5


def test_random_type_facets_and_elongation_is_affine():
    """Exactly the requested facets; elongation e stretches the same draw by 1/(1 − e), so V scales by 1/(1 − e)."""
    t0 = random_type("r", np.random.default_rng(5), facets=36, elongation=0.0)
    t4 = random_type("r", np.random.default_rng(5), facets=36, elongation=0.4)
    assert t0.n_faces == t4.n_faces == 36
    assert t4.volume == pytest.approx(t0.volume / 0.6, rel=1e-9)
    ext0 = np.ptp(t0.vertices, axis=0)
    ext4 = np.ptp(t4.vertices, axis=0)
    assert ext4[2] / ext0[2] == pytest.approx(1 / 0.6, rel=1e-9)
    assert ext4[:2] == pytest.approx(ext0[:2], rel=1e-9)


def test_plane_file(tmp_path):
    normals, offsets = cube(1.0)
    lines = ["# two types"] + [f"box {n[0]} {n[1]} {n[2]} {d}" for n, d in zip(2 * normals, 2 * offsets)]
    tn, td = tetrahedron()
    lines += [f"tet {n[0]:.17g} {n[1]:.17g} {n[2]:.17g} {d:.17g}" for n, d in zip(tn, td)]
    path = tmp_path / "grains.planes"
    path.write_text("\n".join(lines) + "\n")
    types = read_plane_file(path)
    assert [t.name for t in types] == ["box", "tet"]
    assert types[0].volume == pytest.approx(1.0, rel=RTOL)  # normals of length 2 are normalised with d
    assert types[1].volume == pytest.approx((2 * np.sqrt(2)) ** 3 / (6 * np.sqrt(2)), rel=RTOL)
