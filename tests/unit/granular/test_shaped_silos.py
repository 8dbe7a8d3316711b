"""The CI stepped, hopper and parabolic silos (config/scenes/granular-silo-{stepped,hopper,parabolic}-ci.yaml) end to
end: run, resolve every wall contact along its face, fit the shape's theory.

Truths:
- static equilibrium, exact: the vertical forces of all walls (side walls, ledges, floor) add up to the weight and
  their horizontal forces to zero. The residual is sum m a of the grains, i.e. what still moves at the end; measured
  3e-5 (stepped), 6e-4 (hopper), see the scenes. Tolerance 2e-3 of the weight, about 3x the largest residual seen.
- one realisation is one sample: the run's k, k over the wide slabs and mu_j move from seed to seed (and with the
  round-off of the narrow phase, which changes the realisation of a dense pile). Measured here over 22 runs (each
  shape's CI seed 31/32/33 and seeds 41-43 with the facing-chain narrow phase; the CI seed, 41 and 42, and 43 for
  the hopper, with the whole-polygon clipping), the seed-to-seed standard deviations pooled over the three shapes
  (deviations from each shape's mean) are SEED_SD: k 0.05, k_wide 0.05, mu_j 0.04. Each comparison with the
  thesis allows the thesis's spread (k) or 30 % (mu_j) plus two seed SDs: a realisation of the same physics
  passes with ~95 % probability (all 22 did), a shift of the mean by more than that fails.
- the thesis's k and fitted mu_j for the shape (Schinner 2001 §3.3-3.5, digest §2.3). Seed means of k: stepped
  0.69 ± 0.03 (thesis 0.64 ± 0.19), hopper 0.68 ± 0.07 (0.77 ± 0.24), parabola 0.72 ± 0.05 (0.86 ± 0.14: at the
  lower edge of its spread; the thesis's k rises from straight to hopper to parabola, ours does not). mu_j:
  stepped 0.27 ± 0.05 (thesis 0.33), hopper and parabola 0.20 ± 0.04 each (thesis 0.30: a third low; the single
  CI runs these tests were first calibrated on, 0.28 and 0.24, were among the highest seeds).
- k against depth (measured here, not in the thesis, which found the local k independent of position in its stepped
  silo): k is highest in the upper third of the fill on average. Per run, the upper third exceeds the larger of the
  other two by -0.002 to 0.38 (it is not above both in every run) and their mean by 0.02 to 0.51. Required: the
  upper third above the mean of the other two (smallest margin seen 0.02, pooled seed SD of the margin 0.12).
- the thesis's k over the region it trusted: it cut its hopper where fewer than 10 grains fit across and called the
  stresses unreliable below ~25 across. Our -ci hoppers are 6-14 grains across; over the slabs at least 10 across
  (the upper half) the seed means are 0.75 ± 0.06 (hopper; thesis 0.77 ± 0.24) and 0.84 ± 0.05 (parabola;
  0.86 ± 0.14), within the thesis's spread. Those slabs are also the upper ones, where k is high in every shape:
  this matches the thesis's numbers under its criterion, it does not show that width sets k.
- the theory with the fitted mu_j describes the wall pressure: rms residual below 25 % of its largest value (one
  realisation of ~450 grains, windows of ~15 contacts; the scatter of single windows is ~15 %; largest seen over
  the seeds 19 %).
Slow: each scene is ~200 000 steps of ~450 grains (35 s of CPU here).
"""

from pathlib import Path

import numpy as np
import pytest

from porepipe.granular import THESIS_MIN_WIDTH_GRAINS, THESIS_SHAPES, analyse_silo, read_granular, run
from porepipe.scene import load_scene

SCENES = Path(__file__).parents[3] / "config" / "scenes"

pytestmark = pytest.mark.slow

#: seed-to-seed standard deviation of one run's statistics, pooled over the three shapes and 22 runs (see the
#: module docstring)
SEED_SD = {"k": 0.052, "k_wide": 0.052, "mu_j": 0.044}


def _allowed(thesis_tolerance, key):
    """The thesis's tolerance plus two seed-to-seed standard deviations of the statistic ``key``."""
    return thesis_tolerance + 2.0 * SEED_SD[key]


@pytest.fixture(scope="module", params=["stepped", "hopper", "parabolic"])
def shaped(request, tmp_path_factory):
    scene = load_scene(SCENES / f"granular-silo-{request.param}-ci.yaml")
    out = run(
        scene.granular,
        tmp_path_factory.mktemp(request.param) / "granular.h5",
        seed=scene.seed,
        progress=False,
    )
    mu = scene.granular.material.friction
    a = analyse_silo(read_granular(out), shape=scene.granular.silo, mu=mu)
    return request.param, a, mu, out, scene


def test_walls_and_floor_carry_the_weight_exactly(shaped):
    name, a = shaped[:2]
    assert abs(a["force_balance"]) < 2e-3
    assert abs(a["horizontal_balance"]) < 2e-3
    assert a["floor_share"] + a["wall_share"] == pytest.approx(1.0, abs=2e-3)
    segments = sum(s["fy_N_m"] for s in a["segments"])
    assert segments == pytest.approx(a["wall_share"] * a["weight_N_m"], rel=1e-9)  # per-segment sums add up
    if name == "stepped":
        assert a["ledge_share"] > 0.2  # the step carries the column above its ledge (Eq. 3.15's restart)
    else:
        assert a["ledge_share"] == 0.0


def test_k_against_the_thesis(shaped):
    name, a, mu = shaped[:3]
    th = THESIS_SHAPES[(name, mu)]
    assert abs(a["k"] - th["k"]) < _allowed(th["k_err"], "k")


def test_k_is_highest_in_the_upper_third(shaped):
    a = shaped[1]
    upper, middle, lower = a["k_thirds"]
    assert upper > 0.5 * (middle + lower)


def test_k_over_the_thesis_region_against_the_thesis(shaped):
    """Slabs at least THESIS_MIN_WIDTH_GRAINS (10) grains across; the stepped silo's narrow part (5 across) drops
    out there and its upper part (10.5 across) is compared: 0.63 ± 0.20 (thesis 0.64 ± 0.19)."""
    name, a, mu = shaped[:3]
    th = THESIS_SHAPES[(name, mu)]
    assert a["k_wide_slabs"] >= 3
    wide = a["slab_width_grains"] >= THESIS_MIN_WIDTH_GRAINS
    assert a["k_wide"] == pytest.approx(np.mean(a["k_local"][wide]), rel=1e-12)
    assert abs(a["k_wide"] - th["k"]) < _allowed(th["k_err"], "k_wide")


def test_mu_j_against_the_thesis(shaped):
    name, a, mu = shaped[:3]
    th = THESIS_SHAPES[(name, mu)]
    assert abs(a["fit"]["mu_j"] - th["mu_j"]) < _allowed(0.3 * th["mu_j"], "mu_j")
    assert a["fit"]["rms"] < 0.25 * np.nanmax(a["wall_pressure"])


def test_the_walls_take_over_with_depth(shaped):
    """Janssen's mechanism in every shape: the wall pressure grows much slower than hydrostatically at depth."""
    a = shaped[1]
    z, p = a["depth_m"], a["wall_running_mean"]
    top = z < 0.25 * a["fill_height_m"]
    lower = z > 0.6 * a["fill_height_m"]
    slope_top = np.polyfit(z[top], p[top], 1)[0]
    slope_lower = np.polyfit(z[lower], p[lower], 1)[0]
    assert slope_top > 0
    assert slope_lower < 0.5 * slope_top
    assert 0.6 < a["rho_rel"] < 0.91  # between random loose packing and hexagonal disks pi/sqrt(12)


def test_report_page_of_a_shaped_silo(shaped, tmp_path):
    """The report section names the shape, sets the thesis's section and numbers beside ours, draws the profile."""
    from porepipe.report._granular import granular_report

    name, a, mu, out, scene = shaped
    page = granular_report(out, tmp_path / "index.html", mu=mu, silo=scene.granular.silo).read_text()
    th = THESIS_SHAPES[(name, mu)]
    assert f"{name.capitalize()} silo" in page and f"thesis {th['section']}" in page
    assert f"{a['k']:.2f} ± {a['k_std']:.2f}" in page and f"{th['k']} ± {th['k_err']}" in page
    assert f"{a['k_wide']:.2f} ± {a['k_wide_std']:.2f}" in page and "upper / middle / lower third" in page
    assert (tmp_path / "granular_wall_pressure.png").stat().st_size > 1000
