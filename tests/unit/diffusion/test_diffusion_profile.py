"""The axial profile of a flight (:func:`porepipe.diffusion._kernels._profile_add`): against the exact overlap of the
flight with each bin, and bit for bit against the bin-by-bin rule written out."""

import numpy as np
import pytest

from porepipe.diffusion._kernels import _PROFILE_UNROLLED, _profile_add


def _bin_by_bin(prof, p_start, u_ax, length, speed, bin_w):
    """The rule written out in plain Python floats: the flight's axial segment cut at the bin edges, from the bin
    holding its lower end (clamped to the bins) up to its higher end or the last bin; each piece's length times the
    time per length goes to its bin, pieces of no length are skipped."""
    nb = prof.shape[0]
    if length <= 0.0:
        return
    p_end = p_start + u_ax * length
    lo, hi = min(p_start, p_end), max(p_start, p_end)
    first = min(max(int(lo / bin_w), 0), nb - 1)
    if hi - lo <= 1e-300:
        prof[first] += length / speed
        return
    per_len = length / speed / (hi - lo)
    pieces = []  # (bin, lower end, upper end)
    lower = lo
    for k in range(first, nb):
        upper = (k + 1) * bin_w
        pieces.append((k, lower, min(hi, upper)))
        if hi <= upper:
            break
        lower = upper
    for k, a, z in pieces:
        if z > a:
            prof[k] += (z - a) * per_len


def _flights(n, seed):
    """Random flights over random bin layouts: starts inside, on bin edges and beyond either end, spans from zero
    to many bins, axial components of zero included."""
    rng = np.random.default_rng(seed)
    for trial in range(n):
        nb = int(rng.integers(1, 40))
        bin_w = float(rng.uniform(0.1, 3.0))
        span = nb * bin_w
        start = (
            float(rng.uniform(0, span)),
            float(rng.integers(0, nb + 1) * bin_w),
            float(rng.uniform(-0.1 * span, 1.1 * span)),
            span,
        )[trial % 4]
        u_ax = float(rng.uniform(-1, 1)) if trial % 7 else 0.0
        length = float(rng.exponential(span / 3)) if trial % 11 else 0.0
        prof = rng.uniform(0, 1, nb) if trial % 3 else np.zeros(nb)
        yield prof, start, u_ax, length, float(rng.uniform(0.5, 2.0)), bin_w


def test_profile_is_bit_for_bit_the_bin_by_bin_rule():
    """Every bin equal to the last bit (int64 views) over 20 000 random flights; a flight that spans more bins than
    are unrolled also runs the loop."""
    long_spans = 0
    for prof, *flight in _flights(20_000, seed=5):
        expected, got = prof.copy(), prof.copy()
        _bin_by_bin(expected, *flight)
        _profile_add(got, *flight)
        np.testing.assert_array_equal(got.view(np.int64), expected.view(np.int64))
        p_start, u_ax, length, _, bin_w = flight
        long_spans += abs(u_ax) * length > (_PROFILE_UNROLLED + 1) * bin_w
    assert long_spans > 1000


@pytest.mark.parametrize("u_ax", [0.37, -0.61])
def test_profile_adds_the_exact_time_in_each_bin(u_ax):
    """Independent truth: a flight inside the profile's span (as every flight of a transmission run is) at speed v
    spends |overlap with the bin| / (|u_ax| v) in it; the times sum to length / v. Tolerance 1e-12 relative: a few
    roundings of the bin edges and of one product each."""
    nb, bin_w, speed = 12, 0.75, 1.3
    edges = np.arange(nb + 1) * bin_w
    rng = np.random.default_rng(11)
    for _ in range(500):
        p_start, p_end = (float(x) for x in rng.uniform(0, nb * bin_w, 2))
        length = abs(p_end - p_start) / abs(u_ax)
        if (p_end - p_start) * u_ax < 0:  # the flight runs from p_start along u_ax
            p_start = p_end
        prof = np.zeros(nb)
        _profile_add(prof, p_start, u_ax, length, speed, bin_w)
        lo, hi = sorted((p_start, p_start + u_ax * length))
        overlap = np.clip(np.minimum(hi, edges[1:]) - np.maximum(lo, edges[:-1]), 0.0, None)
        exact = overlap / (abs(u_ax) * speed)
        np.testing.assert_allclose(prof, exact, rtol=1e-12, atol=1e-12 * length / speed)
        assert prof.sum() == pytest.approx(length / speed, rel=1e-12)
