"""The CI stepped, hopper and parabolic silos (config/scenes/granular-silo-{stepped,hopper,parabolic}-ci.yaml) end to
end: run, resolve every wall contact along its face, fit the shape's theory.

Truths:
- static equilibrium, exact: the vertical forces of all walls (side walls, ledges, floor) add up to the weight and
  their horizontal forces to zero. The residual is sum m a of the grains, i.e. what still moves at the end; measured
  3e-5 (stepped), 6e-4 (hopper), see the scenes. Tolerance 2e-3 of the weight, about 3x the largest residual seen.
- the thesis's k and fitted mu_j for the shape (Schinner 2001 §3.3-3.5, digest §2.3): k within the thesis's spread
  over test areas (the parabola misses it: strict xfail), mu_j within 30 % (one small realisation; the spread of
  mu_j between fill protocols in granular-silo-ci was ~10 %).
- k against depth (measured here, not in the thesis, which found the local k independent of position in its stepped
  silo): k is highest in the upper third of the fill in every shape. Upper / middle / lower third: stepped 0.80 /
  0.46 / 0.61, hopper 0.79 / 0.59 / 0.41, parabola 0.95 / 0.72 / 0.49 (the straight granular-silo-ci 0.82 / 0.57 /
  0.61; a hopper twice as wide, 22-29 grains across, 0.94 / 0.63 / 0.48: not a width effect). Required: the upper
  third above both others by more than 0.1 (the smallest margin seen is 0.19, stepped).
- the thesis's k over the region it trusted: it cut its hopper where fewer than 10 grains fit across and called the
  stresses unreliable below ~25 across. Our -ci hoppers are 6-14 grains across; over the slabs at least 10 across
  (the upper half) k = 0.73 ± 0.13 (hopper; thesis 0.77 ± 0.24) and 0.88 ± 0.18 (parabola; 0.86 ± 0.14), within
  the thesis's spread. Those slabs are also the upper ones, where k is high in every shape: this matches the
  thesis's numbers under its criterion, it does not show that width sets k.
- the theory with the fitted mu_j describes the wall pressure: rms residual below 25 % of its largest value (one
  realisation of ~450 grains, windows of ~15 contacts; the scatter of single windows is ~15 %).
Slow: each scene is ~200 000 steps of ~450 grains (35 s of CPU here).
"""

from pathlib import Path

import numpy as np
import pytest

from porepipe.granular import THESIS_MIN_WIDTH_GRAINS, THESIS_SHAPES, analyse_silo, read_granular, run
from porepipe.scene import load_scene

SCENES = Path(__file__).parents[3] / "config" / "scenes"

pytestmark = pytest.mark.slow


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


def test_k_against_the_thesis(shaped, request):
    """Stepped 0.63 ± 0.17 (thesis 0.64 ± 0.19), hopper 0.59 ± 0.18 (0.77 ± 0.24); the parabola's 0.69 ± 0.23 is
    0.17 below the thesis's 0.86 ± 0.14, outside its spread: a strict xfail until explained (the thesis's k rises
    from straight to hopper to parabola; ours does not)."""
    name, a, mu = shaped[:3]
    th = THESIS_SHAPES[(name, mu)]
    if name == "parabolic":
        request.applymarker(
            pytest.mark.xfail(strict=True, reason="k 0.69 ± 0.23 against the thesis's 0.86 ± 0.14")
        )
    assert abs(a["k"] - th["k"]) < th["k_err"]


def test_k_falls_with_depth(shaped):
    a = shaped[1]
    upper, middle, lower = a["k_thirds"]
    assert upper > max(middle, lower) + 0.1


def test_k_over_the_thesis_region_against_the_thesis(shaped):
    """Slabs at least THESIS_MIN_WIDTH_GRAINS (10) grains across; the stepped silo's narrow part (5 across) drops
    out there and its upper part (10.5 across) is compared: 0.63 ± 0.20 (thesis 0.64 ± 0.19)."""
    name, a, mu = shaped[:3]
    th = THESIS_SHAPES[(name, mu)]
    assert a["k_wide_slabs"] >= 3
    wide = a["slab_width_grains"] >= THESIS_MIN_WIDTH_GRAINS
    assert a["k_wide"] == pytest.approx(np.mean(a["k_local"][wide]), rel=1e-12)
    assert abs(a["k_wide"] - th["k"]) < th["k_err"]


def test_mu_j_against_the_thesis(shaped):
    name, a, mu = shaped[:3]
    th = THESIS_SHAPES[(name, mu)]
    assert a["fit"]["mu_j"] == pytest.approx(th["mu_j"], rel=0.3)
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
