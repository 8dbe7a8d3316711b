"""Sparse kernels against the dense reference in naive_lbm.py, and the conservation laws of a collision."""

import numpy as np
import pytest
from naive_lbm import collision_matrix, equilibrium, step

from porepipe.lbm import Settings, SphereWalls
from porepipe.lbm._domain import build_lattice
from porepipe.lbm._lattice import OPPOSITE, C, W, dhumieres_matrix, mrt_rates
from porepipe.lbm._solver import make_stepper


def _random_pore(shape, porosity, seed):
    rng = np.random.default_rng(seed)
    return rng.random(shape) < porosity


def _naive_gather(pore, periodic):
    """gather[q-1, n] by explicit loops: flat index of the pull source, own opposite population if solid."""
    ids = -np.ones(pore.shape, dtype=np.int64)
    ids[pore] = np.arange(np.count_nonzero(pore))
    n = int(np.count_nonzero(pore))
    out = np.empty((18, n), dtype=np.int64)
    for (i, j, k), node in np.ndenumerate(ids):
        if node < 0:
            continue
        for q in range(1, 19):
            pos = [i - C[q, 0], j - C[q, 1], k - C[q, 2]]
            ok = True
            for a in range(3):
                if periodic[a]:
                    pos[a] %= pore.shape[a]
                elif not 0 <= pos[a] < pore.shape[a]:
                    ok = False
            src = ids[tuple(pos)] if ok else -1
            out[q - 1, node] = q * n + src if src >= 0 else OPPOSITE[q] * n + node
    return out


@pytest.mark.parametrize("periodic", [(True, True, True), (True, False, True), (False, False, False)])
def test_gather_table_matches_explicit_loops(periodic):
    pore = _random_pore((5, 4, 6), 0.6, seed=1)
    lat = build_lattice(pore, periodic, (0, 5), (0, 5))
    np.testing.assert_array_equal(lat.full_gather(), _naive_gather(pore, periodic))


def _open_pore():
    """Mostly open box with a few solid voxels: long storage-order runs (offset streaming) and irregular ones."""
    pore = np.ones((5, 4, 26), dtype=bool)
    pore[2, 1, 3] = pore[3, 2, 17] = pore[0, 3, 10] = False
    return pore


def test_runs_reproduce_the_gather_table():
    """Every node of a regular run pulls from run_offset + node, exactly the gather table's entry; both kinds occur."""
    lat = build_lattice(_open_pore(), (True, False, True), (0, 5), (0, 5))
    regular = lat.run_offset[:, 0] >= 0
    assert regular.any() and (~regular).any()
    assert lat.run_start[0] == 0 and lat.run_start[-1] == lat.n_nodes and np.all(np.diff(lat.run_start) > 0)
    for r in np.flatnonzero(regular):
        nodes = np.arange(lat.run_start[r], lat.run_start[r + 1])
        np.testing.assert_array_equal(lat.full_gather()[:, nodes], lat.run_offset[r][:, None] + nodes)


def _chunked_pore():
    """More pore nodes than one parallel work chunk, mostly open: runs and tiles cross chunk boundaries."""
    pore = _random_pore((5, 40, 100), 0.995, seed=4)
    from porepipe.lbm import _kernels

    assert np.count_nonzero(pore) > 1.1 * _kernels._CHUNK
    return pore


_GEOMETRIES = {
    "random": lambda: _random_pore((5, 4, 6), 0.7, seed=2),
    "open": _open_pore,
    "chunks": _chunked_pore,
}


@pytest.mark.parametrize("collision", ["bgk", "trt", "mrt"])
@pytest.mark.parametrize("force_layers", [(0, 5), (1, 3)])
@pytest.mark.parametrize("geometry", list(_GEOMETRIES))
@pytest.mark.parametrize("stores", ["STORE_CACHED", "STORE_STREAM", "IN_PLACE"])
def test_sparse_steps_match_dense_reference(collision, force_layers, geometry, stores):
    """Five fused pull/collide steps on a random porous box (gather-table path), on a mostly open box (mostly
    offset-streaming runs) and on an open box of several parallel chunks equal the dense reference, with cached and
    with non-temporal population stores, and in place (two AA step pairs, then one pull step).

    Tolerance 1e-13 absolute on populations of size ~0.1: both are float64 with different summation order.
    """
    from porepipe.lbm import _kernels

    pore = _GEOMETRIES[geometry]()
    periodic = (True, False, True)
    lat = build_lattice(pore, periodic, force_layers, (0, 5))
    tau = 0.8
    settings = Settings(collision=collision, tau=tau, body_force=1e-3)
    rng = np.random.default_rng(3)
    rho0 = 1 + 0.01 * rng.standard_normal(pore.shape)
    u0 = 0.02 * rng.standard_normal((3,) + pore.shape)
    dense = np.where(pore, equilibrium(rho0, u0) + 1e-3 * rng.standard_normal((19,) + pore.shape), 0.0)
    n = lat.n_nodes
    sparse = (dense[:, pore] - W[:, None]).reshape(-1).copy()  # zero-centred
    other = np.zeros_like(sparse)
    fields = np.zeros((4, n))
    mask = np.zeros(pore.shape)
    mask[force_layers[0] : force_layers[1]] = 1
    a_matrix = collision_matrix(collision, tau)
    for _ in range(5):
        dense, rho, u = step(dense, pore, periodic, a_matrix, (1e-3, 0, 0), mask)
    make_stepper(settings, lat, stores=getattr(_kernels, stores))(sparse, other, fields, True, 5)
    result = other  # odd number of steps ends in the second buffer
    np.testing.assert_allclose(result.reshape(19, n) + W[:, None], dense[:, pore], rtol=0, atol=1e-13)
    np.testing.assert_allclose(1 + fields[0], rho[pore], rtol=0, atol=1e-13)
    np.testing.assert_allclose(fields[1:], u[:, pore], rtol=0, atol=1e-13)


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("geometry", ["random", "chunks"])
@pytest.mark.parametrize("steps", [3, 4])
def test_store_modes_write_identical_populations(precision, geometry, steps):
    """Cached stores, line-wide non-temporal vector stores (rows start anywhere within a cache line: element-wise
    head and tail), the old element-wise non-temporal loop and in-place AA streaming (step pairs in one array, an
    odd last step pulled into the other) write the same bits, and the same fields of the last step: how a value
    is streamed and stored cannot change it. TRT steps with a body force from random populations, compared exactly.
    The AA gather step collides the irregular nodes in place through the gather table for float64 storage, through
    the tile scratch (pulled, collided, scattered back) for float32, the regular runs via the tile scratch: "random" is
    all irregular, "chunks" has both."""
    from porepipe.lbm import _kernels

    pore = _GEOMETRIES[geometry]()
    lat = build_lattice(pore, (True, False, True), (0, 5), (0, 5))
    regular = lat.run_offset[:, 0] >= 0
    # both ways of an AA gather step: irregular runs in place through the gather table, regular runs by offset
    # ("chunks" also has tiles holding runs of both kinds)
    assert np.any(~regular) and (geometry == "random" or np.any(regular))
    start = (1e-2 * np.random.default_rng(6).standard_normal(19 * lat.n_nodes)).astype(precision)
    results = []
    for mode in (_kernels.STORE_CACHED, _kernels.STORE_STREAM, _kernels.LEGACY, _kernels.IN_PLACE):
        src, dst = start.copy(), np.zeros_like(start)
        fields = np.zeros((4, lat.n_nodes))
        make_stepper(Settings(body_force=1e-4, precision=precision), lat, stores=mode)(
            src, dst, fields, True, steps
        )
        results.append((dst if steps % 2 else src, fields))
    assert np.any(results[0][0] != 0) and np.any(results[0][1] != 0)
    for pops, fields in results[1:]:
        np.testing.assert_array_equal(pops, results[0][0])
        np.testing.assert_array_equal(fields, results[0][1])


def test_kernel_without_in_place_code_refuses_in_place_streaming():
    """The step kernel compiled without the AA gather step (``with_aa`` False: interpolated walls, ``streaming:
    pull``) would skip every gather step of an in-place run: the call is refused before anything runs."""
    from porepipe.lbm import _kernels

    lat = build_lattice(_random_pore((4, 4, 4), 0.7, 3), (True, True, True), (0, 4), (0, 4))
    src = np.zeros(19 * lat.n_nodes)
    none = np.zeros(0)
    args = (src, src, lat.gather, lat.run_start, lat.run_offset, lat.run_base, 0, 4, np.zeros(3))
    with pytest.raises(ValueError, match="IN_PLACE needs the kernel variant compiled with_aa"):
        _kernels.step(_kernels.TRT, False, *args, np.zeros((4, 0)), False, 2, _kernels.IN_PLACE, none, none)


def test_mrt_rates_match_thesis_and_odd_rates_follow_magic():
    """Thesis Eq. 6.1.14 diagonal; with Λ the q and m moments relax with 1/τ⁻ = 1/(½ + Λ/(τ − ½))."""
    s = mrt_rates(0.857, 1.0)
    assert s[[9, 11, 13, 14, 15]] == pytest.approx([1 / 0.857] * 5, rel=1e-15)
    assert s[[2, 4, 10, 16]] == pytest.approx([1.4, 1.2, 1.4, 1.98], rel=1e-15)
    tied = mrt_rates(1.0, 1.0, magic=3 / 16)
    assert tied[[4, 6, 8, 16, 17, 18]] == pytest.approx([1 / (0.5 + 0.375)] * 6, rel=1e-15)


def test_moment_basis_is_orthogonal_and_equilibrium_moments_are_dhumieres():
    """d'Humières (2002): rows orthogonal; e_eq = −11ρ + 19 j²/ρ, ε_eq = 3ρ − 11/2 j²/ρ, q_eq = −2/3 j."""
    m = dhumieres_matrix()
    gram = m @ m.T
    np.testing.assert_allclose(gram, np.diag(np.diag(gram)), atol=1e-12)
    j = np.array([0.01, -0.02, 0.03])
    meq = m @ equilibrium(np.array(1.0), j)
    jj = j @ j
    np.testing.assert_allclose(meq[[1, 2, 4]], [-11 + 19 * jj, 3 - 5.5 * jj, -2 / 3 * j[0]], atol=1e-14)


@pytest.mark.parametrize("collision", ["bgk", "trt", "mrt"])
def test_collision_conserves_mass_and_gives_momentum_rho_b(collision):
    """On one node with periodic self-links only the collision acts: Σf kept, Σf c grows by ρ b exactly."""
    pore = np.ones((1, 1, 1), dtype=bool)
    lat = build_lattice(pore, (True, True, True), (0, 1), (0, 1))
    b = 1e-4
    settings = Settings(collision=collision, tau=0.9, body_force=b)
    rng = np.random.default_rng(5)
    f = 1e-3 * rng.standard_normal(19)
    src = f.copy()
    dst = np.zeros(19)
    make_stepper(settings, lat)(src, dst, np.zeros((4, 1)), True, 1)
    rho = 1 + f.sum()
    assert dst.sum() == pytest.approx(f.sum(), abs=1e-16)
    np.testing.assert_allclose(C.T @ dst, C.T @ f + np.array([rho * b, 0, 0]), rtol=0, atol=1e-17)


def test_mrt_with_distinct_rates_equals_dense_moment_transform(monkeypatch):
    """The written-out MRT transform against f − M⁻¹ Š M (f − f^eq) + φ with M⁻¹ from numpy, on one node with
    periodic self-links (streaming is the identity). Every non-conserved row gets its own rate, so a row of the
    sparse transform mapped to the wrong rate or with a wrong entry shows. Tolerance 1e-16 absolute on f ~ 1e-2."""
    from porepipe.lbm import _solver

    rng = np.random.default_rng(8)
    rates = rng.uniform(0.5, 1.9, 19)
    rates[[0, 3, 5, 7]] = 0.0  # ρ and j are conserved
    monkeypatch.setattr(_solver, "mrt_rates", lambda *args: rates)
    lat = build_lattice(np.ones((1, 1, 1), dtype=bool), (True, True, True), (0, 1), (0, 1))
    b = 1e-4
    f = 1e-2 * rng.standard_normal(19)
    dst = np.zeros(19)
    make_stepper(Settings(collision="mrt", body_force=b), lat)(f.copy(), dst, np.zeros((4, 1)), True, 1)
    m = dhumieres_matrix()
    rho = 1 + f.sum()
    feq = equilibrium(np.array(rho), C.T @ (f + W) / rho) - W
    phi = 3 * W * rho * C[:, 0] * b
    np.testing.assert_allclose(
        dst, f - np.linalg.inv(m) @ (rates * (m @ (f - feq))) + phi, rtol=0, atol=1e-16
    )


def _sphere_array():
    """Simple-cubic sphere array (radius 5.3 in 16-voxel cells, c ≈ 0.15), three cells along z: the storage rows are
    long enough for regular runs."""
    centres, radii = np.array([[8.0, 8.0, 8.0], [8.0, 8.0, 24.0], [8.0, 8.0, 40.0]]), np.full(3, 5.3)
    return _spheres_in((16, 16, 48), centres, radii)


def _overlapping_spheres():
    """A porous sample: 40 overlapping spheres (radius 3) at random in a periodic 20 × 20 × 60 box, porosity ≈ 0.8."""
    rng = np.random.default_rng(12)
    return _spheres_in((20, 20, 60), rng.uniform(0, 1, (40, 3)) * (20, 20, 60), np.full(40, 3.0))


def _spheres_in(shape, centres, radii):
    """Pore space (voxel centres outside every sphere and its periodic images) and the exact spheres."""
    box = np.array(shape, dtype=float)
    x = np.indices(shape).reshape(3, -1).T + 0.5
    d = np.abs(x[:, None, :] - centres[None])
    d = np.minimum(d, box - d)
    pore = (np.linalg.norm(d, axis=2) > radii).all(axis=1).reshape(shape)
    return pore, SphereWalls(centres, radii, tuple(box))


@pytest.mark.parametrize("sample", [_sphere_array, _overlapping_spheres], ids=["sphere_array", "porous"])
@pytest.mark.parametrize("walls", ["halfway", "cli"])
def test_new_kernel_gives_the_old_kernels_kappa(sample, walls, monkeypatch):
    """κ of the default TRT (Λ = 3/16) after 1000 steps (4 checks) with the current kernel (in place with halfway
    walls, odd step counts between checks included; tiles of regular runs collide straight from the population
    array) and with the two-array kernel before issue 22 (``LEGACY``: every tile through the scratch, element-wise
    stores) on a sphere array and a porous sample, halfway and interpolated (CLI) walls.
    Tolerance: none — the two do the same arithmetic in the same order, so every κ̂ agrees to the last bit."""
    from porepipe.lbm import _kernels, permeability

    pore, spheres = sample()
    lat = build_lattice(pore, (True,) * 3, (0, pore.shape[0]), (0, pore.shape[0]))
    assert np.diff(lat.run_start)[lat.run_offset[:, 0] >= 0].sum() > 0.2 * lat.n_nodes  # the new path runs
    settings = Settings(walls=walls, max_steps=1000, window_steps=250, accept_unconverged=True)
    geometry = spheres if walls == "cli" else None
    new = permeability(pore, "x", settings, progress=False, geometry=geometry)
    monkeypatch.setattr(_kernels, "streams", lambda src: _kernels.LEGACY)
    pull = Settings(**{**settings.model_dump(), "streaming": "pull"})
    old = permeability(pore, "x", pull, progress=False, geometry=geometry)
    assert new.steps == old.steps == 1000 and new.kappa_lu > 0
    np.testing.assert_array_equal(new.history["kappa"], old.history["kappa"])
