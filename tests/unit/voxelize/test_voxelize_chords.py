"""The float32 row chords of the shell method hold exactly the samples that pass the float64 test, or say they may not."""

import numpy as np

from porepipe.voxelize._kernels import (
    CHORD_ROWS,
    N_ROWS,
    _chord_margin,
    _chord_prefix,
    _chord_union_count,
    _row_chords,
    _row_room,
)


def _chords(dxy, cz, r, h):
    """The kernel's chords of rows ``dxy`` (36) through the ball (cz, r): (lo, hi) int arrays, floor(e), ambiguous."""
    e = cz / h - 0.5
    e_int = int(np.floor(e))
    room = np.zeros(CHORD_ROWS, np.float32)
    ends = np.zeros((2, CHORD_ROWS), np.int32)
    margin = np.float32(_chord_margin(cz, r, h))
    _row_room(dxy, r * r, room)
    ambiguous, lo_sum, hi_sum = _row_chords(room, np.float32(e - e_int), np.float32(1.0 / h), margin, ends)
    assert (lo_sum, hi_sum) == (ends[0].sum(), ends[1].sum())  # the sums the shell ends take
    return ends[0, :N_ROWS].astype(int), ends[1, :N_ROWS].astype(int), e_int, ambiguous


def _inside(dxy, cz, r, h, m):
    """The float64 test of the brute force for samples ``m`` (z index) of every row: (36, len(m)) bool."""
    dz = (m + 0.5) * h - cz
    return dxy[:, None] + dz * dz <= r * r


def test_unambiguous_chords_equal_the_exact_test():
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(400):
        h = rng.choice([1.0 / 6, 0.25 / 6, 1.0 / 24])
        r = rng.uniform(0.3, 12.0)
        cz = rng.uniform(0.0, 300.0)
        dxy = rng.uniform(0.0, 1.2, N_ROWS) * r * r  # some rows miss the ball
        lo, hi, e_int, ambiguous = _chords(dxy, cz, r, h)
        if ambiguous:
            continue
        checked += 1
        m = np.arange(int((cz - r) / h) - 3, int((cz + r) / h) + 4)
        inside = _inside(dxy, cz, r, h, m)
        rel = m - e_int
        np.testing.assert_array_equal((rel[None, :] >= lo[:, None]) & (rel[None, :] < hi[:, None]), inside)
        for k in range(m[0] // 6 + 1, m[-1] // 6):  # whole voxels inside the tested range
            sel = (m >= 6 * k) & (m < 6 * k + 6)
            ends = np.zeros((2, CHORD_ROWS), np.int32)
            ends[0, :N_ROWS], ends[1, :N_ROWS] = lo, hi
            base = 6 * k - e_int
            count = _chord_prefix(ends, np.int32(base + 6)) - _chord_prefix(ends, np.int32(base))
            assert count == inside[:, sel].sum()
    assert checked > 300  # the float32 path is the common one


def test_chord_end_exactly_on_a_sample_is_ambiguous():
    # h = 1/8: the centre on a sample, r = 15 h and a row at (2 h, 5 h) from it put a sample exactly on the surface
    # (2² + 5² + 14² = 15²), where float32 cannot tell inside from outside: the kernel must fall back to the tests
    h = 0.125
    cz = (40 + 0.5) * h
    r = 15 * h
    dxy = np.full(N_ROWS, 2.0 * r * r)  # other rows miss the ball
    dxy[7] = (2 * h) ** 2 + (5 * h) ** 2
    assert _inside(dxy[7:8], cz, r, h, np.array([40 + 14]))[0, 0]
    assert _chords(dxy, cz, r, h)[3]
    dxy[7] = (2 * h) ** 2 + (5.5 * h) ** 2  # no sample on the surface: the float32 chord is exact
    lo, hi, e_int, ambiguous = _chords(dxy, cz, r, h)
    assert not ambiguous and (lo[8:] == hi[8:]).all()
    m = np.arange(20, 61)
    np.testing.assert_array_equal(
        _inside(dxy[7:8], cz, r, h, m)[0], (m - e_int >= lo[7]) & (m - e_int < hi[7])
    )


def test_union_of_two_balls_from_their_chords_equals_the_exact_tests():
    # the pair path of the shell method: a voxel's samples inside ball a or ball b from the two balls' exact chords
    # (each in its own frame floor(e)), as the owner's count plus b's samples outside a; fails if a chord end or a
    # frame shift is off by one sample
    rng = np.random.default_rng(12)
    h = 1.0 / 6
    checked = 0
    for _ in range(300):
        ra, rb = rng.uniform(0.5, 3.0, 2)
        cza = rng.uniform(5.0, 15.0)
        czb = cza + rng.uniform(-1.2, 1.2) * (ra + rb)
        dxy_a = rng.uniform(0.0, 1.1, N_ROWS) * ra * ra
        dxy_b = rng.uniform(0.0, 1.1, N_ROWS) * rb * rb
        lo_a, hi_a, e_a, amb_a = _chords(dxy_a, cza, ra, h)
        lo_b, hi_b, e_b, amb_b = _chords(dxy_b, czb, rb, h)
        if amb_a or amb_b:
            continue
        ends_a = np.zeros((2, CHORD_ROWS), np.int32)
        ends_b = np.zeros((2, CHORD_ROWS), np.int32)
        ends_a[0, :N_ROWS], ends_a[1, :N_ROWS] = lo_a, hi_a
        ends_b[0, :N_ROWS], ends_b[1, :N_ROWS] = lo_b, hi_b
        for k in range(
            int(min(cza - ra, czb - rb) / (6 * h)) - 1, int(max(cza + ra, czb + rb) / (6 * h)) + 2
        ):
            m = np.arange(6 * k, 6 * k + 6)
            in_a = _inside(dxy_a, cza, ra, h, m)
            union = in_a | _inside(dxy_b, czb, rb, h, m)
            count = _chord_union_count(
                int(in_a.sum()), ends_a, np.int32(6 * k - e_a), ends_b, np.int32(6 * k - e_b)
            )
            assert count == union.sum()
            checked += int(0 < union.sum() < in_a.sum() + _inside(dxy_b, czb, rb, h, m).sum())
    assert checked > 100  # voxels where the two balls share samples
