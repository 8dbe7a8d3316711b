"""Adsorption, surface diffusion, Langmuir-Hinshelwood and Eley-Rideal on the voxel walls (Mahler 2001 §4.3-4.4).

The thesis designed these mechanisms (Q_ADSORB per voxel face, residence times, RkPartner within a reactive
distance, w_ER = a·θ_B·w) but never ran them; this module runs them in the Knudsen regime (no gas-gas collisions)
with every gas and adsorbed particle advancing through one event calendar (see
:mod:`porepipe.diffusion._surface_kernels`). Units: lengths in voxels, times in jiffies, speeds in voxel/jiffie.

Model (each choice stated so the analytic truths below are exact):

- each wall face of a pore voxel carries ``s × s`` sites of area A_site = (face area)/s² (see
  :mod:`porepipe.diffusion._surface_sites`), a fraction
  ``active_fraction`` of them active (the thesis's a); a site holds one particle;
- a gas particle of species X hitting an active empty site adsorbs with probability ``adsorption``; it stays a
  residence time (fixed or exponential of mean ``residence``), hops to a neighbour site at rate ``hop_rate``
  (rejected if that site is occupied, inactive or missing) and desorbs by the wall law with a thermal speed;
  neighbours are the in-face sites (``neighbours="face"``) or also the sites across the voxel edges where two
  wall faces meet (``"surface"``: 4 for every site, concave and convex edges alike);
- Eley-Rideal A(g) + B(ads) → P: an A hit on a site that holds B reacts with probability ``w``; so per A hit the
  reaction probability is a·θ_B·w, the thesis's (4.16), with θ_B the coverage of the active sites;
- Langmuir-Hinshelwood A(ads) + B(ads) → P: a particle arriving at a site tries each neighbour holding its
  partner with probability ``w`` (reactive distance = one site spacing);
- ``replenish``: each reaction's product is counted and both reactants re-enter the gas (steady state).
- reverse Eley-Rideal (thesis 4.18, ``Mechanism.w_reverse``): a product hit on an empty active site turns it back
  into gas A (which leaves the wall) and B adsorbed on that site, with probability ``w_reverse``;
- reverse Langmuir-Hinshelwood (thesis §4.3.2: an adsorbing product "with a residence time" may react back): a
  product arriving on a site (adsorption or hop) tries each empty active neighbour with ``w_reverse`` (the order of
  the forward tries) and splits into A on its site and B on that neighbour; the two do not try each other at once;
- side and consecutive reactions (thesis 4.20-4.22, :class:`SideReaction`): a gas wall hit of X turns it into its
  by-product with probability w (A → S, B → S′, P → S″; at most one per reactant and phase). The reactions open on
  one hit (ER or its reverse, and the side reaction) share one uniform number: their probabilities add;
- side reactions on the surface (``phase="adsorbed"``, thesis §4.3.2's by-products of adsorbed species): an X
  arriving on a site turns into its by-product there with probability w, tried before any Langmuir-Hinshelwood
  reaction; the by-product keeps the site for its own residence time.

Analytic truths (tests/unit/diffusion/test_surface_mechanisms.py and the reverse / side-reaction tests beside it):

- Langmuir (competitive, one site per particle): with Lambert walls the equilibrium gas hits every site at
  F_X = n_X·v̄_X·A_site/4 per time, so each active site is a Markov chain empty ⇄ X with rates a_X·F_X and 1/τ_X:
  θ_X = K_X·n_X/(1 + Σ_Y K_Y·n_Y), K_X = a_X·v̄_X·A_site·τ_X/4 (:func:`langmuir_coverage`); hops (a symmetric
  exclusion process) do not change it.
- LH encounters: with independent Bernoulli occupations (exact at w → 0) an arrival of X on a site with z
  neighbours reacts with probability 1 − (1 − w·θ_Y)^z, z − 1 for a hop (the site it came from is empty now)
  (:func:`lh_reaction_probability`).
- ER with B fixed on the surface and no replenishment: −dN_B/dt = k·N_A·N_B, k = w·v̄_A·A_site/(4V), N_A − N_B
  constant: the second-order law (:func:`second_order_remaining`), first order when A is in excess.
- ER with its reverse (B never desorbs, all sites active, M sites): x = N_P obeys
  dx/dt = k_f·(N_A0 − x)(N_B0 − x) − k_r·x·(M − N_B0 + x), k_f = w·v̄_A·A_site/(4V), k_r = w′·v̄_P·A_site/(4V), a
  Riccati equation with constant coefficients (:func:`reversible_er_products`); at equilibrium
  N_P·N_empty/(N_A·N_B) = k_f/k_r.
- Reverse Langmuir-Hinshelwood on an empty surface: a product adsorbing on a site splits with probability
  1 − (1 − w′)^z, z its empty neighbours (:func:`lh_reaction_probability` with θ = 1, averaged over the sites);
  a surface side reaction before it takes w_S of the arrivals, the split (1 − w_S) of that.
- A(g) + B(ads) ⇌ P(g) by LH and its reverse with A and P adsorbing only for an instant and B hopping fast (well
  mixed: its sites a uniform random subset): a one-variable rate law with hypergeometric neighbour counts
  (:func:`reversible_lh_products`), exact in that limit up to O(1/N) fluctuations.
- Side reactions with first-order rates k_X = w_X·v̄_X·S/(4V) (S the wall area): A ⇌ S relaxes exponentially with
  rate k_A + k_S to N_S/N_A = k_A/k_S; competing with ER on fixed B, every A hit branches with w_S against w on a B
  site, so the by-product count is S = (w_S·n_sites/w)·(H(N_B0) − H(N_B)) in the mean, harmonic numbers H
  (:func:`side_products_per_er`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.rng import kernel_seed
from porepipe.diffusion import _surface_kernels as S
from porepipe.diffusion._surface_sites import site_neighbours, wall_sites

STAGE = "diffusion"
_LAWS = {"lambert": 1, "isotropic": 3, "cosine_dtheta": 2}
#: shortest time block as a fraction of t_end: its ends are then resolved to ~2e-7 of its length (t_end's float
#: spacing is 2.2e-16 t_end); shorter blocks round onto one another and their tallies are noise
MIN_BLOCK = 1e-9


@dataclass(frozen=True)
class Adsorbate:
    """One species: mean speed (voxel/jiffie), start counts, adsorption probability, mean residence, hop rate."""

    name: str
    vmean: float = 1.0
    gas: int = 0
    adsorbed: int = 0
    adsorption: float = 0.0
    residence: float = math.inf
    hop_rate: float = 0.0

    def __post_init__(self):
        checks = (
            ("vmean", self.vmean > 0 and math.isfinite(self.vmean)),
            ("gas", self.gas >= 0 and int(self.gas) == self.gas),
            ("adsorbed", self.adsorbed >= 0 and int(self.adsorbed) == self.adsorbed),
            ("adsorption", 0.0 <= self.adsorption <= 1.0),
            ("residence", self.residence > 0),
            ("hop_rate", self.hop_rate >= 0 and math.isfinite(self.hop_rate)),
        )
        for key, ok in checks:
            if not ok:
                raise PorepipeError(f"species {self.name!r}: invalid {key} = {getattr(self, key)!r}")


@dataclass(frozen=True)
class Mechanism:
    """A + B → product, bimolecular: ``kind`` "LH" (both adsorbed) or "ER" (``a`` from the gas, ``b`` adsorbed).

    ``w_reverse``: ER (thesis 4.18): probability that a hit of the product on an empty active site turns it back
    into gas ``a`` and adsorbed ``b`` on that site; LH (thesis §4.3.2, an adsorbing product): a product arriving on a
    site tries each empty active neighbour with this probability and splits into ``a`` on its site and ``b`` there.
    """

    kind: str
    a: str
    b: str
    product: str
    w: float
    w_reverse: float = 0.0

    def __post_init__(self):
        if self.kind not in ("LH", "ER"):
            raise PorepipeError(f"mechanism kind must be LH or ER, got {self.kind!r}")
        for key in ("w", "w_reverse"):
            if not 0.0 <= getattr(self, key) <= 1.0:
                raise PorepipeError(
                    f"mechanism {self.kind}: {key} must lie in [0, 1], got {getattr(self, key)!r}"
                )
        if self.product in (self.a, self.b):
            raise PorepipeError(f"mechanism {self.kind}: product {self.product!r} must differ from a and b")


@dataclass(frozen=True)
class SideReaction:
    """Side or consecutive reaction ``reactant`` → ``product`` with probability ``w``: ``phase`` "gas" at a wall hit
    of the gas reactant (thesis 4.20-4.22), "adsorbed" when the reactant arrives on a site (by adsorption or a hop;
    thesis §4.3.2: by-products of adsorbed species), the by-product staying on that site.
    """

    reactant: str
    product: str
    w: float
    phase: str = "gas"

    def __post_init__(self):
        if self.phase not in ("gas", "adsorbed"):
            raise PorepipeError(
                f"side reaction {self.reactant} → {self.product}: phase must be gas or adsorbed, got {self.phase!r}"
            )
        if not 0.0 <= self.w <= 1.0:
            raise PorepipeError(
                f"side reaction {self.reactant} → {self.product}: w must lie in [0, 1], got {self.w!r}"
            )
        if self.reactant == self.product:
            raise PorepipeError(
                f"side reaction {self.reactant} → {self.product}: product must differ from reactant"
            )


def _sites_and_activity(n_faces, s, active_fraction, seed):
    n_sites = n_faces * s * s
    if not 0.0 < active_fraction <= 1.0:
        raise PorepipeError(f"active_fraction must lie in (0, 1], got {active_fraction!r}")
    rng = np.random.default_rng(kernel_seed(seed, STAGE, 19))
    active = rng.random(n_sites) < active_fraction if active_fraction < 1.0 else np.ones(n_sites, bool)
    if not active.any():
        raise PorepipeError(
            f"active_fraction {active_fraction!r} left none of the {n_sites} sites active (the coverage would be "
            "0/0); raise active_fraction or sites_per_edge"
        )
    return n_sites, active


def _start_sites(species, active, seed, spare_of=()):
    """Start site per particle (-1 = gas): the pre-adsorbed ones on distinct random active sites; one spare slot
    (site ``S.SPARE``) per starting particle of each species in ``spare_of`` (the products of reverse reactions) at
    the end.
    """
    n_pre = sum(int(sp.adsorbed) for sp in species)
    free = np.flatnonzero(active)
    if n_pre > free.size:
        raise PorepipeError(f"{n_pre} pre-adsorbed particles do not fit on {free.size} active sites")
    rng = np.random.default_rng(kernel_seed(seed, STAGE, 20))
    chosen = rng.choice(free, size=n_pre, replace=False)
    kinds, sites, k = [], [], 0
    for x, sp in enumerate(species):
        kinds += [x] * (int(sp.gas) + int(sp.adsorbed))
        sites += [-1] * int(sp.gas) + list(chosen[k : k + int(sp.adsorbed)])
        k += int(sp.adsorbed)
    for x in spare_of:
        n_spare = int(species[x].gas) + int(species[x].adsorbed)
        kinds += [x] * n_spare
        sites += [S.SPARE] * n_spare
    return np.array(kinds, dtype=np.int64), np.array(sites, dtype=np.int64)


def _mechanism_arrays(mechanisms, names):
    lh, er = np.full(3, -1, np.int64), np.full(3, -1, np.int64)
    w = np.zeros(4)
    seen = set()
    for m in mechanisms:
        for key in ("a", "b", "product"):
            if getattr(m, key) not in names:
                raise PorepipeError(
                    f"mechanism {m.kind}: {key} = {getattr(m, key)!r} is not a species ({names})"
                )
        if m.kind in seen:
            raise PorepipeError(f"at most one {m.kind} mechanism, got two")
        seen.add(m.kind)
        spec = np.array([names.index(m.a), names.index(m.b), names.index(m.product)], np.int64)
        if m.w == 0.0 and m.w_reverse == 0.0:
            continue  # a zero-probability mechanism is off: not one random number drawn for it
        if m.kind == "LH":
            lh, w[S.W_LH], w[S.W_LH_REV] = spec, m.w, m.w_reverse
        else:
            er, w[S.W_ER], w[S.W_REV] = spec, m.w, m.w_reverse
    return lh, er, w


def _side_arrays(side_reactions, names, phase):
    """Per species: the ``phase`` side reaction's product index (-1 = none) and probability per hit / arrival."""
    to, w = np.full(len(names), -1, np.int64), np.zeros(len(names))
    for r in side_reactions:
        for key in ("reactant", "product"):
            if getattr(r, key) not in names:
                raise PorepipeError(f"side reaction: {key} = {getattr(r, key)!r} is not a species ({names})")
        if r.phase != phase:
            continue
        x = names.index(r.reactant)
        if to[x] >= 0:
            raise PorepipeError(
                f"at most one side reaction per reactant and phase, got two {phase} ones for {r.reactant!r}"
            )
        if r.w > 0.0:  # zero probability: off, no random number drawn for it
            to[x], w[x] = names.index(r.product), r.w
    return to, w


def _reverse_checks(kind, product, species, er, replenish, makers):
    """A reverse reaction needs products that stay (no replenishment), no other source of its product (each product
    slot keeps a spare slot for the second reactant it splits into) and, for LH, a product that reaches a site.
    """
    names = [sp.name for sp in species]
    if replenish:
        raise PorepipeError(
            f"the reverse {kind} reaction needs replenish: false (no product stays in the gas)"
        )
    if product in makers:
        raise PorepipeError(
            f"with the reverse {kind} reaction no side reaction may make its product {names[product]!r}"
        )
    if kind == "Langmuir-Hinshelwood" and not _arrives(species[product], product, er):
        raise PorepipeError(
            f"mechanism LH: w_reverse needs its product {names[product]!r} to reach a site "
            "(adsorption > 0 or hop_rate > 0)"
        )


def _arrives(sp, x, er):
    """Whether species ``x`` can arrive on a site: by adsorption, a hop, or as the reverse Eley-Rideal's ``b``."""
    return sp.adsorption > 0.0 or sp.hop_rate > 0.0 or (x == er[1] and er[0] >= 0)


def _mechanism_tuple(mechanisms, side_reactions, species, replenish):
    """The kernel's ``mech`` tuple, after the checks that tie mechanisms and side reactions together."""
    names = [sp.name for sp in species]
    lh, er, w = _mechanism_arrays(mechanisms, names)
    side_to, side_w = _side_arrays(side_reactions, names, "gas")
    surf_to, surf_w = _side_arrays(side_reactions, names, "adsorbed")
    w_er = {int(er[0]): w[S.W_ER], int(er[2]): w[S.W_REV]} if er[0] >= 0 else {}
    for x, p in w_er.items():
        if p + side_w[x] > 1.0:
            raise PorepipeError(
                f"species {names[x]!r}: Eley-Rideal ({p}) and side reaction ({side_w[x]}) probabilities per hit "
                "add up to more than 1"
            )
    er_b = er if w[S.W_REV] > 0.0 else np.full(3, -1, np.int64)  # the reverse ER puts b on a site
    for x in np.flatnonzero(surf_w > 0.0):
        if not _arrives(species[x], x, er_b):
            raise PorepipeError(
                f"side reaction {names[x]} → {names[surf_to[x]]} (phase adsorbed): {names[x]!r} never arrives on "
                "a site (adsorption > 0 or hop_rate > 0 needed)"
            )
    makers = set(side_to[side_to >= 0].tolist()) | set(surf_to[surf_to >= 0].tolist())
    for kind, spec, rev in (("Eley-Rideal", er, S.W_REV), ("Langmuir-Hinshelwood", lh, S.W_LH_REV)):
        if w[rev] > 0.0:
            _reverse_checks(kind, int(spec[2]), species, er_b, replenish, makers)
    return lh, er, w, side_to, side_w, surf_to, surf_w


def surface_run(
    pore,
    species,
    mechanisms=(),
    side_reactions=(),
    *,
    t_end: float,
    t_warm: float = 0.0,
    sites_per_edge: int = 2,
    neighbours: str = "face",
    active_fraction: float = 1.0,
    wall_law: str = "lambert",
    residence_law: str = "exponential",
    replenish: bool = False,
    blocks: int = 16,
    t_samples=(),
    voxel_um=1.0,
    periodic=(False, False, False),
    seed: int = 0,
) -> dict:
    """Run the adsorbing, reacting Knudsen gas in a closed (or periodic) pore from 0 to ``t_end`` jiffies.

    ``neighbours``: the sites a hop may reach and a Langmuir-Hinshelwood partner may sit on: "face" (the in-face
    neighbours only) or "surface" (also across the voxel edges where two wall faces meet, so every site has 4).

    Returns per species (arrays in the order of ``species``) over the blocks after ``t_warm``: ``coverage`` (time
    mean adsorbed count / active sites) and its error, ``gas_density`` (time mean gas count / pore volume),
    ``adsorptions``, ``desorptions``, ``hops``, ``hop_tries``, ``wall_hits``, ``side_reactions`` (by reactant);
    ``surface_side_reactions`` (phase adsorbed, by reactant); ``lh_reactions``/``er_reactions``/``er_reverse_reactions``/
    ``lh_reverse_reactions`` (counts after ``t_warm``); ``series`` (gas and adsorbed counts at ``t_samples``,
    shape (k, species, 2)); ``final_counts`` (gas + adsorbed slots per species at the end); geometry data
    (``pore_volume``, ``sites``, ``site_area``, ``active_sites``) and ``events``.
    """
    from porepipe.diffusion._api import prepare

    species, mechanisms, side_reactions = tuple(species), tuple(mechanisms), tuple(side_reactions)
    names = [sp.name for sp in species]
    if not species or len(set(names)) != len(names):
        raise PorepipeError(f"species must be a non-empty list of distinct names, got {names}")
    if wall_law not in _LAWS:
        raise PorepipeError(f"wall_law must be one of {', '.join(_LAWS)}, got {wall_law!r}")
    if residence_law not in ("fixed", "exponential"):
        raise PorepipeError(f"residence_law must be fixed or exponential, got {residence_law!r}")
    if int(sites_per_edge) != sites_per_edge or sites_per_edge < 1:
        raise PorepipeError(f"sites_per_edge must be a positive whole number, got {sites_per_edge!r}")
    _check_times(t_end, t_warm, blocks)
    mech = _mechanism_tuple(mechanisms, side_reactions, species, replenish)
    geom = prepare(pore, voxel_um, periodic, axis=None)
    if not np.allclose(geom.h, 1.0):
        raise PorepipeError(f"the adsorbing gas needs cubic voxels, got voxel_um {geom.voxel_um.tolist()}")
    face_of, site_face = wall_sites(geom.codes, geom.periodic)
    if site_face.shape[0] == 0:
        raise PorepipeError(
            "the pore has no wall face (all pore and periodic on every axis): the adsorbing gas needs walls; "
            "close an axis or give solid voxels"
        )
    s = int(sites_per_edge)
    n_sites, active = _sites_and_activity(site_face.shape[0], s, active_fraction, seed)
    _check_events(species, mechanisms, side_reactions, geom, int(active.sum()), t_end)
    spare_of = {int(mech[k][2]) for k, rev in ((1, S.W_REV), (0, S.W_LH_REV)) if mech[2][rev] > 0.0}
    kinds, site0 = _start_sites(species, active, seed, sorted(spare_of))
    if kinds.size == 0:
        raise PorepipeError("no particles: give some species a gas or adsorbed count > 0")
    opts = np.array([_LAWS[wall_law], int(residence_law == "exponential"), int(bool(replenish))], np.int64)
    n_sp = len(species)
    tally = np.zeros((blocks, n_sp, S.N_STALLY))
    rtally = np.zeros((blocks, S.N_XTALLY))
    samples = _sample_times(t_samples, t_end)
    series = np.zeros((samples.size, n_sp, 2))
    final_sp = np.empty(kinds.size, np.int64)
    final_st = np.empty(kinds.size, np.int64)
    nbr = site_neighbours(geom.codes, geom.periodic, face_of, site_face, s, neighbours)
    geo = (geom.codes, geom.h, geom.periodic, geom.cells(), face_of, site_face, active, s, nbr)
    kin = (
        opts,
        np.array([sp.vmean for sp in species]),
        np.array([sp.adsorption for sp in species]),
        np.array([sp.residence for sp in species]),
        np.array([sp.hop_rate for sp in species]),
    )
    seed_k = kernel_seed(seed, STAGE, 21)
    out = (tally, rtally, series, final_sp, final_st)
    events = S.surface_kernel(
        geo, kin, mech, kinds, site0, seed_k, float(t_end), float(t_warm), samples, *out
    )
    return _summary(
        tally, rtally, series, final_sp, final_st, geom, n_sites, active, s, t_end - t_warm, events
    )


def _check_events(species, mechanisms, side_reactions, geom, n_active, t_end) -> None:
    """Refuse a run whose events exceed ``_api.MAX_EVENTS`` by the two rates that never stop: the wall hits of gas
    particles that never adsorb (v̄·S/4V each per jiffie, exact for an equilibrium gas) and the hop tries of adsorbed
    ones that never leave (those adsorbed at the start, and those of the gas that adsorbs, up to the active sites),
    counting only species no reaction turns into another (the rest comes on top).
    """
    from porepipe.diffusion._api import MAX_EVENTS

    reacting = {m.a for m in mechanisms} | {m.b for m in mechanisms} | {r.reactant for r in side_reactions}
    reacting |= {m.product for m in mechanisms if m.w_reverse > 0}  # it splits back into a and b
    hit_rate = geom.wall_area / (4.0 * geom.pore_volume)  # per unit speed
    rate = sum(
        (sp.gas * sp.vmean * hit_rate if sp.adsorption == 0 else 0.0)
        + (
            min(sp.adsorbed + (sp.gas if sp.adsorption > 0 else 0), n_active) * sp.hop_rate
            if sp.residence == math.inf
            else 0.0
        )
        for sp in species
        if sp.name not in reacting
    )
    if rate * t_end > MAX_EVENTS:
        raise PorepipeError(
            f"the surface run would need more than {rate * t_end:.3g} events ({rate:.3g} wall hits and hop tries per "
            f"jiffie for t_end = {t_end:.4g} jiffies; at most {MAX_EVENTS:.0e}: years at ~1e6 events/s); shorten "
            "t_end (duration_jiffies) or lower the particle counts or hop rates"
        )


def _check_times(t_end, t_warm, blocks) -> None:
    """A finite run 0 <= t_warm < t_end cut into a whole number of blocks >= 1 (an infinite t_end never ends), each
    at least ``MIN_BLOCK`` t_end long.
    """
    if not (0.0 <= t_warm < t_end < math.inf) or not isinstance(blocks, int | np.integer) or blocks < 1:
        raise PorepipeError(
            f"need 0 <= t_warm < t_end < inf and a whole number of blocks >= 1, got t_warm {t_warm!r}, "
            f"t_end {t_end!r}, blocks {blocks!r}"
        )
    if (t_end - t_warm) / blocks < MIN_BLOCK * t_end:
        raise PorepipeError(
            f"t_end - t_warm = {t_end - t_warm:g} cut into {blocks} blocks gives blocks shorter than {MIN_BLOCK:g} "
            "t_end (float resolution): use fewer blocks or a shorter warmup t_warm"
        )


def _sample_times(t_samples, t_end) -> np.ndarray:
    """``t_samples`` as a 1-D array, ascending in [0, t_end] (the event loop takes them in order)."""
    samples = np.asarray(t_samples, dtype=float).reshape(-1)
    if not (np.all((samples >= 0) & (samples <= t_end)) and np.all(np.diff(samples) >= 0)):
        raise PorepipeError(
            f"t_samples must be ascending times in [0, t_end = {t_end!r}], got {samples.tolist()}"
        )
    return samples


def _summary(tally, rtally, series, final_sp, final_st, geom, n_sites, active, s, span, events) -> dict:
    n_blk, n_sp = tally.shape[0], tally.shape[1]
    blk = span / n_blk
    n_active = int(active.sum())
    cov_b = tally[:, :, S.S_ADS_T] / blk / n_active
    err = cov_b.std(axis=0, ddof=1) / math.sqrt(n_blk) if n_blk > 1 else np.full(n_sp, math.inf)
    total = tally.sum(axis=0)
    keep = final_st != S.GONE
    return {
        "coverage": cov_b.mean(axis=0),
        "coverage_err": err,
        "coverage_blocks": cov_b,
        "gas_density": total[:, S.S_GAS_T] / span / geom.pore_volume,
        "wall_hits": total[:, S.S_HITS],
        "adsorptions": total[:, S.S_ADS],
        "desorptions": total[:, S.S_DES],
        "hop_tries": total[:, S.S_HOP_TRY],
        "hops": total[:, S.S_HOP_OK],
        "lh_reactions": int(rtally[:, S.X_LH].sum()),
        "er_reactions": int(rtally[:, S.X_ER].sum()),
        "er_reverse_reactions": int(rtally[:, S.X_ER_REV].sum()),
        "lh_reverse_reactions": int(rtally[:, S.X_LH_REV].sum()),
        "side_reactions": total[:, S.S_SIDE],
        "surface_side_reactions": total[:, S.S_SURF_SIDE],
        "lh_blocks": rtally[:, S.X_LH],
        "er_blocks": rtally[:, S.X_ER],
        "blocks_tally": tally,
        "span": span,
        "series": series,
        "final_counts": np.bincount(final_sp[keep], minlength=n_sp),
        "pore_volume": geom.pore_volume,
        "sites": n_sites,
        "active_sites": n_active,
        "site_area": 1.0 / (s * s),
        "sites_per_edge": s,
        "events": int(events),
    }


# ---------------------------------------------------------------------------------------------------------------------
# analytic truths
def langmuir_coverage(k, n) -> np.ndarray:
    """Competitive Langmuir isotherm θ_X = K_X·n_X/(1 + Σ K_Y·n_Y) (one site per particle)."""
    kn = np.asarray(k, float) * np.asarray(n, float)
    return kn / (1.0 + kn.sum())


def langmuir_constant(adsorption: float, vmean: float, site_area: float, residence: float) -> float:
    """K = a·v̄·A_site·τ/4: site hits per time per unit gas density (v̄·A/4, Lambert equilibrium) × a × τ."""
    return adsorption * vmean * site_area * residence / 4.0


def _in_face_neighbours(s: int) -> np.ndarray:
    """(s, s) number of in-face neighbour sites (4 inside, 3 on an edge, 2 in a corner; 0 for s = 1)."""
    z = np.full((s, s), 4)
    z[0, :] -= 1
    z[-1, :] -= 1
    z[:, 0] -= 1
    z[:, -1] -= 1
    return z if s > 1 else np.zeros((1, 1), int)


def lh_reaction_probability(
    s: int, w: float, theta_partner: float, arrival: str, neighbours: str = "face"
) -> float:
    """Mean probability that an arrival reacts under independent Bernoulli occupation with partner coverage θ.

    ``arrival`` "adsorption": a uniform (empty) site, 1 − (1 − wθ)^z averaged over the s×s sites;
    "hop": an accepted hop from a site to a uniform neighbour, 1 − (1 − wθ)^(z_target − 1) averaged over
    the ordered neighbour pairs (source, target). ``neighbours`` "face": z of the in-face sites; "surface": z = 4.
    """
    z = _in_face_neighbours(s) if neighbours == "face" else np.full((s, s), 4)
    q = 1.0 - w * theta_partner
    if arrival == "adsorption":
        return float(np.mean(1.0 - q**z))
    if arrival != "hop":
        raise PorepipeError(f"arrival must be adsorption or hop, got {arrival!r}")
    if s < 2 and neighbours == "face":
        return 0.0
    # each target site is reached from its z neighbours: weight by z
    return float(np.sum(z * (1.0 - q ** (z - 1))) / np.sum(z))


def second_order_remaining(n_a0: float, n_b0: float, k: float, t) -> np.ndarray:
    """N_B(t) for A + B → P with −dN_B/dt = k·N_A·N_B and N_A − N_B = n_a0 − n_b0 (exact solution)."""
    t = np.asarray(t, float)
    d = n_a0 - n_b0
    if abs(d) < 1e-12 * max(n_a0, 1.0):
        return n_b0 / (1.0 + k * n_b0 * t)
    e = np.exp(-k * d * t)
    return d * n_b0 * e / (n_a0 - n_b0 * e)


def first_order_rate(w: float, vmean: float, wall_area: float, pore_volume: float) -> float:
    """Rate per particle w·v̄·S/(4V) of a wall reaction of probability w per hit (equilibrium wall flux v̄/4)."""
    return w * vmean * wall_area / (4.0 * pore_volume)


def reversible_first_order(n_total: float, k_f: float, k_r: float, t) -> np.ndarray:
    """N_A(t) for A ⇌ S with rates k_f, k_r per particle, all A at t = 0: exponential relaxation with rate k_f + k_r
    to N_A = n_total·k_r/(k_f + k_r) (so N_S/N_A → k_f/k_r).
    """
    t = np.asarray(t, float)
    eq = n_total * k_r / (k_f + k_r)
    return eq + (n_total - eq) * np.exp(-(k_f + k_r) * t)


def reversible_er_products(n_a0: float, n_b0: float, sites: float, k_f: float, k_r: float, t) -> np.ndarray:
    """N_P(t) of A(g) + B(ads) ⇌ P(g) on ``sites`` active sites, no P at t = 0 (exact Riccati solution).

    dx/dt = k_f(N_A0 − x)(N_B0 − x) − k_r·x·(M − N_B0 + x) = α(x − r₁)(x − r₂), α = k_f − k_r; r₁ is the root in
    [0, min(N_A0, N_B0)] (the equilibrium) and x = r₁(1 − E)/(1 − (r₁/r₂)E), E = exp(α(r₁ − r₂)t); written with
    q = α·r₂ so that α = 0 (linear relaxation) needs no special case.
    """
    t = np.asarray(t, float)
    beta = -k_f * (n_a0 + n_b0) - k_r * (sites - n_b0)
    gamma = k_f * n_a0 * n_b0
    alpha = k_f - k_r
    q = 0.5 * (-beta + math.sqrt(beta * beta - 4.0 * alpha * gamma))  # > 0: α·r₂
    r1 = gamma / q
    e = np.exp((alpha * r1 - q) * t)
    return r1 * (1.0 - e) / (1.0 - alpha * r1 / q * e)


def _hypergeometric_pgf(q: float, hits: float, pool: float, draws: int) -> float:
    """E[q^n] for n ~ Hypergeometric(``pool`` sites, ``hits`` marked, ``draws`` drawn), continued to real ``hits``:
    Σ_k C(draws, k)·(q − 1)^k·(hits)_k/(pool)_k with falling factorials (the factorial moments of n).
    """
    total, ratio = 0.0, 1.0
    for k in range(draws + 1):
        total += math.comb(draws, k) * (q - 1.0) ** k * ratio
        ratio *= (hits - k) / (pool - k)
    return total


def reversible_lh_products(
    n_a0: float,
    n_b0: float,
    sites: int,
    nu: tuple,
    adsorption: tuple,
    w: float,
    w_reverse: float,
    t,
    z: int = 4,
) -> np.ndarray:
    """N_P(t) of A(g) + B(ads) ⇌ P(g) through Langmuir-Hinshelwood and its reverse in the well-mixed limit.

    A and P adsorb on an empty site (probabilities ``adsorption`` = (a_A, a_P)) and leave at once (residence → 0);
    B never desorbs and hops fast enough that its N_B sites are a uniform random subset of the ``sites`` sites, each
    with ``z`` distinct neighbours. An A adsorbing on an empty site reacts when one of its n_B neighbours holding B
    takes its try (w each), a P adsorbing splits into A + B when one of its z − n_B empty neighbours takes its try
    (w_reverse each); n_B is hypergeometric. With gas wall hits ν = (ν_A, ν_P) per particle and time (v̄·S/(4V)):
    dx/dt = ν_A·(N_A0 − x)·g_A(N_B0 − x) − ν_P·x·g_P(N_B0 − x), g_A = a_A·(1 − θ)·(1 − E[(1 − w)^n_B]),
    g_P = a_P·(1 − θ)·(1 − E[(1 − w_reverse)^(z − n_B)]), θ = N_B/M; integrated to 1e-10 (solve_ivp).
    """
    from scipy.integrate import solve_ivp

    t = np.asarray(t, float)
    m = float(sites)

    def rhs(_, y):
        nb = n_b0 - y[0]
        empty = 1.0 - nb / m
        g_a = adsorption[0] * empty * (1.0 - _hypergeometric_pgf(1.0 - w, nb, m - 1.0, z))
        g_p = adsorption[1] * empty * (1.0 - _hypergeometric_pgf(1.0 - w_reverse, m - 1.0 - nb, m - 1.0, z))
        return [nu[0] * (n_a0 - y[0]) * g_a - nu[1] * y[0] * g_p]

    sol = solve_ivp(rhs, (0.0, float(t.max())), [0.0], t_eval=t, rtol=1e-10, atol=1e-8, method="LSODA")
    return sol.y[0]


def side_products_per_er(c: float, n_b0: int, n_b: int) -> tuple[float, float]:
    """Mean and variance of the side-product count of A once Eley-Rideal has taken fixed B from ``n_b0`` to ``n_b``.

    Every A hit reacts with B with probability w·N_B/n_sites and to the by-product with w_S, whatever N_A: between
    two ER events at N_B = j the side events are geometric with mean c/j, c = w_S·n_sites/w. Sum over j = n_b + 1 …
    n_b0: mean c·(H(n_b0) − H(n_b)) (→ c·ln(n_b0/n_b)), variance Σ (c/j)(1 + c/j).
    """
    m = c / np.arange(n_b + 1, n_b0 + 1, dtype=float)
    return float(m.sum()), float((m * (1.0 + m)).sum())


# ---------------------------------------------------------------------------------------------------------------------
# setup surface of the diffusion stage
def surface_result(pore, settings, voxel_um, periodic, seed: int = 0):
    """Setup ``surface``: :func:`surface_run` with ``settings.surface`` in the pore space (a DiffusionResult).

    Speeds: the species' mean speeds at ``settings.temperature_K`` relative to the fastest (v̄ = 1 voxel/jiffie).
    Values per species ``<name>_coverage`` (± ``_err``), ``<name>_gas_density`` (per voxel³), ``<name>_langmuir``
    (the competitive isotherm at the measured densities, meaningful without reactions; NaN when a species that adsorbs
    never desorbs); reaction counts and rates (LH, ER, reverse ER) and side reactions per reactant.
    """
    from porepipe.diffusion._api import DiffusionResult
    from porepipe.diffusion._species import mean_speed

    ss = settings.surface
    if not ss.species:
        raise PorepipeError("setup surface needs diffusion.surface.species (at least one)")
    speeds = [mean_speed(sp.name, settings.temperature_K) for sp in ss.species]
    species = [
        Adsorbate(
            sp.name, v / max(speeds), sp.gas, sp.adsorbed, sp.adsorption, sp.residence_jiffies, sp.hop_rate
        )
        for sp, v in zip(ss.species, speeds)
    ]
    mechanisms = [Mechanism(m.kind, m.a, m.b, m.product, m.w, m.w_reverse) for m in ss.mechanisms]
    side = [SideReaction(r.reactant, r.product, r.w, r.phase) for r in ss.side_reactions]
    t = np.linspace(0.0, ss.duration_jiffies, ss.samples) if ss.samples else ()
    run = surface_run(
        pore,
        species,
        mechanisms,
        side,
        t_end=ss.duration_jiffies,
        t_warm=ss.warmup_jiffies,
        sites_per_edge=ss.sites_per_edge,
        neighbours=ss.neighbours,
        active_fraction=ss.active_fraction,
        wall_law=settings.wall_law.value,
        residence_law=ss.residence_law,
        replenish=ss.replenish,
        blocks=ss.blocks,
        t_samples=t,
        voxel_um=voxel_um,
        periodic=periodic,
        seed=seed,
    )
    k = [
        langmuir_constant(s.adsorption, s.vmean, run["site_area"], s.residence) if s.adsorption else 0.0
        for s in species
    ]
    stationary = all(math.isfinite(x) for x in k)  # a species that never leaves fills the sites for ever
    theta = langmuir_coverage(k, run["gas_density"]) if stationary else np.full(len(species), math.nan)
    v = {"events": run["events"], "sites": run["sites"], "active_sites": run["active_sites"]}
    for x, sp in enumerate(species):
        v[f"{sp.name}_coverage"] = float(run["coverage"][x])
        v[f"{sp.name}_coverage_err"] = float(run["coverage_err"][x])
        v[f"{sp.name}_gas_density"] = float(run["gas_density"][x])
        v[f"{sp.name}_langmuir"] = float(theta[x])
    span = run["span"]
    counts = {k: run[f"{k}_reactions"] for k in ("lh", "er", "er_reverse", "lh_reverse")}
    v.update({f"{k}_reactions": n for k, n in counts.items()})
    v.update({f"{k}_rate": n / span for k, n in counts.items()})
    for x, sp in enumerate(species):
        v[f"{sp.name}_side_reactions"] = float(run["side_reactions"][x])
        v[f"{sp.name}_surface_side_reactions"] = float(run["surface_side_reactions"][x])
    arrays = {"series_counts": run["series"], "series_time_jiffies": np.asarray(t, float)}
    return DiffusionResult("surface", "-", v, arrays)
