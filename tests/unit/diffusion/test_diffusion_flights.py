"""Exact flights: the DDA with jumps against an independent sort-all-crossings reference, and the edge cases."""

import numpy as np
import pytest
from naive_diffusion import flight_naive
from numba import njit

from porepipe.diffusion import _kernels as K
from porepipe.diffusion._kernels import (
    _AHEAD,
    _EDGE_CODE,
    _HALF_WIDTH,
    _JUMP_CODE,
    _NEVER,
    _PRISM_CODE,
    _SLAB_CODE,
    _advance,
    _ahead_cube,
    _box_codes,
    _chessboard_distance,
    _fly,
)


def _codes(pore):
    codes = np.empty(pore.shape, np.uint8)
    _box_codes(pore.astype(np.uint8), codes)
    return codes


def _check_end(codes, h, pos, idx, event):
    """The particle ends in a pore voxel, inside its closed box, on the face of the event, facing solid."""
    assert codes[tuple(idx)] > 0
    lo, hi = idx * h, (idx + 1) * h
    assert np.all(pos >= lo) and np.all(pos <= hi)
    d, up = event >> 1, event & 1
    assert pos[d] == (hi[d] if up else lo[d])  # exactly on the plane, no round-off
    nb = idx.copy()
    nb[d] += 1 if up else -1
    assert not (0 <= nb[d] < codes.shape[d]) or codes[tuple(nb)] == 0


def _assert_flight_as_reference(codes, h, pos, idx, u, tol=1e-9):
    """One closed-box flight from ``pos`` (in voxel ``idx``) along ``u``: the event, length and end point of the
    sort-all-crossings reference (length to ``tol``), ending in pore on the event's face (:func:`_check_end`)."""
    ref = flight_naive(codes, h, pos.copy(), u)
    assert ref is not None
    t_ref, ev_ref = ref
    p, i = pos.copy(), idx.copy()
    event, length, _ = _fly(codes, h, np.zeros(3, np.bool_), -1, p, i, u, np.zeros(3, np.int64))
    assert event == ev_ref
    assert length == pytest.approx(t_ref, rel=tol, abs=tol)
    np.testing.assert_allclose(p, pos + t_ref * u, rtol=0, atol=1e-9)
    _check_end(codes, h, p, i, event)


@pytest.mark.parametrize("h", [(1.0, 1.0, 1.0), (1.0, 1.0, 6.1), (0.5, 1.3, 1.0)])
def test_random_flights_match_reference_and_never_enter_solid(h):
    rng = np.random.default_rng(42)
    pore = (rng.random((14, 12, 16)) < 0.93).astype(np.uint8)
    pore[3:11, 3:9, 3:13] = 1  # a big cavity, so the jumps are exercised too
    codes = _codes(pore)
    h = np.array(h)
    cells = np.argwhere(codes > 0)
    n_flights = 400
    for _ in range(n_flights):
        idx = cells[rng.integers(len(cells))].astype(np.int64)
        pos = (idx + rng.random(3)) * h
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        _assert_flight_as_reference(codes, h, pos, idx, u)


def test_many_consecutive_flights_stay_in_pore():
    """A particle bouncing 20 000 times (new random directions into the pore) never ends outside the pore space."""
    rng = np.random.default_rng(1)
    pore = (rng.random((20, 20, 20)) < 0.85).astype(np.uint8)
    codes = _codes(pore)
    h = np.ones(3)
    periodic = np.zeros(3, dtype=np.bool_)
    img = np.zeros(3, dtype=np.int64)
    idx = np.argwhere(codes > 0)[0].astype(np.int64)
    pos = (idx + 0.5) * h
    for _ in range(20000):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        event, _, _ = _fly(codes, h, periodic, -1, pos, idx, u, img)
        _check_end(codes, h, pos, idx, event)
        # leave the wall into the pore: flip the normal component if it points into the solid
        d, up = event >> 1, event & 1
        nxt = rng.normal(size=3)
        nxt[d] = -abs(nxt[d]) if up else abs(nxt[d])
        u = nxt / np.linalg.norm(nxt)
        event, _, _ = _fly(codes, h, periodic, -1, pos, idx, u, img)
        _check_end(codes, h, pos, idx, event)


def test_zero_components_fly_along_the_axis():
    pore = np.ones((3, 3, 10), np.uint8)
    pore[1, 1, 7] = 0
    codes = _codes(pore)
    h = np.ones(3)
    per = np.zeros(3, dtype=np.bool_)
    img = np.zeros(3, dtype=np.int64)
    pos, idx = np.array([1.5, 1.5, 0.25]), np.array([1, 1, 0])
    event, length, cross = _fly(codes, h, per, -1, pos, idx, np.array([0.0, 0.0, 1.0]), img)
    assert (event, length, cross) == (5, 6.75, 6)
    assert pos.tolist() == [1.5, 1.5, 7.0] and idx.tolist() == [1, 1, 6]
    pos, idx = np.array([1.5, 1.5, 2.5]), np.array([1, 1, 2])
    event, length, _ = _fly(codes, h, per, -1, pos, idx, np.array([-1.0, 0.0, 0.0]), img)
    assert (event, length) == (0, 1.5) and pos.tolist() == [0.0, 1.5, 2.5]


def test_edge_and_corner_hits_are_deterministic():
    """A flight exactly through an edge / a corner: ties go to the lowest axis first (documented rule)."""
    h = np.ones(3)
    per = np.zeros(3, dtype=np.bool_)
    img = np.zeros(3, dtype=np.int64)
    pore = np.ones((3, 3, 3), np.uint8)
    pore[2, 2, :] = 0  # solid column: the diagonal from the centre of (1, 1, z) meets its edge at (2, 2)
    codes = _codes(pore)
    u = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    pos, idx = np.array([1.5, 1.5, 1.5]), np.array([1, 1, 1])
    event, length, _ = _fly(codes, h, per, -1, pos, idx, u, img)
    assert event == 3 and idx.tolist() == [
        2,
        1,
        1,
    ]  # stepped x into (2,1,1), then met the y face of the column
    np.testing.assert_allclose(pos, [2.0, 2.0, 1.5], atol=1e-12)
    assert length == pytest.approx(np.sqrt(0.5))
    pore = np.ones((3, 3, 3), np.uint8)
    pore[2, 2, 2] = 0
    codes = _codes(pore)
    u = np.ones(3) / np.sqrt(3.0)
    for _ in range(2):  # same input, same answer
        pos, idx = np.array([1.5, 1.5, 1.5]), np.array([1, 1, 1])
        event, length, _ = _fly(codes, h, per, -1, pos, idx, u, img)
        assert event == 5 and idx.tolist() == [2, 2, 1]
        np.testing.assert_allclose(pos, [2.0, 2.0, 2.0], atol=1e-12)


def test_exit_and_periodic_wrap():
    pore = np.ones((4, 4, 5), np.uint8)
    codes = _codes(pore)
    h = np.ones(3)
    img = np.zeros(3, dtype=np.int64)
    per = np.array([True, False, False])
    u = np.array([3.0, 0.0, 4.0]) / 5.0
    pos, idx = np.array([0.5, 2.5, 0.0]), np.array([0, 2, 0])
    event, length, _ = _fly(codes, h, per, 2, pos, idx, u, img)
    assert event == 7 and length == pytest.approx(5 / 0.8)
    assert pos[2] == 5.0  # exactly on the outlet plane
    assert img.tolist() == [1, 0, 0] and pos[0] == pytest.approx(0.25)  # x: 0.5 + 3.75 = 4.25 -> wrapped once


@pytest.mark.parametrize("zero", [(0,), (1,), (2,), (0, 1), (1, 2), (0, 2)])
def test_jumps_with_zero_direction_components_match_reference(zero):
    """Flights that do not move along some axes (no face of that axis is ever crossed, its jump count is 0) through
    a big cavity, where they jump, against the sort-all-crossings reference (a solid shell: every hit is on a solid
    voxel, which the reference finds also for flights along one axis)."""
    rng = np.random.default_rng(7)
    pore = (rng.random((24, 22, 26)) < 0.97).astype(np.uint8)
    pore[2:22, 2:20, 2:24] = 1
    pore[[0, -1], :, :] = pore[:, [0, -1], :] = pore[:, :, [0, -1]] = 0
    codes = _codes(pore)
    h = np.array([1.0, 0.7, 1.3])
    cells = np.argwhere(codes >= 4)
    for _ in range(200):
        idx = cells[rng.integers(len(cells))].astype(np.int64)
        pos = (idx + rng.random(3)) * h
        u = rng.normal(size=3)
        u[list(zero)] = 0.0
        u /= np.linalg.norm(u)
        _assert_flight_as_reference(codes, h, pos, idx, u, tol=1e-12)


def test_lengths_are_exact_to_round_off_after_many_jumps():
    """A long flight through a big closed box (many jumps and face steps) ends at the analytic wall hit: the
    crossing times are kept from the flight's start, not re-accumulated per segment (1e-13 relative)."""
    codes = _codes(np.ones((60, 60, 300), np.uint8))
    h = np.ones(3)
    periodic = np.zeros(3, dtype=np.bool_)
    img = np.zeros(3, dtype=np.int64)
    rng = np.random.default_rng(3)
    for _ in range(200):
        pos = np.array([30.0, 30.0, 0.0]) + rng.random(3) * [0.5, 0.5, 0.0]
        idx = np.floor(pos).astype(np.int64)
        u = np.array([rng.normal() * 0.05, rng.normal() * 0.05, 1.0])
        u /= np.linalg.norm(u)
        t_ref, ev_ref = flight_naive(codes, h, pos.copy(), u)
        event, length, _ = _fly(codes, h, periodic, -1, pos, idx, u, img)
        assert event == ev_ref
        assert length == pytest.approx(t_ref, rel=1e-13)


def test_wall_across_a_periodic_face_keeps_the_image_count():
    """A wall met in the voxel across a periodic face: the particle stays on this side, so no wrap is counted
    (unwrapped position = pos + img * n * h stays continuous)."""
    pore = np.ones((4, 3, 3), np.uint8)
    pore[0, 1, 1] = pore[2, 0, 1] = 0
    codes = _codes(pore)
    per = np.array([True, False, False])
    img = np.zeros(3, dtype=np.int64)
    pos, idx = np.array([3.5, 1.5, 1.5]), np.array([3, 1, 1])
    event, length, _ = _fly(codes, np.ones(3), per, -1, pos, idx, np.array([1.0, 0.0, 0.0]), img)
    assert (event, length) == (1, 0.5)
    assert pos.tolist() == [4.0, 1.5, 1.5] and idx.tolist() == [3, 1, 1]
    assert img.tolist() == [0, 0, 0]
    pos, idx = np.array([3.5, 0.5, 1.5]), np.array([3, 0, 1])  # a pore voxel across the face: wrap and go on
    event, length, _ = _fly(codes, np.ones(3), per, -1, pos, idx, np.array([1.0, 0.0, 0.0]), img)
    assert (event, length) == (1, 2.5) and img.tolist() == [1, 0, 0]
    assert pos.tolist() == [2.0, 0.5, 1.5] and idx.tolist() == [1, 0, 1]


@pytest.mark.parametrize("h", [(1.0, 1.0, 1.0), (0.6, 1.0, 1.7)])
def test_flights_from_the_walls_jump_through_cubes_ahead_and_match_reference(h):
    """Flights that start next to a wall (codes below _JUMP_CODE), where the cube centred on the voxel is too small to
    jump: each cube tried ahead of the voxel (`_ahead_cube`, every offset of _AHEAD) must hold the voxel and be all
    pore. A channel with a few solid pillars, so that some tried cubes are refused; against the sort-all-crossings
    reference."""
    rng = np.random.default_rng(11)
    pore = np.ones((26, 22, 40), np.uint8)
    for _ in range(6):
        a, b, c = rng.integers(0, 26), rng.integers(0, 22), rng.integers(0, 40)
        pore[a, b : b + 3, c : c + 2] = 0
    codes = _codes(pore)
    chess = np.empty(pore.shape, np.uint8)
    _chessboard_distance(pore, chess)
    h = np.array(h)
    cells = np.argwhere((chess >= 1) & (chess < _JUMP_CODE))  # some are slab voxels
    n, used = codes.shape, {}
    for _ in range(1200):
        idx = cells[rng.integers(len(cells))].astype(np.int64)
        pos = (idx + rng.random(3)) * h
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        s = np.sign(u).astype(np.int64)
        c = codes[tuple(idx)]
        ahead = _ahead_cube(codes.reshape(-1), *n, *idx, *s, np.ravel_multi_index(idx, n), c)
        if any(ahead[1:]):
            offset = int(np.abs(ahead[1:]).max())
            used[offset] = used.get(offset, 0) + 1
            r, centre = _HALF_WIDTH[:, ahead[0]].astype(np.int64), idx + np.array(ahead[1:])
            assert np.all(np.abs(centre - idx) <= r)  # the box holds the particle's voxel ...
            lo, hi = centre - r, centre + r + 1
            assert np.all(lo >= 0) and np.all(hi <= n)
            assert codes[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]].all()  # ... and is all pore
        _assert_flight_as_reference(codes, h, pos, idx, u)
    assert sorted(used) == sorted(_AHEAD)  # every offset is taken ...
    assert sum(used.values()) < 1200  # ... and all are refused too


@pytest.mark.parametrize("h", [(1.0, 1.0, 1.0), (0.6, 1.0, 1.7)])
def test_flights_through_slabs_and_prisms_match_reference(h):
    """Flights in a channel with flat walls and a few obstacles, where the codes next to the walls are slabs (thin
    across the wall) and those along the free runs prisms (long along one axis): every start voxel and direction, on
    the sort-all-crossings reference; slab, prism, edge and cube voxels are all among the start voxels."""
    rng = np.random.default_rng(23)
    pore = np.ones((30, 26, 90), np.uint8)
    for _ in range(5):
        a, b, c = rng.integers(0, 30), rng.integers(0, 26), rng.integers(0, 90)
        pore[a, b : b + 3, c : c + 2] = 0
    pore[8:20, 4:7, 60] = 0
    codes = _codes(pore)
    h = np.array(h)
    cells = np.argwhere(codes > 0)
    kinds = set()
    for _ in range(1500):
        idx = cells[rng.integers(len(cells))].astype(np.int64)
        c = codes[tuple(idx)]
        kinds.add(_kind(c))
        pos = (idx + rng.random(3)) * h
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        _assert_flight_as_reference(codes, h, pos, idx, u)
    assert kinds == {"cube", "slab", "prism", "edge"}


def _kind(code):
    if code >= _PRISM_CODE:
        return "prism"
    if code >= _SLAB_CODE:
        return "slab"
    return "edge" if code >= _EDGE_CODE else "cube"


@pytest.mark.parametrize("h", [(1.0, 1.0, 1.0), (0.6, 1.0, 1.7)])
def test_flights_from_edge_boxes_match_reference(h):
    """Flights that start in the edge boxes of a square channel (thin across both walls of an edge, long along it),
    with a pillar that cuts some short, in every direction: on the sort-all-crossings reference."""
    rng = np.random.default_rng(5)
    pore = np.ones((16, 14, 40), np.uint8)
    pore[0:3, 4:6, 20] = 0
    codes = _codes(pore)
    h = np.array(h)
    cells = np.argwhere((codes >= _EDGE_CODE) & (codes < _SLAB_CODE))
    assert len(cells) > 0
    for _ in range(800):
        idx = cells[rng.integers(len(cells))].astype(np.int64)
        pos = (idx + rng.random(3)) * h
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        _assert_flight_as_reference(codes, h, pos, idx, u)


def _advance_all(times, steps):
    out = np.empty_like(times)
    for k in range(times.shape[0]):
        t0, t1, t2 = _advance(times[k, 0], times[k, 1], times[k, 2], steps[k, 0], steps[k, 1], steps[k, 2])
        out[k, 0], out[k, 1], out[k, 2] = t0, t1, t2
    return out


@pytest.mark.parametrize("x86", [True, False], ids=["sse2-masks", "generic"])
def test_a_walk_step_advances_exactly_the_earliest_axis_lowest_first_on_ties(x86, monkeypatch):
    """The walk's branch-free step (bit masks from the compares) against the rule written out: the earliest of the
    three crossing times advances by its own step, a tie goes to the lowest axis, the others keep their bits.
    Ties, equal pairs, an axis that never crosses (_NEVER) and zeros are drawn on purpose; both code paths (SSE2's
    compare on x86, the generic compare elsewhere), compiled afresh for each."""
    if x86 and not K._X86:
        pytest.skip("SSE2 masks: x86-64 only")
    monkeypatch.setattr(K, "_X86", x86)
    rng = np.random.default_rng(3)
    pool = np.array([0.0, 0.5, 1.0, 1.0 + 2.0**-52, 2.5, _NEVER])
    times = np.concatenate([rng.choice(pool, (4000, 3)), rng.random((4000, 3)) * 10.0])
    steps = np.concatenate([rng.choice([0.25, 1.0, _NEVER], (4000, 3)), rng.random((4000, 3))])
    got = njit(_advance_all)(times, steps)
    want = times.copy()
    for k in range(times.shape[0]):
        axis = int(np.argmin(times[k]))  # argmin: the first of equal minima
        want[k, axis] = times[k, axis] + steps[k, axis]
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
