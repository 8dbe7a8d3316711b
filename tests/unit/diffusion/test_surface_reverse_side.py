"""Reverse Eley-Rideal (thesis 4.18) and side reactions (4.20-4.22) on the voxel walls of a closed 8³ box with
Lambert walls, against exact kinetics (the thesis wrote these equations down but never ran them):

- side reactions A ⇌ S (first order, k_X = w_X·v̄_X·S/(4V)): exponential relaxation to N_S/N_A = k_A/k_S;
- A(g) + B(ads) ⇌ P(g): the Riccati solution of the mass-action law and detailed balance (forward = reverse count)
  at equilibrium;
- ER competing with a side reaction of A: the by-product count against the ER progress, c·(H(N_B0) − H(N_B)),
  c = w_S·n_sites/w (the branching ratio per hit is the ratio of the probabilities);
- atoms of A and B conserved through every channel; zero probabilities cost nothing; bad combinations refused.

Each run takes 1-2 s once the kernel is compiled.
"""

import math

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.diffusion._geometry import closed_box
from porepipe.diffusion._surface import (
    Adsorbate,
    Mechanism,
    SideReaction,
    first_order_rate,
    reversible_er_products,
    reversible_first_order,
    side_products_per_er,
    surface_run,
)

BOX = closed_box((8, 8, 8)).pore  # V = 512, S = 384 faces, 1536 sites at s = 2


def _time_mean_tol(variance, rate, span):
    """4 σ of the time mean of a stationary count with the given variance and relaxation rate over ``span``
    (integrated autocorrelation time 1/rate: Var(mean) = 2·variance/(rate·span))."""
    return 4.0 * math.sqrt(2.0 * variance / (rate * span))


def test_side_reactions_a_to_s_and_back_relax_exponentially():
    """A → S (w 0.03) and S → A (w 0.02), different speeds: N_A(t) within 4 binomial σ of the exponential (each
    particle is an independent two-state chain); after 5 relaxation times the mean N_A against N·k_S/(k_A + k_S)
    within 4 σ of a time mean (correlation time 1/(k_A + k_S))."""
    t = np.array([0.0, 50.0, 100.0, 200.0, 400.0, 600.0])
    species = [Adsorbate("A", 1.0, gas=2000), Adsorbate("S", 0.7)]
    side = [SideReaction("A", "S", 0.03), SideReaction("S", "A", 0.02)]
    run = surface_run(BOX, species, (), side, t_end=1600, t_warm=600, t_samples=t, seed=1)
    area, vol = run["sites"] * run["site_area"], run["pore_volume"]
    k_f, k_r = first_order_rate(0.03, 1.0, area, vol), first_order_rate(0.02, 0.7, area, vol)
    truth = reversible_first_order(2000, k_f, k_r, t)
    p = truth / 2000
    n_a = run["series"][:, 0, 0]
    assert np.all(np.abs(n_a - truth) <= 4 * np.sqrt(2000 * p * (1 - p)) + 1e-9)
    eq = 2000 * k_r / (k_f + k_r)
    mean_a = run["gas_density"][0] * vol
    assert abs(mean_a - eq) <= _time_mean_tol(eq * k_f / (k_f + k_r), k_f + k_r, 1000.0)
    assert run["side_reactions"][0] > 3000 and run["side_reactions"][1] > 3000


def test_reverse_eley_rideal_follows_the_riccati_law_to_detailed_balance():
    """A(g) + B(ads) ⇌ P(g), w = 0.05, w′ = 0.1, B never desorbs: N_P(t) within 4√N_P + 1 % of the exact
    solution; at equilibrium the forward and reverse counts agree within 4 Poisson σ of their sum and the mean N_P
    matches the root r₁ within 4 σ of a time mean (variance ≤ N_P, relaxation rate of the linearised law)."""
    t = np.array([0.0, 25.0, 50.0, 100.0, 200.0, 400.0])
    species = [Adsorbate("A", 1.0, gas=2000), Adsorbate("B", 0.8, adsorbed=800), Adsorbate("P", 0.6)]
    mech = [Mechanism("ER", "A", "B", "P", 0.05, w_reverse=0.1)]
    run = surface_run(BOX, species, mech, t_end=1400, t_warm=400, t_samples=t, seed=2)
    vol, m = run["pore_volume"], run["active_sites"]
    k_f = first_order_rate(0.05, 1.0, run["site_area"], vol)
    k_r = first_order_rate(0.1, 0.6, run["site_area"], vol)
    truth = reversible_er_products(2000, 800, m, k_f, k_r, t)
    n_p = run["series"][:, 2, 0]
    assert np.all(np.abs(n_p - truth) <= 4 * np.sqrt(truth + 1) + 0.01 * truth)
    fwd, rev = run["er_reactions"], run["er_reverse_reactions"]
    assert fwd > 2000 and abs(fwd - rev) <= 4 * math.sqrt(fwd + rev)
    x_eq = float(reversible_er_products(2000, 800, m, k_f, k_r, 1e9))
    rate = k_f * (2000 + 800 - 2 * x_eq) + k_r * (m - 800 + 2 * x_eq)  # −d(dx/dt)/dx at x_eq
    assert abs(run["gas_density"][2] * vol - x_eq) <= _time_mean_tol(x_eq, rate, 1000.0)


def test_side_reaction_branches_against_eley_rideal_by_the_probability_ratio():
    """ER on fixed B (w = 0.05) and A → S (w_S = 0.02) on every wall hit: at each sample the S count against
    c·(H(N_B0) − H(N_B)), c = w_S·n_sites/w, within 4 σ of the geometric sums plus one step c/N_B (a sample falls
    between two ER events)."""
    t = np.linspace(0.0, 300.0, 7)
    species = [
        Adsorbate("A", 1.0, gas=3000),
        Adsorbate("B", 0.8, adsorbed=1500),
        Adsorbate("P", 0.6),
        Adsorbate("S", 0.9),
    ]
    run = surface_run(
        BOX,
        species,
        [Mechanism("ER", "A", "B", "P", 0.05)],
        [SideReaction("A", "S", 0.02)],
        t_end=300,
        t_samples=t,
        seed=3,
    )
    c = 0.02 * run["sites"] / 0.05
    n_b = run["series"][:, 1, 1].astype(int)
    n_s = run["series"][:, 3, 0]
    assert n_b[-1] < 0.2 * 1500
    for b, s in zip(n_b, n_s):
        mean, var = side_products_per_er(c, 1500, int(b))
        assert abs(s - mean) <= 4 * math.sqrt(var) + c / b


def test_every_channel_conserves_atoms_and_zero_probabilities_cost_nothing():
    """ER + reverse + A → S, B → S′, P → S″ with B adsorbing and desorbing: A + P + S + S″ and B + P + S′ + S″ keep
    their start values; P = forward − reverse − side(P). Side reactions and a reverse of probability 0 give the
    very run without them."""
    species = [
        Adsorbate("A", 1.0, gas=1200),
        Adsorbate("B", 0.8, gas=300, adsorbed=500, adsorption=0.4, residence=40.0, hop_rate=0.3),
        Adsorbate("P", 0.6),
        Adsorbate("S", 1.0),
        Adsorbate("S1", 0.8),
        Adsorbate("S2", 0.6),
    ]
    mech = [Mechanism("ER", "A", "B", "P", 0.2, w_reverse=0.3)]
    side = [SideReaction("A", "S", 0.01), SideReaction("B", "S1", 0.01), SideReaction("P", "S2", 0.01)]
    run = surface_run(BOX, species, mech, side, t_end=300, seed=4)
    a, b, p, s, s1, s2 = run["final_counts"]
    assert run["er_reverse_reactions"] > 200 and min(run["side_reactions"][:3]) > 20
    assert (a + p + s + s2, b + p + s1 + s2) == (1200, 800)
    assert p == run["er_reactions"] - run["er_reverse_reactions"] - run["side_reactions"][2]
    plain = surface_run(BOX, species, [Mechanism("ER", "A", "B", "P", 0.2)], t_end=100, seed=4)
    zero = [SideReaction(r.reactant, r.product, 0.0) for r in side]
    off = surface_run(BOX, species, [Mechanism("ER", "A", "B", "P", 0.2, 0.0)], zero, t_end=100, seed=4)
    assert off["events"] == plain["events"] and off["side_reactions"].sum() == 0
    np.testing.assert_array_equal(off["coverage_blocks"], plain["coverage_blocks"])


SP = [Adsorbate("A", gas=10), Adsorbate("B", adsorbed=5), Adsorbate("P"), Adsorbate("S")]
ER = Mechanism("ER", "A", "B", "P", 0.5, w_reverse=0.2)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: Mechanism("ER", "A", "B", "B", 0.1), "must differ"),
        (lambda: Mechanism("ER", "A", "B", "P", 0.1, w_reverse=1.5), "w_reverse must"),
        (lambda: SideReaction("A", "A", 0.1), "must differ"),
        (lambda: SideReaction("A", "S", -0.1), "w must"),
        (lambda: surface_run(BOX, SP, [], [SideReaction("A", "Q", 0.1)], t_end=1), "'Q'"),
        (
            lambda: surface_run(BOX, SP, [], [SideReaction("A", "S", 0.1)] * 2, t_end=1),
            "one side reaction per reactant",
        ),
        (lambda: surface_run(BOX, SP, [ER], [SideReaction("A", "S", 0.6)], t_end=1), "more than 1"),
        (lambda: surface_run(BOX, SP, [ER], t_end=1, replenish=True), "replenish"),
        (lambda: surface_run(BOX, SP, [ER], [SideReaction("S", "P", 0.1)], t_end=1), "its product"),
    ],
)
def test_bad_combinations_raise_one_clear_error(make, match):
    with pytest.raises(PorepipeError, match=match):
        make()


def test_scene_keys_reach_the_kernel():
    """``diffusion.surface.side_reactions`` and ``mechanisms[].w_reverse`` through setup ``surface``: the values
    carry the reverse and side counts, and the atoms balance."""
    from porepipe.diffusion import Settings
    from porepipe.diffusion._surface import surface_result

    settings = Settings(
        setup="surface",
        surface={
            "species": [
                {"name": "N2", "gas": 600},
                {"name": "O2", "adsorbed": 300},
                {"name": "CO2"},
                {"name": "Ar"},
            ],
            "mechanisms": [
                {"kind": "ER", "a": "N2", "b": "O2", "product": "CO2", "w": 0.3, "w_reverse": 0.3}
            ],
            "side_reactions": [{"reactant": "CO2", "product": "Ar", "w": 0.05}],
            "duration_jiffies": 200,
            "warmup_jiffies": 0,
        },
    )
    res = surface_result(np.asarray(BOX), settings, 1e-3, (False, False, False), seed=5)
    v = res.values
    assert v["er_reverse_reactions"] > 10 and v["CO2_side_reactions"] > 10
    assert v["er_reactions"] - v["er_reverse_reactions"] >= v["CO2_side_reactions"]
