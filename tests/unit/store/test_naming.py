"""The resolution tag in file names round-trips every float exactly (``f"{a:g}"`` does not)."""

import re

import numpy as np
import pytest

from porepipe._shared.naming import TAG_RE, res_tag


@pytest.mark.parametrize(
    ("a", "tag"),
    [
        (2.0, "2"),
        (0.5, "0.5"),
        (1, "1"),
        (0.1234567, "0.1234567"),
        (1e-5, "0.00001"),
        (300.0, "300"),
        (0.1 + 0.2, "0.30000000000000004"),
    ],
)
def test_known_tags(a, tag):
    assert res_tag(a) == tag


def test_g_format_would_lose_digits():
    assert f"{0.1234567:g}" == "0.123457" and float(res_tag(0.1234567)) == 0.1234567


def test_every_float_round_trips_and_matches_the_wildcard():
    """20 000 floats over 12 decades (log-uniform) and the dyadic neighbours of 1: float(tag) == a bit for bit."""
    rng = np.random.default_rng(13)
    values = np.concatenate([10.0 ** rng.uniform(-6, 6, 20_000), np.nextafter(1.0, [0.0, 2.0])])
    for a in values:
        tag = res_tag(a)
        assert float(tag) == a, (a, tag)
        assert re.fullmatch(TAG_RE, tag), tag


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_non_positive_or_non_finite_is_refused(bad):
    with pytest.raises(ValueError, match="positive finite"):
        res_tag(bad)
