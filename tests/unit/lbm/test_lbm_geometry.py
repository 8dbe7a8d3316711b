"""Percolation pruning against a naive flood fill; set-up bookkeeping; Darcy estimates on synthetic fields."""

import numpy as np
import pytest

from porepipe.lbm._darcy import Sampler, estimates
from porepipe.lbm._domain import build_lattice, chamber_setup, periodic_setup
from porepipe.lbm._lattice import C
from porepipe.lbm._percolation import flow_paths


def _flood(pore, seeds, periodic):
    """Breadth-first flood fill over D3Q19 links from the seed voxels (list of index tuples)."""
    seen = np.zeros(pore.shape, dtype=bool)
    stack = [s for s in seeds if pore[s]]
    for s in stack:
        seen[s] = True
    while stack:
        v = stack.pop()
        for q in range(1, 19):
            w = [v[k] + C[q, k] for k in range(3)]
            ok = True
            for k in range(3):
                if periodic[k]:
                    w[k] %= pore.shape[k]
                elif not 0 <= w[k] < pore.shape[k]:
                    ok = False
            w = tuple(w)
            if ok and pore[w] and not seen[w]:
                seen[w] = True
                stack.append(w)
    return seen


def _naive_spanning(pore, lateral_periodic):
    """Voxels from which both the inlet and the outlet face are reachable without wrapping the flow axis."""
    periodic = (False, lateral_periodic, lateral_periodic)
    inlet = [(0, j, k) for j in range(pore.shape[1]) for k in range(pore.shape[2])]
    outlet = [(pore.shape[0] - 1, j, k) for j in range(pore.shape[1]) for k in range(pore.shape[2])]
    return _flood(pore, inlet, periodic) & _flood(pore, outlet, periodic)


@pytest.mark.parametrize("lateral_periodic", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_chamber_pruning_keeps_exactly_the_spanning_clusters(lateral_periodic, seed):
    pore = np.random.default_rng(seed).random((7, 5, 5)) < 0.35
    keep, n_span = flow_paths(pore, lateral_periodic, wrap_flow_axis=False)
    np.testing.assert_array_equal(keep, _naive_spanning(pore, lateral_periodic))
    assert (n_span > 0) == bool(keep.any())


def test_periodic_pruning_keeps_dead_ends_attached_through_the_wrap():
    """A pocket touching only the outlet face is joined to the through-channel across the periodic face."""
    pore = np.zeros((6, 5, 5), dtype=bool)
    pore[:, 1, 1] = True  # through channel
    pore[4:, 3, 3] = True  # pocket at the outlet face ...
    pore[0, 2, 3] = True  # wrap partner of (5, 3, 3) along c = (1, -1, 0) ...
    pore[0, 1, 2] = True  # ... joined to the channel at (0, 1, 1) by edge and face links
    pore[2, 3, 0] = True  # isolated voxel: closed pore
    keep, n_span = flow_paths(pore, lateral_periodic=False, wrap_flow_axis=True)
    assert n_span == 1
    assert keep[5, 3, 3] and keep[4, 3, 3], "pocket linked across the periodic face must stay"
    assert not keep[2, 3, 0], "closed pore must go"
    keep_chamber, _ = flow_paths(pore, lateral_periodic=False, wrap_flow_axis=False)
    assert not keep_chamber[5, 3, 3], "in the chamber set-up only spanning clusters stay"


def test_no_path_gives_no_lattice_and_a_reason():
    pore = np.ones((6, 4, 4), dtype=bool)
    pore[3] = False
    for prep in (
        periodic_setup(pore, mirror=False, lateral_periodic=True, prune=True),
        chamber_setup(
            pore, inlet_layers=3, outlet_layers=2, force_layers=1, lateral_periodic=True, prune=True
        ),
    ):
        assert prep.lattice is None and "κ = 0" in prep.reason


def test_mirror_doubles_the_domain_and_chambers_add_open_layers():
    pore = np.random.default_rng(4).random((5, 4, 4)) < 0.8
    pore[:, 0, 0] = True
    mirrored = periodic_setup(pore, mirror=True, lateral_periodic=True, prune=False)
    np.testing.assert_array_equal(mirrored.lattice.pore, np.concatenate([pore, pore[::-1]]))
    ch = chamber_setup(
        pore, inlet_layers=4, outlet_layers=3, force_layers=2, lateral_periodic=True, prune=False
    )
    assert ch.lattice.shape == (12, 4, 4)
    assert ch.lattice.pore[:4].all() and ch.lattice.pore[9:].all()
    assert ch.lattice.sample_layers == (4, 9) and ch.lattice.force_layers == (0, 2)
    assert ch.lattice.force_nodes == (0, 32)


def _lattice_for_estimates():
    pore = np.ones((10, 3, 3), dtype=bool)
    pore[4:8, 0, :] = False  # some solid inside the sample
    return build_lattice(pore, (True, False, False), (0, 2), (3, 8)), pore


def test_pressure_gradient_methods_agree_on_a_linear_profile():
    """p linear in the layer index: methods 1-4 give the same gradient, so the same κ̂ = ν ρ̄ U / (−∇p)."""
    lat, pore = _lattice_for_estimates()
    sampler = Sampler.of(lat)
    layer = sampler.layer
    fields = np.zeros((4, lat.n_nodes))
    fields[0] = 1e-4 - 3e-6 * layer  # δρ falls by 3e-6 per layer: ∇p = −1e-6
    fields[1] = 2e-5
    nu = 0.1
    est = estimates(
        sampler,
        sampler.tables(fields),
        nu=nu,
        body_force=1e-6,
        sample_voxels=5 * 9,
        sample_area=9,
        trim_layers=1,
    )
    s_nodes = int(np.count_nonzero(pore[3:8]))
    u_mean = 2e-5 * s_nodes / 45
    rho_bar = 1 + 1e-4 - 3e-6 * (3 + 7) / 2
    for method in ("ends", "fit", "fit_trimmed", "outside"):
        assert est[f"{method}/mean"] == pytest.approx(nu * rho_bar * u_mean / 1e-6, rel=1e-9)
    rho_s = 1 + np.mean(fields[0][sampler.sample_nodes])
    q = np.mean([np.sum((1 + fields[0][layer == ell]) * 2e-5) for ell in range(3, 8)])
    assert est["ends/flux"] == pytest.approx(nu * rho_bar * q / (rho_s * 9) / 1e-6, rel=1e-9)


def test_body_force_estimate_is_nu_u_over_b():
    pore = np.ones((4, 3, 3), dtype=bool)
    lat = build_lattice(pore, (True, False, False), (0, 4), (0, 4))
    fields = np.zeros((4, lat.n_nodes))
    fields[1] = 3e-5
    sampler = Sampler.of(lat)
    est = estimates(
        sampler,
        sampler.tables(fields),
        nu=0.2,
        body_force=1e-6,
        sample_voxels=36,
        sample_area=9,
        trim_layers=0,
    )
    assert est["body_force/mean"] == pytest.approx(0.2 * 3e-5 / 1e-6, rel=1e-12)
    assert est["body_force/flux"] == pytest.approx(0.2 * 3e-5 / 1e-6, rel=1e-12)


@pytest.mark.parametrize("geometry", ["dense", "porous"])
def test_lattice_build_memory_stays_within_its_budget(geometry):
    """Peak memory of build_lattice (numpy allocations, traced) stays within 4 B per voxel (int32 node map) plus
    100 B per pore node (the full uint32 pull table, 72 B, run bounds, 9 B, and slack); what the lattice keeps is
    at most the 72 B per node of the table (porous: nearly every node irregular) and under 10 B per node for a dense
    box (its runs need no table). The former int64 node map and (N, 18) int64 run scratch peaked at 237 B per node.
    """
    import tracemalloc

    rng = np.random.default_rng(5)
    pore = np.ones((48, 48, 48), dtype=bool) if geometry == "dense" else rng.random((48, 48, 48)) < 0.5
    build_lattice(pore[:4, :4, :4], (True,) * 3, (0, 4), (0, 4))  # compile outside the trace
    tracemalloc.start()
    try:
        lat = build_lattice(pore, (True,) * 3, (0, 48), (0, 48))
        kept, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    n = lat.n_nodes
    assert peak <= 4 * pore.size + 100 * n
    assert kept <= (10 if geometry == "dense" else 76) * n


@pytest.mark.parametrize("kept", [0.3, 0.7, 1.0])
def test_irregular_columns_are_numpys_column_selection_and_c_contiguous(kept):
    # in place (most columns kept) or copied, the table is C-contiguous: the step kernel compiles once per array
    # layout, so a strided view for one geometry and a copy for another compiled it twice (~16 CPU-s each)
    from porepipe.lbm._domain import _irregular_columns

    rng = np.random.default_rng(3)
    full = rng.integers(0, 2**32, (18, 997), dtype=np.uint32)
    keep = rng.random(997) < kept
    expected = full[:, keep].copy()  # numpy's own selection
    got = _irregular_columns(full, keep)
    assert got.flags.c_contiguous and got.dtype == np.uint32
    np.testing.assert_array_equal(got, expected)
