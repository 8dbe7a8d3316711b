"""Initial radius distributions (§5.1), placement by density and region, ramps (5.4.1)."""

import numpy as np
import pytest
from scipy import stats

from porepipe.packing import Settings, sample_radii, schedule_value
from porepipe.packing._settings import RadiusSpec, Ramp
from porepipe.packing._setup import place_type


def _trunc_exp_cdf(alpha, lo, hi):
    def cdf(r):
        r = np.clip(r, lo, hi)
        return (np.exp(-alpha * lo) - np.exp(-alpha * r)) / (np.exp(-alpha * lo) - np.exp(-alpha * hi))

    return cdf


@pytest.mark.parametrize("alpha,lo,hi", [(0.2, 10.0, 100.0), (0.05, 10.0, 100.0), (3.0, 0.9, 1.2)])
def test_exponential_radii_follow_truncated_exponential(alpha, lo, hi):
    r = sample_radii(
        RadiusSpec(dist="exponential", min_um=lo, max_um=hi, alpha_per_um=alpha),
        20000,
        np.random.default_rng(1),
    )
    assert r.min() >= lo and r.max() <= hi
    # KS at the 0.1 % level: a correct sampler fails one seed in a thousand
    assert stats.kstest(r, _trunc_exp_cdf(alpha, lo, hi)).pvalue > 1e-3


def test_uniform_and_alpha_zero_radii():
    for spec in (
        RadiusSpec(dist="uniform", min_um=2, max_um=5),
        RadiusSpec(dist="exponential", min_um=2, max_um=5, alpha_per_um=0.0),
    ):
        r = sample_radii(spec, 20000, np.random.default_rng(2))
        assert stats.kstest(r, stats.uniform(2, 3).cdf).pvalue > 1e-3


def test_discrete_radii_inline_and_file(tmp_path):
    values, probs = [1.0, 2.0, 4.0], [0.5, 0.3, 0.2]
    path = tmp_path / "radii_prob.txt"
    path.write_text("".join(f"{v} {p}\n" for v, p in zip(values, probs)))
    for spec in (
        RadiusSpec(dist="discrete", values_um=values, probabilities=probs),
        RadiusSpec(dist="discrete", file=path),
    ):
        r = sample_radii(spec, 40000, np.random.default_rng(3))
        counts = np.array([(r == v).sum() for v in values])
        assert counts.sum() == r.size
        # chi-square goodness of fit at the 0.1 % level
        assert stats.chisquare(counts, np.array(probs) * r.size).pvalue > 1e-3


def test_initial_radius_overrides_distribution():
    r = sample_radii(
        RadiusSpec(dist="uniform", min_um=0.9, max_um=1.2, initial_um=1.2), 10, np.random.default_rng(0)
    )
    np.testing.assert_array_equal(r, 1.2)


def test_ramp_equals_recursive_definition():
    # 5.4.1: k^s = k^0 (s < S0), k^{s-1} + dk (S0 <= s < S1), k^1 (s >= S1)
    ramp = Ramp(start=1200.0, end=1.0, from_step=20, to_step=25)
    dk = (ramp.end - ramp.start) / (ramp.to_step - ramp.from_step)
    k = ramp.start
    for s in range(40):
        if s < ramp.from_step:
            k = ramp.start
        elif s < ramp.to_step:
            k = k + dk
        else:
            k = ramp.end
        # closed form vs recursion: they differ by the recursion's accumulated round-off only
        assert schedule_value(ramp, s, 0.0) == pytest.approx(k, rel=1e-12, abs=1e-9)
    assert schedule_value(None, 3, 1.5) == 1.5 and schedule_value(7.0, 3, 1.5) == 7.0


def test_density_and_regions_place_spheres_in_their_cubes():
    settings = Settings.model_validate(
        {
            "types": [
                {"name": "a", "number_density_per_um3": 0.01, "radius_um": {"min_um": 1, "max_um": 1}},
                {"name": "b", "count": 500, "radius_um": {"min_um": 1, "max_um": 2}},
            ],
            "regions": {"cube_um": 10, "types": ["a", "b", "b", "a", "a", "b", "b", "a"]},
        }
    )
    box = np.array([20.0, 20.0, 20.0])
    xa, _ = place_type(0, settings.types[0], settings, box, np.random.default_rng(0))
    xb, rb = place_type(1, settings.types[1], settings, box, np.random.default_rng(1))
    assert xa.shape == (40, 3)  # rho * V(regions of a) = 0.01 * 4 * 1000
    assert xb.shape == (500, 3) and rb.shape == (500,)
    table = np.array(settings.regions.types)
    for x, name in ((xa, "a"), (xb, "b")):
        q = np.floor(x / 10).astype(int)
        assert np.all(table[q[:, 0] + 2 * q[:, 1] + 4 * q[:, 2]] == name)
