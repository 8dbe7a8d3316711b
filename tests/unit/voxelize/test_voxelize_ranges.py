"""A voxel row's ranges of the shell method: every voxel with a sample inside the ball lies in [lo, hi), and every
voxel of the run [f_lo, f_hi) has all 216 samples inside (checked against the float64 test of every sample).
"""

import numpy as np

from porepipe._shared.sample_points import hull_gap
from porepipe.voxelize._kernels import _ranges_frame, _row_ranges


def _samples_inside(cx, cy, cz, r, i, j, k, h):
    """Samples of voxel (i, j, k) inside the ball by the brute force's float64 test (0..216)."""
    p = (6 * np.array([i, j, k])[:, None] + np.arange(6) + 0.5) * h
    dx2, dy2, dz2 = ((p[0] - cx) ** 2, (p[1] - cy) ** 2, (p[2] - cz) ** 2)
    return int(((dx2[:, None, None] + dy2[None, :, None] + dz2[None, None, :]) <= r * r).sum())


def test_ranges_hold_every_voxel_with_samples_inside_and_only_full_voxels_in_the_run():
    # fails if an end of either range is one voxel off (the counts of a missing shell voxel stay 0, a voxel in the
    # run is written 216): rows cut the ball at every depth, centres anywhere within a voxel, tangents included
    rng = np.random.default_rng(21)
    h = 1.0 / 6
    checked_lo = checked_run = 0
    for _ in range(300):
        r = rng.uniform(0.2, 6.0)
        cx, cy, cz = rng.uniform(10.0, 12.0, 3)
        if rng.random() < 0.2:  # a centre on a sample plane, a radius reaching a sample exactly
            cz = (6 * 11 + 2 + 0.5) * h
            r = 5 * h * rng.integers(1, 20) / 5
        i = int(rng.integers(int((cx - r) / (6 * h)) - 1, int((cx + r) / (6 * h)) + 2))
        j = int(rng.integers(int((cy - r) / (6 * h)) - 1, int((cy + r) / (6 * h)) + 2))
        nx, fx = hull_gap(cx, i, h)
        ny, fy = hull_gap(cy, j, h)
        k0, k1 = 0, 200
        lo, hi, f_lo, f_hi = _row_ranges(
            _ranges_frame(cz, r, h), r * r, nx * nx + ny * ny, fx * fx + fy * fy, k0, k1
        )
        assert k0 <= lo <= f_lo <= f_hi <= hi <= k1 and (f_lo < f_hi or f_lo == f_hi == lo)
        counts = {
            k: _samples_inside(cx, cy, cz, r, i, j, k, h)
            for k in range(int(cz / (6 * h)) - 8, int(cz / (6 * h)) + 9)
        }
        for k, n in counts.items():
            if n:
                assert lo <= k < hi, (k, n, lo, hi)
            if f_lo <= k < f_hi:
                assert n == 216, (k, n, f_lo, f_hi)
        checked_lo += lo < hi and counts[lo] > 0 and counts[hi - 1] > 0
        checked_run += f_lo < f_hi and (counts[f_lo - 1] < 216 or counts[f_hi] < 216)
    assert checked_lo > 100 and checked_run > 30  # ranges tight at both ends, runs next to partial voxels


def test_hull_gap_equals_the_case_split():
    # branch-free near distance: bit for bit the value of "p0 - c if c < p0, c - p1 if c > p1, else 0", centres on
    # and next to the hull's ends included
    h = 1.0 / 6
    rng = np.random.default_rng(22)
    for voxel in (0, 3, 17):
        p0, p1 = (6 * voxel + 0.5) * h, (6 * voxel + 5.5) * h
        centres = np.concatenate(
            [rng.uniform(p0 - 2.0, p1 + 2.0, 200), [p0, p1], np.nextafter([p0, p0, p1, p1], [-1, 99, -1, 99])]
        )
        for c in centres:
            near, far = hull_gap(c, voxel, h)
            expected = p0 - c if c < p0 else (c - p1 if c > p1 else 0.0)
            assert near == expected and np.signbit(near) == np.signbit(expected)
            assert far == max(abs(c - p0), abs(c - p1))
