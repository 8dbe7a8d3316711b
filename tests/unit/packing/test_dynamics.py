"""Step kernel: Newton's third law, pair relaxation to dx_eq, damping (§5.3), neighbour lists vs all pairs."""

import itertools

import numba
import numpy as np
import pytest
from naive_packing import max_overlaps, min_image, neighbour_pairs

from porepipe.packing import _kernels as K
from porepipe.packing._api import pair_tables
from porepipe.packing._kernels import _pair_dxeq
from porepipe.packing._neighbours import build_neighbours


class Run:
    """A bare driver of the step kernel (list built once with a generous skin)."""

    def __init__(self, x, r, types, box, k_t, sig_t, xi_t, dt, periodic=True, skin=None, cut=1.3):
        self.x = np.array(x, float)
        self.r = np.array(r, float)
        self.types = np.array(types, np.int64)
        self.box = np.array(box, float)
        self.per = np.broadcast_to(np.asarray(periodic, bool), (3,)).copy()
        n, nt = len(self.r), len(k_t)
        self.v = np.zeros((n, 3))
        self.f = np.zeros((n, 3))
        self.k, self.sig = np.array(k_t, float), np.array(sig_t, float)
        xi = np.array(xi_t, float)
        self.cm, self.cp = 1 - 0.5 * dt * xi, 1 + 0.5 * dt * xi
        self.dt, self.cut = dt, cut
        skin = self.r.max() * 2 if skin is None else skin
        self.nbr = build_neighbours(
            self.x, self.r, self.types, self.box, self.per, np.ones((nt, nt), np.uint8), cut, skin, half=True
        )
        self.kernel = K.make_step_kernel(False, False, not self.per.all())
        self.sigmax = np.zeros(n)
        self.conv = np.zeros(n, np.uint8)
        self.s = 0

    def step(self):
        self.s += 1
        xn, fn = np.empty_like(self.x), np.empty_like(self.f)
        self.kernel(
            self.x,
            xn,
            self.v,
            self.f,
            fn,
            self.r,
            self.types,
            np.arange(len(self.r)),
            np.zeros(len(self.r), np.uint8),
            *self.nbr,
            self.box,
            self.per,
            *pair_tables(self.k, self.sig),
            self.sig,
            self.cm,
            self.cp,
            np.zeros(len(self.k)),
            self.cut,
            self.dt,
            1.0,
            0,
            self.s,
            self.x,
            self.r,
            self.sigmax,
            self.conv,
            np.empty((len(self.r), 3)),
            K.work_array(len(self.r)),
        )
        self.x, self.f = xn, fn

    def kinetic(self):
        return 0.5 * (self.v**2).sum()


def _random_spheres(rng, n, box, rmin, rmax):
    return rng.random((n, 3)) * box, rmin + (rmax - rmin) * rng.random(n)


def test_newtons_third_law_sum_of_forces_vanishes():
    rng = np.random.default_rng(11)
    box = np.array([40.0, 40.0, 40.0])
    x, r = _random_spheres(rng, 120, box, 1.0, 5.0)
    x[1] = x[0]  # coincident centres exercise the tie-break direction
    types = rng.integers(0, 2, 120)
    run = Run(x, r, types, box, [50.0, 5.0], [0.3, 0.2], [1.0, 1.0], 0.01)
    run.step()
    total = run.f.sum(axis=0)
    # each pair force is computed from bitwise-identical inputs at both ends, so only the summation order
    # differs: the residual is round-off, below 1e-12 of the summed magnitudes
    assert np.abs(total).max() <= 1e-12 * np.abs(run.f).sum()
    assert np.abs(run.f).sum() > 0


@pytest.mark.parametrize("ntypes", [1, 2])
def test_coincident_centres_push_apart_with_the_harmonic_force_at_distance_zero(ntypes):
    """Two spheres on one centre (plus one far away): the pair force is the law's value at distance 0,
    sqrt(k) (1 + k/4) / dx_eq (5.2.2, exact to round-off), along a unit direction, equal and opposite on the two.
    The batched pair pass evaluates such a pair apart from the others (its distance gives no direction)."""
    box = np.array([40.0, 40.0, 40.0])
    x = np.array([[10.0, 10.0, 10.0], [10.0, 10.0, 10.0], [30.0, 30.0, 30.0]])
    r = np.array([2.0, 1.5, 1.0])
    types = np.zeros(3, np.int64) if ntypes == 1 else np.array([0, 1, 0])
    k_t, sig_t = np.array([50.0, 30.0])[:ntypes], np.array([0.3, 0.2])[:ntypes]
    run = Run(x, r, types, box, k_t, sig_t, [1.0, 1.0], 0.01)
    run.step()
    k = k_t[types[:2]].mean()
    dxeq = 3.5 - 0.5 * sig_t[types[:2]].min() * (3.5 - 0.5)
    expected = np.sqrt(k) * (1 + k / 4) / dxeq
    assert np.linalg.norm(run.f[0]) == pytest.approx(expected, rel=1e-12)
    assert np.array_equal(run.f[1], -run.f[0])
    assert np.array_equal(run.f[2], np.zeros(3))
    # the direction is the pair's own draw (ids 0 and 1), the same for any list order or thread count: SplitMix64
    # counters (0x5EED, 0, 1, axis) written out here in Python integers; 1e-15: one rounding per component
    np.testing.assert_allclose(
        run.f[0] / np.linalg.norm(run.f[0]), _tie_direction_reference(0, 1), rtol=0, atol=1e-15
    )


def _splitmix64(z: int) -> int:
    mask = (1 << 64) - 1
    z = (z + 0x9E3779B97F4A7C15) & mask
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
    return z ^ (z >> 31)


def _tie_direction_reference(i: int, j: int) -> np.ndarray:
    """The unit push direction on sphere id i from id j at coincident centres: uniform numbers in [0, 1) from the
    counters (0x5EED, min, max, axis), shifted by 1/2 and normalised, the sign flipped for the larger id."""
    a, b = min(i, j), max(i, j)
    u = [
        (_splitmix64(0x5EED ^ _splitmix64(a ^ _splitmix64(b ^ _splitmix64(c)))) >> 11) / 2.0**53 - 0.5
        for c in range(3)
    ]
    return (1.0 if i < j else -1.0) * np.array(u) / np.linalg.norm(u)


def _all_pairs_forces(x, r, types, box, per, k_t, sig_t, cut):
    """Pair forces summed over all pairs in reach, straight from the force law (5.2.2) in NumPy, O(N^2)."""
    d = min_image(x[:, None, :] - x[None, :, :], box, per)
    dist = np.sqrt((d * d).sum(-1))
    np.fill_diagonal(dist, np.inf)
    k = 0.5 * (k_t[types][:, None] + k_t[types][None, :])
    rsum = r[:, None] + r[None, :]
    dxeq = rsum - 0.5 * np.minimum(sig_t[types][:, None], sig_t[types][None, :]) * (
        rsum - np.abs(r[:, None] - r[None, :])
    )
    u8 = (dxeq / dist) ** 8
    f = np.where(
        dist <= dxeq, np.sqrt(k) * (1 + k / 4) / dxeq * (1 - dist / dxeq), 4 * k / dist * u8 * (u8 - 1)
    )
    f = np.where(dist <= cut * dxeq, f, 0.0)
    return (f[..., None] * d / dist[..., None]).sum(1)


@pytest.mark.parametrize("ntypes", [1, 2])
@pytest.mark.parametrize("periodic", [True, [True, False, True]])
def test_forces_and_overlaps_equal_all_pairs_for_any_thread_count(periodic, ntypes):
    """Each listed pair is evaluated once and applied to both ends, slab colours one after another: the forces equal
    an all-pairs sum of the force law to round-off (1e-12 of the largest force: only the summation order differs),
    max sigma equals the all-pairs maximum, and 1 and 2 threads give the same bits (box wide enough for 12 slabs).
    A slab holds more pairs than one evaluation batch (K._BATCH), so batch boundaries are crossed; one type takes
    the kernel's path without type tables."""
    rng = np.random.default_rng(3)
    box = np.array([30.0, 150.0, 40.0])
    x, r = _random_spheres(rng, 1000, box, 2.0, 4.0)
    types = rng.integers(0, ntypes, r.size)
    k_t, sig_t = np.array([40.0, 10.0])[:ntypes], np.array([0.3, 0.2])[:ntypes]
    got = []
    for threads in (1, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        try:
            run = Run(x, r, types, box, k_t, sig_t, [1.0, 1.0], 0.01, periodic=periodic, skin=1.0)
            run.step()
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        got.append((run.f.copy(), run.sigmax.copy()))
    # slabs along y, at least one reach 1.3 * 8 + 1 wide: 13, or 12 with periodic faces (a multiple of 3)
    assert run.nbr[2].size - 1 == (12 if run.per[1] else 13)
    ref = _all_pairs_forces(x, np.asarray(r), types, box, run.per, k_t, sig_t, 1.3)
    assert np.abs(got[0][0] - ref).max() <= 1e-12 * np.abs(ref).max()
    sig_ref = max_overlaps(x, np.asarray(r), box, run.per)
    np.testing.assert_allclose(np.maximum(got[0][1], 0.0), np.maximum(sig_ref, 0.0), rtol=0, atol=1e-14)
    assert got[0][0].tobytes() == got[1][0].tobytes() and got[0][1].tobytes() == got[1][1].tobytes()
    degree, (slab_start, slab_items) = np.diff(run.nbr[0]), run.nbr[2:]
    assert max(degree[slab_items[a:b]].sum() for a, b in itertools.pairwise(slab_start)) > K._BATCH


@pytest.mark.parametrize("ta,tb", [(0, 0), (0, 1), (1, 1)])
def test_two_spheres_relax_to_equilibrium_distance(ta, tb):
    radii = [30.0, 10.0]
    sig_t = [0.2, 0.4]
    r = [radii[ta], radii[tb]]
    dxeq = _pair_dxeq(r[0], r[1], min(sig_t[ta], sig_t[tb]))
    x = [[100.0, 100.0, 100.0], [100.0 + 0.97 * dxeq, 100.0, 100.0]]
    run = Run(x, r, [ta, tb], [400.0, 400.0, 400.0], [200.0, 60.0], sig_t, [0.3, 0.3], 0.2)
    for _ in range(2000):
        run.step()
    dist = np.linalg.norm(run.x[1] - run.x[0])
    # the damped pair converges geometrically; after 2000 steps (>= 40 e-foldings) the distance is at dx_eq to round-off level
    assert dist == pytest.approx(dxeq, rel=1e-9)
    assert run.kinetic() < 1e-16


def test_damping_decay_of_free_spheres_in_a_closed_box():
    # spheres far apart (no partners) in a box closed by walls: v^s = (C-/C+) v^{s-1} exactly, so the kinetic
    # energy decays monotonically by (C-/C+)^2 per step, wall reflections included
    rng = np.random.default_rng(3)
    box = [300.0, 300.0, 300.0]
    x = np.array([[50, 50, 50], [250, 50, 50], [50, 250, 250], [250, 250, 50]], float)
    dt, xi = 0.5, 0.3
    run = Run(x, [1.0] * 4, [0] * 4, box, [10.0], [0.3], [xi], dt, periodic=False, skin=1.0)
    run.v[:] = rng.normal(0, 40.0, (4, 3))
    ratio = ((1 - 0.5 * dt * xi) / (1 + 0.5 * dt * xi)) ** 2
    ke = [run.kinetic()]
    for _ in range(60):
        run.step()
        ke.append(run.kinetic())
        assert np.all((run.x >= 0) & (run.x <= 300))
    ke = np.array(ke)
    np.testing.assert_allclose(ke[1:] / ke[:-1], ratio, rtol=1e-12)


def test_damped_interacting_pair_energy_peaks_decrease():
    # an attracting pair in a closed box oscillates about dx_eq; with damping every kinetic-energy peak is lower
    run = Run(
        [[40.0, 50, 50], [61.0, 50, 50]],
        [10.0, 10.0],
        [0, 0],
        [100.0] * 3,
        [30.0],
        [0.3],
        [0.4],
        0.1,
        periodic=False,
    )
    ke = []
    for _ in range(400):
        run.step()
        ke.append(run.kinetic())
    ke = np.array(ke)
    peaks = ke[1:-1][(ke[1:-1] > ke[:-2]) & (ke[1:-1] >= ke[2:])]
    assert peaks.size >= 3
    assert np.all(np.diff(peaks) < 0)


@pytest.mark.parametrize("periodic", [True, False])
def test_neighbour_list_equals_all_pairs_reference(periodic):
    rng = np.random.default_rng(5)
    box = np.array([120.0, 90.0, 150.0])
    # radius ratio 100 : 1 puts the spheres into 7 radius classes with their own grids
    r = np.concatenate([rng.uniform(0.3, 0.6, 400), rng.uniform(2, 8, 60), rng.uniform(20, 30, 4)])
    x = rng.random((r.size, 3)) * box
    per = np.full(3, periodic)
    start, idx = build_neighbours(
        x, r, np.zeros(r.size, np.int64), box, per, np.ones((1, 1), np.uint8), 1.3, 0.2
    )
    got = set()
    for i in range(r.size):
        js = idx[start[i] : start[i + 1]]
        assert len(set(js.tolist())) == js.size, "duplicate partner"
        got |= {(min(i, j), max(i, j)) for j in js.tolist()}
    assert got == neighbour_pairs(x, r, box, per, 1.3, 0.2)
    assert idx.size == 2 * len(got)


@pytest.mark.parametrize("n", [1, 63, 64, 65, 10007])
def test_step_reductions_match_numpy(n):
    """The fused one-pass reductions of a step equal the plain numpy ones (sums to 1e-12 relative: other order)."""
    from porepipe.packing._api import _step_stats

    rng = np.random.default_rng(n)
    sig = rng.normal(size=n)
    sig[rng.random(n) < 0.2] = -np.inf
    conv = (rng.random(n) < 0.5).astype(np.uint8)
    aux = rng.random((n, 3))
    nconv, ke, smax, ssum, scnt, dmax, darg, stale, bad = _step_stats(sig, conv, aux)
    finite = sig > -np.inf
    assert (nconv, scnt, smax, stale, bad) == (conv.sum(), finite.sum(), sig.max(), aux[:, 2].max(), -1)
    assert ke == pytest.approx(aux[:, 0].sum(), rel=1e-12)
    assert ssum == pytest.approx(sig[finite].sum(), rel=1e-12, abs=1e-12)
    assert (dmax, darg) == (aux[:, 1].max(), np.argmax(aux[:, 1]))
    aux[n // 2, 0] = np.nan
    assert _step_stats(sig, conv, aux)[-1] == n // 2
