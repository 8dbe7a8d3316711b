"""Interpolated bounce-back: link list, wall distances (ray-sphere, grey), kernel against a dense reference,
κ̂ error estimate, throat width."""

import numpy as np
import pytest
from naive_lbm import collision_matrix, equilibrium

from porepipe._shared.errors import PorepipeError
from porepipe.lbm import GreyWalls, Settings, SphereWalls, Walls
from porepipe.lbm._domain import build_lattice
from porepipe.lbm._lattice import OPPOSITE, C, Q, W
from porepipe.lbm._solver import kappa_error, make_stepper
from porepipe.lbm._throats import critical_throat
from porepipe.lbm._walls import Links, build_links, coefficients


def _random_pore(shape=(6, 7, 8), seed=1):
    rng = np.random.default_rng(seed)
    return rng.random(shape) > 0.3


def _upstream(idx, q, shape):
    return tuple((idx[k] - C[q, k]) % shape[k] for k in range(3))


def _dense_interpolated_step(f, pore, coef, a_matrix):
    """One periodic pull step; a wall link of population q at x takes a f_ō(x) + b f_ō(x + c_q) + c f_q(x).

    ``coef`` (19, L0, L1, L2, 3); the behind value is the post-collision population ō of the node x + c_q (0 there
    if it is solid, where b must be 0). Written voxel by voxel from the definition, no tables.
    """
    shape = pore.shape
    g = np.zeros_like(f)
    for x in np.argwhere(pore):
        x = tuple(x)
        for q in range(Q):
            up = _upstream(np.array(x), q, shape)
            if pore[up]:
                g[(q, *x)] = f[(q, *up)]
                continue
            o = OPPOSITE[q]
            behind = tuple((np.array(x) + C[q]) % shape)
            a, b, c = coef[(q, *x)]
            g[(q, *x)] = a * f[(o, *x)] + b * (f[(o, *behind)] if pore[behind] else 0.0) + c * f[(q, *x)]
    rho = g.sum(axis=0)
    j = np.tensordot(C.T.astype(float), g, axes=(1, 0))
    with np.errstate(invalid="ignore", divide="ignore"):
        feq = equilibrium(rho, j / rho)
    post = g - np.tensordot(a_matrix, np.nan_to_num(g - feq), axes=(1, 0))
    return np.where(pore, post, 0.0)


class _RandomQ:
    """A test geometry: a fixed pseudo-random q per link (any q in (0, 1] must be handled)."""

    def __init__(self, seed):
        self.seed = seed

    def permuted(self, order):
        return self

    def fractions(self, nodes, pops):
        rng = np.random.default_rng(self.seed)
        return rng.uniform(1e-3, 1.0, size=len(pops))


@pytest.mark.parametrize("scheme", [Walls.cli, Walls.bfl])
def test_interpolated_step_matches_dense_reference(scheme):
    """Three TRT steps on a random periodic porous box with a random q per link equal the voxel-by-voxel dense
    reference (1e-13 absolute: float64 in a different summation order)."""
    pore = _random_pore()
    periodic = (True, True, True)
    lat = build_lattice(pore, periodic, (0, 0), (0, pore.shape[0]), keep_wall_links=True)
    links = build_links(lat.pore, lat.periodic, *lat.wall_links, _RandomQ(5), scheme)
    assert (
        links.n_boundary == lat.n_wall_links and 0 < links.size < links.n_boundary
    )  # some have no node behind
    coef = np.zeros((Q, *pore.shape, 3))
    coef[..., 0] = 1.0  # halfway bounce-back where no link is stored
    node, pop = links.nodes_and_populations()
    coords = np.argwhere(pore)[node]
    b, c = links.b.astype(float), links.c.astype(float)
    coef[(pop, *coords.T)] = np.column_stack([1 - b - c, b, c])
    rng = np.random.default_rng(3)
    rho0 = 1 + 0.01 * rng.standard_normal(pore.shape)
    u0 = 0.02 * rng.standard_normal((3,) + pore.shape)
    dense = np.where(pore, equilibrium(rho0, u0) + 1e-3 * rng.standard_normal((19,) + pore.shape), 0.0)
    n = lat.n_nodes
    sparse = (dense[:, pore] - W[:, None]).reshape(-1).copy()
    other = np.zeros_like(sparse)
    a_matrix = collision_matrix("trt", 0.8)
    for _ in range(3):
        dense = _dense_interpolated_step(dense, pore, coef, a_matrix)
    make_stepper(Settings(collision="trt", tau=0.8), lat, links)(sparse, other, np.zeros((4, n)), False, 3)
    np.testing.assert_allclose(other.reshape(19, n) + W[:, None], dense[:, pore], rtol=0, atol=1e-13)


@pytest.mark.parametrize("scheme", [Walls.cli, Walls.bfl])
@pytest.mark.parametrize("collision", ["bgk", "trt", "mrt"])
def test_in_place_interpolated_walls_give_the_pull_kernels_bits(scheme, collision):
    """The in-place (AA) kernel with linear wall links equals the two-array pull kernel bit for bit after 1–6 steps
    (step pairs in place, an odd last step pulled), on a random porous box with a random q per link.
    Tolerance: none — the link values are the same expression
    of the same populations, applied in the same order before the same collision."""
    from porepipe.lbm import _kernels as K

    pore = _random_pore()
    lat = build_lattice(pore, (True,) * 3, (0, 0), (0, pore.shape[0]), keep_wall_links=True)
    links = build_links(lat.pore, lat.periodic, *lat.wall_links, _RandomQ(7), scheme)
    assert (links.b != 0).any() and (links.c != 0).any() and links.size > 100
    n = lat.n_nodes
    start = 1e-3 * np.random.default_rng(4).standard_normal(19 * n)
    settings = Settings(collision=collision, tau=0.8, body_force=1e-4)
    for steps in range(1, 7):
        runs = []
        for stores in (K.STORE_CACHED, K.IN_PLACE):
            src, dst = start.copy(), np.zeros_like(start)
            fields = np.zeros((4, n))
            make_stepper(settings, lat, links, stores=stores)(src, dst, fields, True, steps)
            runs.append((dst if steps % 2 else src, fields))
        np.testing.assert_array_equal(runs[1][0], runs[0][0])
        np.testing.assert_array_equal(runs[1][1], runs[0][1])


def test_auto_streams_in_place_with_links_only_beyond_the_cache(monkeypatch):
    """``streaming: auto`` takes the in-place kernel with halfway walls always, with linear links only where the
    two population arrays exceed the last-level cache (below it the in-place variant's compilation costs more than
    it saves), never with MR1 links; ``aa`` and ``pull`` choose themselves."""
    from porepipe.lbm import _kernels as K
    from porepipe.lbm._solver import _streams_in_place

    pore = _random_pore()
    lat = build_lattice(pore, (True,) * 3, (0, 0), (0, pore.shape[0]), keep_wall_links=True)
    cli = build_links(lat.pore, lat.periodic, *lat.wall_links, _RandomQ(7), Walls.cli)
    mr1 = build_links(lat.pore, lat.periodic, *lat.wall_links, _RandomQ(7), Walls.mr1)
    auto = Settings()
    assert _streams_in_place(auto, lat, Links.none())
    assert not _streams_in_place(auto, lat, cli)
    assert _streams_in_place(Settings(streaming="aa"), lat, cli)
    assert not _streams_in_place(Settings(streaming="pull"), lat, Links.none())
    monkeypatch.setattr(K, "STREAMING_BYTES", 0)
    assert _streams_in_place(auto, lat, cli)
    assert not _streams_in_place(Settings(walls="mr1"), lat, mr1)
    assert not _streams_in_place(Settings(precision="float32"), lat, cli)


def test_in_place_refuses_multi_reflection_links():
    from porepipe.lbm import _kernels as K

    pore = _random_pore()
    lat = build_lattice(pore, (True,) * 3, (0, 0), (0, pore.shape[0]), keep_wall_links=True)
    links = build_links(lat.pore, lat.periodic, *lat.wall_links, _RandomQ(7), Walls.mr1)
    with pytest.raises(PorepipeError, match="streaming = aa cannot run these wall links"):
        make_stepper(Settings(walls="mr1"), lat, links, stores=K.IN_PLACE)


def test_coefficients_reduce_to_halfway_at_one_half_and_follow_the_published_schemes():
    """(b, c) with a = 1 − b − c. At q = ½ both linear schemes are plain bounce-back (b = c = 0). BFL (Bouzidi et
    al. 2001): q < ½: a = 2q, b = 1 − 2q; q ≥ ½: a = 1/(2q), c = 1 − 1/(2q). CLI (Ginzburg et al. 2008): a = 1,
    b = −c = (1 − 2q)/(1 + 2q). Without a node behind: CLI halfway, BFL its local branch for q ≥ ½. MR1 (the same
    paper, Table 3): b = −c = κ₀ = (1 − 2q − 2q²)/(1 + q)², d = κ₋₁ = q²/(1 + q)², e = −α = −4/(1 + q)²; CLI with
    one node behind, halfway with none."""
    q = np.array([0.5, 1e-6, 0.2, 0.7, 1.0])
    behind = np.ones(q.size, dtype=bool)
    for scheme in (Walls.cli, Walls.bfl):
        np.testing.assert_allclose(coefficients(q, behind, scheme)[0], [0, 0, 0, 0], atol=1e-15)
    bfl = coefficients(q, behind, Walls.bfl)
    np.testing.assert_allclose(bfl[2, :2], [0.6, 0.0])
    np.testing.assert_allclose(bfl[3, :2], [0.0, 1 - 0.5 / 0.7])
    np.testing.assert_allclose(bfl[4, :2], [0.0, 0.5])
    cli = coefficients(q, behind, Walls.cli)
    np.testing.assert_allclose(cli[2, :2], [0.6 / 1.4, -0.6 / 1.4])
    np.testing.assert_allclose(cli[4, :2], [-1 / 3, 1 / 3])
    np.testing.assert_allclose(cli[:, 2:], 0.0)
    np.testing.assert_allclose(coefficients(q, ~behind, Walls.cli), 0.0)
    local = coefficients(q, ~behind, Walls.bfl)
    np.testing.assert_allclose(local[:, 0], 0.0)
    np.testing.assert_allclose(local[3, :2], [0.0, 1 - 0.5 / 0.7])
    mr1 = coefficients(q, behind, Walls.mr1, behind)
    np.testing.assert_allclose(mr1[0], [-0.5 / 2.25, 0.5 / 2.25, 0.25 / 2.25, -4 / 2.25])
    np.testing.assert_allclose(mr1[4], [-0.75, 0.75, 0.25, -1.0])
    np.testing.assert_allclose(coefficients(q, behind, Walls.mr1, ~behind), cli)
    np.testing.assert_allclose(coefficients(q, ~behind, Walls.mr1, behind), 0.0)


def test_ray_sphere_fractions_match_brute_force_with_periodic_images():
    """q of random links against a numpy loop over all spheres and all 27 images (1e-12); 0 for a node in a sphere."""
    rng = np.random.default_rng(7)
    shape = (13, 11, 9)
    centres = rng.uniform(0, 1, (15, 3)) * shape
    radii = rng.uniform(1.0, 4.5, 15)
    geo = SphereWalls(centres, radii, tuple(float(s) for s in shape))
    nodes = np.column_stack([rng.integers(0, s, 400) for s in shape])
    pops = rng.integers(1, 19, 400)
    got = geo.fractions(nodes, pops)
    x = nodes + 0.5
    d = -C[pops].astype(float)
    best = np.full(400, 2.0)
    inside = np.zeros(400, dtype=bool)
    shifts = np.array(np.meshgrid(*[[-1, 0, 1]] * 3, indexing="ij")).reshape(3, -1).T * shape
    for c, r in zip(centres, radii):
        for s in shifts:
            e = x - (c + s)
            a, b, cc = np.sum(d * d, 1), np.sum(e * d, 1), np.sum(e * e, 1) - r * r
            disc = b * b - a * cc
            t = np.where(disc >= 0, (-b - np.sqrt(np.maximum(disc, 0))) / a, 2.0)
            inside |= cc <= 0
            best = np.where((t > 0) & (t < best), t, best)
    want = np.where(inside, 0.0, np.where(best <= 1, best, -1.0))
    np.testing.assert_allclose(got, want, atol=1e-12)
    assert np.count_nonzero(want > 0) > 20


def test_grey_walls_locate_a_plane_from_partial_volumes():
    """A plane wall at z = 3.3 (matrix above): the partial voxel z = 3 has matrix fraction 0.7; links from the node
    z = 2 (centre 2.5) along +z cut the level ½ between fractions 0 and 0.7 at q = 0.5/0.7 of the link."""
    solid = np.zeros((2, 2, 6))
    solid[:, :, 3] = 0.7
    solid[:, :, 4:] = 1.0
    geo = GreyWalls(solid, 0.5)
    q = geo.fractions(np.array([[0, 0, 2], [0, 0, 2]]), np.array([6, 1]))  # c_6 = (0, 0, −1): upstream z = 3
    assert q[0] == pytest.approx(0.5 / 0.7, rel=1e-14) and q[1] == -1.0


def test_kappa_error_is_exact_for_a_geometric_approach():
    """κ_j = κ∞ (1 + A r^j): the tail estimate |Δ| r/(1 − r) equals the true remaining error."""
    kappas = [2.0 * (1 + 0.3 * 0.6**j) for j in range(6)]
    true = abs(kappas[-1] - 2.0) / kappas[-1]
    assert kappa_error(kappas) == pytest.approx(true, rel=1e-12)
    assert kappa_error(kappas[:2]) == float("inf")
    assert kappa_error([1.0, 1.1, 1.3]) == float("inf")  # changes growing: not converging
    assert kappa_error([1.0, 1.0 + 1e-9, 1.0 + 3e-9], noise=1e-7) == pytest.approx(2e-9, rel=1e-6)  # noise


@pytest.mark.parametrize("b", [1, 2, 3, 5])
def test_critical_throat_of_a_square_duct_is_its_width(b):
    """A duct of B × B nodes (halfway walls at ±B/2): w = 2·EDT − 1 is B for odd B (centre node EDT (B + 1)/2);
    for B = 2 every node has EDT 1, so w = 1 (the estimate is conservative for even widths)."""
    pore = np.zeros((6, b + 2, b + 2), dtype=bool)
    pore[:, 1:-1, 1:-1] = True
    w = critical_throat(pore, True)
    want = {1: 1.0, 2: 1.0, 3: 3.0, 5: 5.0}[b]
    assert w == pytest.approx(want)
