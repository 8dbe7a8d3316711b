"""Adsorption, surface hops, Langmuir-Hinshelwood and Eley-Rideal on the voxel walls (Mahler 2001 §4.3-4.4, which
designed but never ran them) against analytic truths in a closed 8³ box with Lambert walls (uniform wall flux):

- competitive Langmuir isotherm θ_X = K_X n_X/(1 + Σ K n), K = a·v̄·A_site·τ/4, for exponential and fixed
  residence times (renewal: only the mean matters) and with surface hops (an exclusion process keeps it);
- first-order desorption N(t) = N₀·exp(−t/τ) (exponential law) and a step at τ (fixed law);
- Eley-Rideal A(g) + B(ads): the exact second-order law −dN_B/dt = k N_A N_B, k = w·v̄_A·A_site/(4V), and the
  thesis's (4.16) w_ER = a·θ_B·w per A hit in a replenished steady state;
- Langmuir-Hinshelwood: reactions per arrival 1 − (1 − wθ)^z under independent site occupations (exact as w → 0);
- conservation of A and B atoms (A + B → P) and zero-probability mechanisms costing nothing.

Each run takes well under a second once the kernel is compiled (one kernel for every option).
"""

import math

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.diffusion._geometry import closed_box
from porepipe.diffusion._surface import (
    Adsorbate,
    Mechanism,
    langmuir_constant,
    langmuir_coverage,
    lh_reaction_probability,
    second_order_remaining,
    surface_run,
)

BOX = closed_box((8, 8, 8)).pore  # V = 512, S = 384 faces, 1536 sites at s = 2


def _langmuir_prediction(run, species):
    k = [langmuir_constant(sp.adsorption, sp.vmean, run["site_area"], sp.residence) for sp in species]
    return langmuir_coverage(k, run["gas_density"])


@pytest.mark.parametrize("law, hop", [("exponential", 0.0), ("fixed", 0.0), ("exponential", 0.5)])
def test_coverage_follows_the_competitive_langmuir_isotherm(law, hop):
    """Tolerance 4 standard errors of the 16 block means plus 0.3 % relative: the isotherm is evaluated at the
    mean gas density, and the gas count fluctuates by ~1/√1500, a bias of order 1e-3·θ."""
    species = [
        Adsorbate("A", 1.0, gas=1500, adsorption=0.5, residence=10.0, hop_rate=hop),
        Adsorbate("B", 0.7, gas=1500, adsorption=0.3, residence=20.0),
    ]
    run = surface_run(BOX, species, t_end=2200, t_warm=200, residence_law=law, seed=3)
    theta = run["coverage"]
    assert theta.min() > 0.2 and theta.sum() < 0.8  # a regime where both species matter
    pred = _langmuir_prediction(run, species)
    np.testing.assert_array_less(np.abs(theta - pred), 4 * run["coverage_err"] + 3e-3 * pred)
    if hop:
        assert run["hops"][0] > 0.2 * run["hop_tries"][0]


def test_desorption_is_first_order_or_a_step():
    """No readsorption (a = 0): N(t)/N₀ = exp(−t/τ) within 4 binomial σ; with a fixed residence all leave at τ."""
    t = np.array([0.0, 5.0, 10.0, 20.0, 29.0, 31.0])
    run = surface_run(BOX, [Adsorbate("A", adsorbed=1200, residence=10.0)], t_end=40, t_samples=t, seed=4)
    n = run["series"][:, 0, 1]
    p = np.exp(-t / 10.0)
    assert np.all(np.abs(n - 1200 * p) <= 4 * np.sqrt(1200 * p * (1 - p)) + 1e-9)
    run = surface_run(
        BOX,
        [Adsorbate("A", adsorbed=300, residence=30.0)],
        t_end=40,
        t_samples=t,
        residence_law="fixed",
        seed=4,
    )
    np.testing.assert_array_equal(run["series"][:, 0, 1], [300, 300, 300, 300, 300, 0])
    np.testing.assert_array_equal(run["series"][:, 0, 0], [0, 0, 0, 0, 0, 300])


def test_eley_rideal_follows_the_exact_second_order_law_and_conserves_atoms():
    """B fixed on the surface (τ = ∞), A from the gas, w = 0.02: N_B(t) against the closed form; tolerance 4·√N_B
    (Poisson-like counting noise of the reactions so far) plus 1 %. Atoms: A and B each end up in A + P and B + P."""
    t = np.linspace(0.0, 300.0, 7)
    species = [Adsorbate("A", 1.0, gas=3000), Adsorbate("B", 0.8, adsorbed=1000), Adsorbate("P", 0.6)]
    run = surface_run(BOX, species, [Mechanism("ER", "A", "B", "P", 0.02)], t_end=300, t_samples=t, seed=5)
    k = 0.02 * 1.0 * run["site_area"] / (4.0 * run["pore_volume"])
    truth = second_order_remaining(3000, 1000, k, t)
    n_b = run["series"][:, 1, 1]
    assert truth[-1] < 0.2 * truth[0]  # the decay is well sampled
    assert np.all(np.abs(n_b - truth) <= 4 * np.sqrt(np.maximum(1000 - truth, 1)) + 0.01 * truth)
    a, b, p = run["final_counts"]
    assert (a + p, b + p, p) == (3000, 1000, run["er_reactions"])


def test_eley_rideal_probability_per_hit_is_a_theta_w():
    """Thesis (4.16): in a steady state (products counted, reactants replenished; B adsorbs from the gas and never
    desorbs, only half the sites active) the reactions per A hit are a·θ_B·w with θ_B the coverage of the active
    sites: tolerance 4 Poisson σ of the reaction count plus 1 % (θ_B is a time mean, the product is not)."""
    species = [
        Adsorbate("A", 1.0, gas=2000),
        Adsorbate("B", 0.8, gas=400, adsorption=0.2, residence=math.inf),
        Adsorbate("P", 0.6),
    ]
    run = surface_run(
        BOX,
        species,
        [Mechanism("ER", "A", "B", "P", 0.3)],
        active_fraction=0.5,
        replenish=True,
        t_end=1500,
        t_warm=300,
        seed=6,
    )
    a = run["active_sites"] / run["sites"]
    assert a == pytest.approx(0.5, abs=0.05)
    expect = run["wall_hits"][0] * a * run["coverage"][1] * 0.3
    assert 0.05 < run["coverage"][1] < 0.6
    assert abs(run["er_reactions"] - expect) <= 4 * math.sqrt(expect) + 0.01 * expect


def test_langmuir_hinshelwood_rate_against_independent_occupations():
    """Steady state with replenishment, w = 0.05: reactions = Σ_X [adsorptions_X·g_ads(θ_Y) + hops_X·g_hop(θ_Y)]
    (lh_reaction_probability). Tolerance 4 Poisson σ plus 3 %: the formula neglects the O(w) depletion of
    partners next to a site that just reacted (the measured deficit is ~1.5 % at w = 0.05)."""
    species = [
        Adsorbate("A", 1.0, gas=1500, adsorption=0.5, residence=10.0, hop_rate=0.5),
        Adsorbate("B", 0.8, gas=1500, adsorption=0.3, residence=20.0, hop_rate=0.2),
        Adsorbate("P", 0.6),
    ]
    w = 0.05
    run = surface_run(
        BOX, species, [Mechanism("LH", "A", "B", "P", w)], replenish=True, t_end=2200, t_warm=200, seed=7
    )
    th = run["coverage"]
    s = run["sites_per_edge"]
    pred = sum(
        run["adsorptions"][x] * lh_reaction_probability(s, w, th[y], "adsorption")
        + run["hops"][x] * lh_reaction_probability(s, w, th[y], "hop")
        for x, y in ((0, 1), (1, 0))
    )
    assert run["lh_reactions"] > 2000
    assert abs(run["lh_reactions"] - pred) <= 4 * math.sqrt(pred) + 0.03 * pred
    np.testing.assert_array_equal(run["final_counts"], [1500, 1500, 0])  # replenished: totals constant


def test_langmuir_hinshelwood_conserves_atoms_and_zero_w_costs_nothing():
    """Without replenishment A + B → P keeps A + P and B + P; w = 0 gives the very run without the mechanism."""
    species = [
        Adsorbate("A", 1.0, gas=800, adsorption=0.6, residence=30.0, hop_rate=1.0),
        Adsorbate("B", 0.8, gas=500, adsorption=0.6, residence=30.0, hop_rate=1.0),
        Adsorbate("P", 0.6),
    ]
    run = surface_run(BOX, species, [Mechanism("LH", "A", "B", "P", 0.5)], t_end=400, seed=8)
    a, b, p = run["final_counts"]
    assert p == run["lh_reactions"] > 100
    assert (a + p, b + p) == (800, 500)
    off = surface_run(BOX, species, [Mechanism("LH", "A", "B", "P", 0.0)], t_end=400, seed=8)
    plain = surface_run(BOX, species, t_end=400, seed=8)
    assert off["lh_reactions"] == 0 and off["events"] == plain["events"]
    np.testing.assert_array_equal(off["series"], plain["series"])
    np.testing.assert_array_equal(off["coverage_blocks"], plain["coverage_blocks"])


def test_lh_probability_closed_forms():
    """Hand values: s = 2, every site has z = 2 neighbours: 1 − (1 − wθ)² on adsorption, wθ after a hop."""
    assert lh_reaction_probability(2, 0.5, 0.4, "adsorption") == pytest.approx(1 - 0.8**2)
    assert lh_reaction_probability(2, 0.5, 0.4, "hop") == pytest.approx(0.2)
    assert lh_reaction_probability(1, 0.5, 0.4, "adsorption") == 0.0
    assert second_order_remaining(5.0, 5.0, 0.1, 2.0) == pytest.approx(5.0 / (1 + 0.1 * 5 * 2))
    # equal-count limit of the general formula
    assert second_order_remaining(5.0 + 1e-6, 5.0, 0.1, 2.0) == pytest.approx(5.0 / 2.0, rel=1e-5)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: Adsorbate("A", adsorption=1.5), "adsorption"),
        (lambda: Adsorbate("A", residence=0.0), "residence"),
        (lambda: Mechanism("XY", "A", "B", "P", 0.1), "kind"),
        (lambda: Mechanism("LH", "A", "B", "P", 2.0), "w must"),
        (
            lambda: surface_run(BOX, [Adsorbate("A", gas=1)], [Mechanism("LH", "A", "Q", "Z", 0.1)], t_end=1),
            "'Q'",
        ),
        (lambda: surface_run(BOX, [Adsorbate("A", adsorbed=10**5)], t_end=1), "do not fit"),
        (lambda: surface_run(BOX, [Adsorbate("A", gas=1)], t_end=1, active_fraction=0.0), "active_fraction"),
        (lambda: surface_run(BOX, [Adsorbate("A", gas=1)], t_end=1, wall_law="specular"), "wall_law"),
        (lambda: surface_run(BOX, [Adsorbate("A"), Adsorbate("A", gas=1)], t_end=1), "distinct"),
    ],
)
def test_bad_inputs_raise_one_clear_error(make, match):
    with pytest.raises(PorepipeError, match=match):
        make()


def test_setup_surface_through_the_stage_file_door(tmp_path):
    """Setup ``surface`` from a scene section: the written result holds coverages next to the Langmuir isotherm
    (tolerance as above) and the settings survive the round trip (an infinite residence is allowed)."""
    import json

    import xarray as xr

    from porepipe._shared.store import ResultWriter
    from porepipe.diffusion import Settings
    from porepipe.diffusion._run import run as run_stage

    binary = tmp_path / "binary_a0.001.h5"
    with ResultWriter(binary, stage="segment", scene="t", scene_hash="abc") as w:
        w.write_volume("pore", np.asarray(BOX), voxel_um=0.001, periodic=(0, 0, 0))
    settings = Settings(
        setup="surface",
        surface={
            "species": [
                {"name": "N2", "gas": 1500, "adsorption": 0.5, "residence_jiffies": 10.0},
                {"name": "CO2", "gas": 500, "adsorption": 0.2, "residence_jiffies": 30.0},
                {"name": "Ar", "gas": 10},  # never adsorbs (and never desorbs): no obstacle to the isotherm
            ],
            "duration_jiffies": 1200,
            "warmup_jiffies": 200,
        },
    )
    out = run_stage(settings, binary, tmp_path / "s.h5", "z", seed=9)
    ds = xr.open_dataset(out, engine="h5netcdf")
    for name in ("N2", "CO2"):
        theta, err, lang = (float(ds[f"{name}_{k}"]) for k in ("coverage", "coverage_err", "langmuir"))
        assert abs(theta - lang) <= 4 * err + 3e-3 * theta
    assert float(ds["Ar_coverage"]) == 0.0
    assert ds["series_counts"].shape == (20, 3, 2)
    species = json.loads(ds.attrs["settings"])["surface"]["species"]
    assert species[2]["residence_jiffies"] == math.inf  # written as Infinity, read back as inf
    with pytest.raises(PorepipeError, match="surface.species"):
        run_stage(Settings(setup="surface"), binary, tmp_path / "t.h5", "z")
    assert not (tmp_path / "t.h5").exists()
