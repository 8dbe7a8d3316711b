"""Minkowski functionals of digitised analytic bodies converge to the exact values; χ is exact whenever the
digitised body has the right topology.

Each body is digitised (voxel centre inside = pore) at a = 1/4, 1/8, 1/16, 1/32 of its unit length, with a fixed
sub-voxel shift of the centre, inside a background frame, and measured with minus sampling (then the window sums are
the body's own V, S, ∫H, χ). The relative error allowed at each resolution is in ``TOLERANCES`` (measured error ×
~1.5-2, rounded up); the last column is the convergence claim. The printed table (``pytest -s``) gives the errors.

References for S and ∫H: for the ball, hollow ball, torus and cylinder the exact values; for polyhedra and the
cylinder the 13-direction Crofton formulae converge to the *discrete Crofton limit*
``S_lim = 4 Σ_i γ_i A(u_i)``, ``M_lim = 2π Σ_j γ'_j b(n_j)`` (A: projected area, b: width), which differs from the
exact value for bodies with flat faces (aligned cube: -7.3 %); the test compares with that limit and states the gap.
"""

import numpy as np
import pytest
from scipy import ndimage
from skimage.measure import euler_number

from porepipe.minkowski import Adjacency, minkowski_functionals
from porepipe.minkowski import _weights as W

RESOLUTIONS = (4, 8, 16, 32)
UNIT = W.DIRECTIONS / np.linalg.norm(W.DIRECTIONS, axis=1)[:, None]
GEOM = W.geometry((1.0, 1.0, 1.0))


def _rotation(seed):
    q = np.random.default_rng(seed).normal(size=4)
    a, b, c, d = q / np.linalg.norm(q)
    return np.array(
        [
            [a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)],
            [2 * (b * c + a * d), a * a - b * b + c * c - d * d, 2 * (c * d - a * b)],
            [2 * (b * d - a * c), 2 * (c * d + a * b), a * a - b * b - c * c + d * d],
        ]
    )


ROT = _rotation(3)
CUBE_SIDE, CYL_R, CYL_H, TOR_R, TOR_RHO, HOLLOW_IN, TOUCH_R = 1.6, 0.7, 1.6, 1.0, 0.4, 0.6, 0.6


def _body_frame(x, y, z, rotation):
    p = np.stack(np.broadcast_arrays(x, y, z), -1)
    return p if rotation is None else p @ rotation


def ball(x, y, z):
    return x * x + y * y + z * z <= 1.0


def cube(x, y, z, rotation=None):
    return np.all(np.abs(_body_frame(x, y, z, rotation)) <= CUBE_SIDE / 2, axis=-1)


def cylinder(x, y, z):
    return (x * x + y * y <= CYL_R**2) & (np.abs(z) <= CYL_H / 2)


def torus(x, y, z):
    p = _body_frame(x, y, z, ROT)
    q = np.hypot(p[..., 0], p[..., 1]) - TOR_R
    return q * q + p[..., 2] ** 2 <= TOR_RHO**2


def hollow_ball(x, y, z):
    d2 = x * x + y * y + z * z
    return (d2 <= 1.0) & (d2 >= HOLLOW_IN**2)


def touching_balls(x, y, z):
    return ((x - TOUCH_R) ** 2 + y * y + z * z <= TOUCH_R**2) | (
        (x + TOUCH_R) ** 2 + y * y + z * z <= TOUCH_R**2
    )


def _cube_limits(rotation):
    axes = np.eye(3) if rotation is None else rotation
    width = np.abs(UNIT @ axes).sum(axis=1)  # Σ_k |u · n_k| for the three face normals
    return (
        4 * np.sum(GEOM.line_weight * CUBE_SIDE**2 * width),
        2 * np.pi * np.sum(GEOM.plane_weight * CUBE_SIDE * width),
    )


def _torus_surface_limit(n=800):
    """2 Σ_i γ_i ∫_∂T |n · u_i| dA by midpoint quadrature (relative error ~1e-6 at n = 800)."""
    t = (np.arange(n) + 0.5) * 2 * np.pi / n
    u, v = np.meshgrid(t, t, indexing="ij")
    normal = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], -1) @ ROT.T
    area = TOR_RHO * (TOR_R + TOR_RHO * np.cos(v)) * (2 * np.pi / n) ** 2
    return 2 * sum(g * np.sum(np.abs(normal @ d) * area) for g, d in zip(GEOM.line_weight, UNIT))


def _cylinder_limits():
    uz = np.abs(UNIT[:, 2])
    side = np.sqrt(1 - uz**2)
    return (
        4 * np.sum(GEOM.line_weight * (np.pi * CYL_R**2 * uz + 2 * CYL_R * CYL_H * side)),
        2 * np.pi * np.sum(GEOM.plane_weight * (CYL_H * uz + 2 * CYL_R * side)),
    )


# torus: ∫χ(T ∩ E_t) dt = 4R sin α for a plane normal at angle α to the axis (Morse count of the section), so
# M_lim = 2π Σ_j γ'_j 4R sin α_j; the isotropic mean of sin α is π/4, giving the exact 2π²R.
_TOR_SIN = np.sqrt(1 - (UNIT @ ROT[:, 2]) ** 2)

#: name: (indicator, half extent, (V, S_ref, M_ref, χ), (components, cavities), exact S and M for the record)
BODIES = {
    "ball": (ball, 1.0, (4 / 3 * np.pi, 4 * np.pi, 4 * np.pi, 1), (1, 0)),
    "cube": (cube, 0.8, (CUBE_SIDE**3, *_cube_limits(None), 1), (1, 0)),
    "cube_rotated": (lambda x, y, z: cube(x, y, z, ROT), 1.4, (CUBE_SIDE**3, *_cube_limits(ROT), 1), (1, 0)),
    "cylinder": (cylinder, 0.9, (np.pi * CYL_R**2 * CYL_H, *_cylinder_limits(), 1), (1, 0)),
    "torus": (
        torus,
        1.4,
        (
            2 * np.pi**2 * TOR_R * TOR_RHO**2,
            _torus_surface_limit(),
            2 * np.pi * np.sum(GEOM.plane_weight * 4 * TOR_R * _TOR_SIN),
            0,
        ),
        (1, 0),
    ),
    "hollow_ball": (
        hollow_ball,
        1.0,
        (4 / 3 * np.pi * (1 - HOLLOW_IN**3), 4 * np.pi * (1 + HOLLOW_IN**2), 4 * np.pi * (1 - HOLLOW_IN), 2),
        (1, 1),
    ),
    "touching_balls": (
        touching_balls,
        1.2,
        (8 / 3 * np.pi * TOUCH_R**3, 8 * np.pi * TOUCH_R**2, 8 * np.pi * TOUCH_R, 1),
        (1, 0),
    ),
}

#: allowed |relative error| of (V, S, ∫H) at a = 1/4, 1/8, 1/16, 1/32 (pore 6-adjacent).
TOLERANCES = {
    "ball": ((0.03, 0.01, 0.005, 0.002), (0.03, 0.01, 0.005, 0.002), (0.01, 0.01, 0.006, 0.003)),
    "cube": ((0.06, 0.05, 0.04, 0.015), (0.15, 0.10, 0.06, 0.015), (0.12, 0.07, 0.04, 0.015)),
    # ∫H of polyhedra at a generic orientation keeps a bias of a few %: lattice planes cut the edges in wedges whose
    # digitised tips break into extra section components at a rate that does not shrink with a (smooth bodies and
    # lattice-aligned edges do not have this).
    "cube_rotated": ((0.03, 0.01, 0.005, 0.002), (0.15, 0.06, 0.04, 0.02), (0.06, 0.04, 0.04, 0.045)),
    "cylinder": ((0.20, 0.05, 0.04, 0.01), (0.03, 0.02, 0.02, 0.015), (0.03, 0.02, 0.01, 0.01)),
    "torus": ((0.04, 0.01, 0.005, 0.002), (0.06, 0.03, 0.006, 0.003), (0.01, 0.015, 0.01, 0.003)),
    "hollow_ball": ((0.04, 0.005, 0.005, 0.002), (0.03, 0.015, 0.003, 0.002), (0.15, 0.03, 0.005, 0.003)),
    # the contact point: near it the digitised sections of the two balls merge over a band of width ~sqrt(a r),
    # so ∫H converges only like sqrt(a); S and V as for one ball.
    "touching_balls": ((0.12, 0.01, 0.005, 0.001), (0.02, 0.06, 0.005, 0.005), (0.25, 0.25, 0.10, 0.10)),
}


def digitise(indicator, half_extent, a, seed=1):
    """Voxel-centre digitisation with a background frame and a fixed sub-voxel shift of the body."""
    shift = np.random.default_rng(seed).uniform(-0.5, 0.5, 3) * a
    n = int(np.ceil(2 * half_extent / a)) + 4
    axis = (np.arange(n) - n / 2 + 0.5) * a
    x, y, z = np.meshgrid(axis - shift[0], axis - shift[1], axis - shift[2], indexing="ij", sparse=True)
    return indicator(x, y, z).astype(np.uint8)


def topology(volume, adjacency_pore):
    """(components of the pore, cavities = background components not touching the frame) by labelling."""
    full, face = np.ones((3, 3, 3)), ndimage.generate_binary_structure(3, 1)
    pore_s, back_s = (face, full) if adjacency_pore == 6 else (full, face)
    n_comp = ndimage.label(volume, pore_s)[1]
    labels, n_back = ndimage.label(1 - volume, back_s)
    outer = np.unique(
        np.concatenate(
            [
                labels[0].ravel(),
                labels[-1].ravel(),
                labels[:, 0].ravel(),
                labels[:, -1].ravel(),
                labels[:, :, 0].ravel(),
                labels[:, :, -1].ravel(),
            ]
        )
    )
    return n_comp, n_back - len(outer[outer > 0])


@pytest.mark.parametrize("name", list(BODIES))
def test_body_converges(name):
    indicator, half_extent, exact, right_topology = BODIES[name]
    rows = []
    for level, k in enumerate(RESOLUTIONS):
        a = 1.0 / k
        volume = digitise(indicator, half_extent, a)
        ds = minkowski_functionals(volume, a, periodic=False)
        pore = ds.sel(phase="pore")
        window = float(ds.attrs["window_um3"])
        measured = (float(pore.phi) * window, float(pore.S_V) * window, float(pore.K_V) * window)
        errors = [m / e - 1 for m, e in zip(measured, exact[:3])]
        rows.append(f"{name} a=1/{k}: " + " ".join(f"{q} {e:+.4f}" for q, e in zip(("V", "S", "∫H"), errors)))
        for quantity, err, tol in zip(("V", "S", "∫H"), errors, TOLERANCES[name]):
            assert abs(err) <= tol[level], (
                f"{quantity} error {err:+.4f} > {tol[level]} at a=1/{k}\n" + "\n".join(rows)
            )
        chi = float(pore.chi)
        # independent implementation: scikit-image's Euler number with the same connectivity (6 -> 1)
        assert chi == euler_number(volume, connectivity=1)
        if topology(volume, 6) == right_topology:
            assert chi == exact[3], f"χ = {chi} at a=1/{k} although the digitised body has the right topology"
        rows[-1] += f" χ {chi:.0f} (topology {'right' if topology(volume, 6) == right_topology else 'wrong'})"
    print("\n".join(rows))


@pytest.mark.parametrize("name", ["torus", "hollow_ball", "touching_balls"])
def test_chi26_exact_where_topology_right(name):
    indicator, half_extent, exact, right_topology = BODIES[name]
    for k in RESOLUTIONS:
        volume = digitise(indicator, half_extent, 1.0 / k)
        ds = minkowski_functionals(volume, 1.0 / k, False, Adjacency.pore26_matrix6)
        chi = float(ds.chi.sel(phase="pore"))
        assert chi == euler_number(volume, connectivity=3)
        if topology(volume, 26) == right_topology:
            assert chi == exact[3], (name, k)


def test_agrees_with_quantimpy():
    # quantimpy (Boelens & Tchelepi 2021) counts the same 2x2x2 configurations with its own code: its volume must
    # equal ours exactly, its integral of mean curvature equals the mean of our 6- and 26-adjacency values (it
    # averages the two section adjacencies), its surface uses other direction weights (within 1.5 % here).
    minkowski = pytest.importorskip("quantimpy.minkowski", reason="quantimpy (GPL peer) not installed")
    rng = np.random.default_rng(2)
    volume = np.zeros((40, 40, 40), np.uint8)
    x, y, z = np.meshgrid(*(np.arange(40.0),) * 3, indexing="ij", sparse=True)
    for c in rng.uniform(8, 32, (25, 3)):
        volume |= ((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2 <= 5.5**2).astype(np.uint8)
    volume = np.pad(volume, 2)
    v, s, h, _ = minkowski.functionals(volume.astype(bool))
    ours = {adj: minkowski_functionals(volume, 1.0, False, adj) for adj in Adjacency}
    window = float(ours[Adjacency.pore6_matrix26].attrs["window_um3"])
    pore = {adj: ds.sel(phase="pore") for adj, ds in ours.items()}
    assert float(pore[Adjacency.pore6_matrix26].phi) * window == pytest.approx(v, rel=1e-12)
    mean_h = sum(float(p.K_V) for p in pore.values()) / 2 * window
    assert 2 * np.pi**2 * h == pytest.approx(mean_h, rel=1e-9)  # float rounding only
    assert 8 * s == pytest.approx(float(pore[Adjacency.pore6_matrix26].S_V) * window, rel=0.015)


def test_surface_agrees_with_marching_cubes_on_a_fine_ball():
    # scikit-image marching cubes + mesh area: an independent (mesh-based) surface estimator. On the raw binary
    # image its staircase mesh overestimates by ~9 %, so it meshes the 0.5 level of the image blurred with a
    # Gaussian of σ = 1 voxel (area shift ~σ²/r² ≈ 0.2 % at r = 24 voxels). Both within 1 % of 4πr².
    from skimage.measure import marching_cubes, mesh_surface_area

    volume = digitise(ball, 1.0, 1 / 24)
    verts, faces, _, _ = marching_cubes(ndimage.gaussian_filter(volume.astype(float), 1.0), 0.5)
    mc = mesh_surface_area(verts, faces) / 24**2
    ds = minkowski_functionals(volume, 1 / 24, periodic=False)
    ours = float(ds.S_V.sel(phase="pore")) * float(ds.attrs["window_um3"])
    assert ours == pytest.approx(4 * np.pi, rel=0.01)
    assert mc == pytest.approx(4 * np.pi, rel=0.01)
