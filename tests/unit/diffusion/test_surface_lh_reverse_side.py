"""Reverse Langmuir-Hinshelwood and side reactions of adsorbed species (thesis §4.3.2: an adsorbing product "may lead
to a reverse reaction or to by-products"; the equations were images and the thesis never ran them) on the voxel walls
of a closed 8³ box with Lambert walls (every site hit at the same rate), against exact kinetics:

- branching per arrival on an empty surface: a surface side reaction takes w_S of the product's arrivals, the
  reverse reaction (1 − w_S)·(1 − (1 − w′)^z), z the site's empty neighbours (4 across edges; 2, 3, 4 in-face at
  s = 3), by adsorption and by hops (geometric number of hops per product, bracketed by the coverage);
- A(g) + B(ads) ⇌ P(g) with A and P adsorbing only for an instant and B hopping: the well-mixed rate law with
  hypergeometric neighbour counts (:func:`reversible_lh_products`) and detailed balance (forward = reverse count) at
  equilibrium;
- atoms of A and B conserved through LH, its reverse and side reactions in both phases; zero probabilities cost
  nothing; bad combinations refused with one line.

Each run takes 0.2-5 s once the kernel is compiled.
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
    lh_reaction_probability,
    reversible_lh_products,
    surface_run,
)

BOX = closed_box((8, 8, 8)).pore  # V = 512, S = 384 faces, 1536 sites at s = 2
INSTANT = (
    1e-6  # residence of a species that leaves at once (the next hit on its site comes ~10 jiffies later)
)


@pytest.mark.parametrize("neighbours, s", [("surface", 2), ("face", 3)])
def test_reverse_lh_and_surface_side_reaction_branch_by_their_probabilities(neighbours, s):
    """P adsorbs (a = 0.5) on a surface that stays empty (every species leaves at once, A and B never come back):
    per P adsorption the side reaction P → S happens with w_S = 0.1 and the split with (1 − w_S)·⟨1 − (1 − w′)^z⟩
    (w′ = 0.3; z = 4 across edges, the in-face 2/3/4 at s = 3), each within 4 binomial σ."""
    species = [
        Adsorbate("A", 1.0, residence=INSTANT),
        Adsorbate("B", 0.8, residence=INSTANT),
        Adsorbate("P", 0.6, gas=3000, adsorption=0.5, residence=INSTANT),
        Adsorbate("S", 0.9, residence=INSTANT),
    ]
    mech = [Mechanism("LH", "A", "B", "P", 0.0, w_reverse=0.3)]
    side = [SideReaction("P", "S", 0.1, phase="adsorbed")]
    run = surface_run(BOX, species, mech, side, t_end=100, sites_per_edge=s, neighbours=neighbours, seed=11)
    n = run["adsorptions"][2]
    p_rev = 0.9 * lh_reaction_probability(s, 0.3, 1.0, "adsorption", neighbours)
    for count, p in ((run["lh_reverse_reactions"], p_rev), (run["surface_side_reactions"][2], 0.1)):
        assert abs(count - n * p) <= 4 * math.sqrt(n * p * (1 - p))
    a, b, p, s_ = run["final_counts"]
    assert n > 3000 and a == b == run["lh_reverse_reactions"] and a + p + s_ == 3000
    assert run["lh_reactions"] == 0  # w = 0: the forward reaction is off


def test_reverse_lh_and_surface_side_reaction_on_hop_arrivals():
    """P starts adsorbed (900 on 13 824 sites, never desorbs) and hops; every arrival ends it with
    q = w_S + (1 − w_S)·(1 − (1 − w′)·(1 − w′(1 − θ))³) (the site it came from is empty, the other 3 neighbours hold
    another P with θ ≤ 899/13 822, falling as P splits): the arrivals per P, 1/q, are geometric, so 900/hops within
    4σ = 4q·√((1 − q)/900) of [q(θ_max), q(0)]; the side share of the ends is w_S/q within 4 binomial σ."""
    box = closed_box((24, 24, 24)).pore
    species = [
        Adsorbate("A", 1.0, residence=INSTANT),
        Adsorbate("B", 0.8, residence=INSTANT),
        Adsorbate("P", 0.6, adsorbed=900, hop_rate=1.0),
        Adsorbate("S", 0.9, residence=INSTANT),
    ]
    mech = [Mechanism("LH", "A", "B", "P", 0.0, w_reverse=0.1)]
    side = [SideReaction("P", "S", 0.1, phase="adsorbed")]
    run = surface_run(box, species, mech, side, t_end=200, neighbours="surface", seed=15)
    rev, ends = run["lh_reverse_reactions"], run["surface_side_reactions"][2]
    assert rev + ends == 900  # every P has split or turned into S
    theta = 899 / (run["sites"] - 2)
    q = [0.1 + 0.9 * (1 - 0.9 * (1 - 0.1 * (1 - th)) ** 3) for th in (theta, 0.0)]
    sigma = max(q) * math.sqrt((1 - min(q)) / 900)
    assert q[0] - 4 * sigma <= 900 / run["hops"][2] <= q[1] + 4 * sigma
    share = 0.1 / np.mean(q)
    assert abs(ends / 900 - share) <= 4 * math.sqrt(share * (1 - share) / 900) + (0.1 / q[0] - 0.1 / q[1])


def test_reverse_lh_follows_the_well_mixed_rate_law_to_detailed_balance():
    """A + B ⇌ P, w = 0.02, w′ = 0.08, B hopping at 2 per jiffie (≈ 60 hops per relaxation time): N_P(t) within
    4√N_P + 1 % of the rate law; at equilibrium forward and reverse counts agree within 4 Poisson σ of their sum and
    the mean N_P within 4 σ of a time mean (variance ≤ N_P, correlation time from the law's relaxation) plus 1 %:
    11 of N_P ≈ 204, where w′ off by 25 % (z − 1 tries instead of z) moves the law by 30. Without hops (measured)
    the equilibrium N_P comes out ~1 % high: the split leaves B next to the site its A left from."""
    w, w_rev = 0.02, 0.08
    t = np.array([0.0, 10.0, 20.0, 40.0, 60.0, 100.0, 150.0, 200.0])
    species = [
        Adsorbate("A", 1.0, gas=1500, adsorption=1.0, residence=INSTANT),
        Adsorbate("B", 0.8, adsorbed=600, hop_rate=2.0),
        Adsorbate("P", 0.6, adsorption=1.0, residence=INSTANT),
    ]
    mech = [Mechanism("LH", "A", "B", "P", w, w_reverse=w_rev)]
    run = surface_run(BOX, species, mech, t_end=2600, t_warm=200, t_samples=t, neighbours="surface", seed=12)
    area, vol = run["sites"] * run["site_area"], run["pore_volume"]
    nu = (first_order_rate(1.0, 1.0, area, vol), first_order_rate(1.0, 0.6, area, vol))
    law = reversible_lh_products(
        1500, 600, run["sites"], nu, (1.0, 1.0), w, w_rev, np.r_[t, 400.0, 500.0, 1e4]
    )
    truth, x_eq = law[: t.size], law[-1]
    n_p = run["series"][:, 2, 0]
    assert np.all(np.abs(n_p - truth) <= 4 * np.sqrt(truth + 1) + 0.01 * truth)
    fwd, rev = run["lh_reactions"], run["lh_reverse_reactions"]
    assert fwd > 1000 and abs(fwd - rev) <= 4 * math.sqrt(fwd + rev)
    rate = math.log((x_eq - law[-3]) / (x_eq - law[-2])) / 100.0  # late-time relaxation rate of the law
    sigma = math.sqrt(2.0 * x_eq / (rate * 2400.0))
    assert abs(run["gas_density"][2] * vol - x_eq) <= 4 * sigma + 0.01 * x_eq


def test_reverse_lh_and_side_reactions_conserve_atoms_and_zero_probabilities_cost_nothing():
    """LH + reverse with A, B and P adsorbing, hopping and desorbing, A → S at gas hits, B → S′ and P → S″ on the
    surface: A + P + S + S″ and B + P + S′ + S″ keep their start values; P = forward − reverse − side(P). A reverse
    and surface side reactions of probability 0 give the very run without them."""
    species = [
        Adsorbate("A", 1.0, gas=900, adsorption=0.6, residence=20.0, hop_rate=1.0),
        Adsorbate("B", 0.8, gas=300, adsorbed=400, adsorption=0.6, residence=30.0, hop_rate=0.5),
        Adsorbate("P", 0.6, adsorption=0.5, residence=5.0, hop_rate=0.5),
        Adsorbate("S", 1.0),
        Adsorbate("S1", 0.8, adsorption=0.2, residence=10.0),
        Adsorbate("S2", 0.6, adsorption=0.2, residence=10.0),
    ]
    mech = [Mechanism("LH", "A", "B", "P", 0.5, w_reverse=0.3)]
    side = [
        SideReaction("A", "S", 0.01),
        SideReaction("B", "S1", 0.02, phase="adsorbed"),
        SideReaction("P", "S2", 0.05, phase="adsorbed"),
    ]
    run = surface_run(BOX, species, mech, side, t_end=300, seed=13)
    a, b, p, s, s1, s2 = run["final_counts"]
    assert run["lh_reverse_reactions"] > 100 and min(run["surface_side_reactions"][1:3]) > 20
    assert run["side_reactions"][0] > 20
    assert (a + p + s + s2, b + p + s1 + s2) == (900, 700)
    assert p == run["lh_reactions"] - run["lh_reverse_reactions"] - run["surface_side_reactions"][2]
    plain = surface_run(BOX, species, [Mechanism("LH", "A", "B", "P", 0.5)], side[:1], t_end=100, seed=13)
    zero = side[:1] + [SideReaction(r.reactant, r.product, 0.0, r.phase) for r in side[1:]]
    off = surface_run(BOX, species, [Mechanism("LH", "A", "B", "P", 0.5, 0.0)], zero, t_end=100, seed=13)
    assert off["events"] == plain["events"] and off["surface_side_reactions"].sum() == 0
    np.testing.assert_array_equal(off["coverage_blocks"], plain["coverage_blocks"])


SP = [
    Adsorbate("A", gas=10, adsorption=0.5),
    Adsorbate("B", adsorbed=5, hop_rate=1.0),
    Adsorbate("P", adsorption=0.5),
    Adsorbate("S"),
]
LH = Mechanism("LH", "A", "B", "P", 0.5, w_reverse=0.2)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: SideReaction("A", "S", 0.1, phase="solid"), "phase must be gas or adsorbed"),
        (
            lambda: surface_run(BOX, SP, [LH], t_end=1, replenish=True),
            "reverse Langmuir-Hinshelwood.*replenish",
        ),
        (
            lambda: surface_run(BOX, SP, [LH], [SideReaction("S", "P", 0.1)], t_end=1),
            "may make its product 'P'",
        ),
        (
            lambda: surface_run(BOX, SP[:2] + [Adsorbate("P", gas=3)] + SP[3:], [LH], t_end=1),
            "product 'P' to reach a site",
        ),
        (
            lambda: surface_run(BOX, SP, [], [SideReaction("S", "A", 0.1, "adsorbed")], t_end=1),
            "'S' never arrives",
        ),
        (
            lambda: surface_run(BOX, SP, [], [SideReaction("A", "S", 0.1, "adsorbed")] * 2, t_end=1),
            "one side reaction per reactant and phase",
        ),
    ],
)
def test_bad_combinations_raise_one_clear_error(make, match):
    with pytest.raises(PorepipeError, match=match):
        make()


def test_scene_keys_reach_the_kernel():
    """``mechanisms[].w_reverse`` for LH and ``side_reactions[].phase: adsorbed`` through setup ``surface``: the
    values carry the reverse and surface side counts, and the product balance holds; a bad phase names its key."""
    from pydantic import ValidationError

    from porepipe.diffusion import Settings
    from porepipe.diffusion._surface import surface_result

    surface = {
        "species": [
            {"name": "N2", "gas": 600, "adsorption": 0.8, "residence_jiffies": 20, "hop_rate": 1.0},
            {"name": "O2", "gas": 300, "adsorption": 0.8, "residence_jiffies": 20, "hop_rate": 1.0},
            {"name": "CO2", "adsorption": 0.5, "residence_jiffies": 5},
            {"name": "Ar"},
        ],
        "mechanisms": [{"kind": "LH", "a": "N2", "b": "O2", "product": "CO2", "w": 0.5, "w_reverse": 0.3}],
        "side_reactions": [{"reactant": "CO2", "product": "Ar", "w": 0.05, "phase": "adsorbed"}],
        "duration_jiffies": 200,
        "warmup_jiffies": 0,
    }
    settings = Settings(setup="surface", surface=surface)
    v = surface_result(np.asarray(BOX), settings, 1e-3, (False, False, False), seed=14).values
    assert v["lh_reverse_reactions"] > 10 and v["CO2_surface_side_reactions"] > 10
    assert v["lh_reactions"] - v["lh_reverse_reactions"] >= v["CO2_surface_side_reactions"]
    bad = dict(surface, side_reactions=[{"reactant": "CO2", "product": "Ar", "w": 0.05, "phase": "liquid"}])
    with pytest.raises(ValidationError, match="phase"):
        Settings(setup="surface", surface=bad)
