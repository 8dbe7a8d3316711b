"""The shared in-place flood fill (porepipe._shared.clusters) against an independent graph labelling.

Truth: the voxel graph built edge by edge from the neighbour steps (with periodic wrap) and labelled by scipy's
sparse ``connected_components``; spanning and largest clusters picked from those labels. Exact agreement is required
(the selection is combinatorial; only ties could differ, and they are excluded by checking the reference is unique).
"""

import itertools
import tracemalloc

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from porepipe._shared.clusters import neighbour_offsets, spanning_clusters


def _components(pore, connectivity, periodic):
    n = pore.shape
    index = np.arange(pore.size).reshape(n)
    rows, cols = [], []
    for step in neighbour_offsets(connectivity):
        src = np.ones(n, dtype=bool)
        dst = index
        for d in range(3):
            s = int(step[d])
            if s == 0:
                continue
            dst = np.roll(dst, -s, axis=d)
            if not periodic[d]:
                sl = [slice(None)] * 3
                sl[d] = slice(n[d] - 1, n[d]) if s > 0 else slice(0, 1)
                src[tuple(sl)] = False
        ok = src & pore & pore.ravel()[dst]
        rows.append(index[ok])
        cols.append(dst[ok])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(pore.size, pore.size))
    _, labels = connected_components(graph, directed=False)
    return np.where(pore, labels.reshape(n) + 1, 0)


def _reference(pore, axis, connectivity, periodic, keep, wrap):
    per = [bool(p) and d != axis for d, p in enumerate(periodic)]
    labels = _components(pore, connectivity, per)
    ids, sizes = np.unique(labels[labels > 0], return_counts=True)
    if axis is None:
        best = ids[sizes == sizes.max()]
        return (labels == best[0]) if best.size == 1 else None, ids.size
    span = np.intersect1d(np.take(labels, 0, axis=axis), np.take(labels, -1, axis=axis))
    span = span[span > 0]
    if span.size == 0:
        return np.zeros(pore.shape, bool), 0
    if keep == "largest":
        s = sizes[np.searchsorted(ids, span)]
        if np.sum(s == s.max()) > 1:
            return None, span.size
        mask = labels == span[np.argmax(s)]
    else:
        mask = np.isin(labels, span)
    if wrap:
        per[axis] = True
        wrapped = _components(pore, connectivity, per)
        mask = np.isin(wrapped, np.unique(wrapped[mask])) & pore
    return mask, span.size


@pytest.mark.parametrize(
    ("connectivity", "phi", "periodic", "axis", "keep", "wrap"),
    [
        (6, 0.62, (False, False, False), 2, "largest", False),
        (6, 0.55, (True, True, False), 2, "largest", False),
        (6, 0.6, (True, False, True), None, "largest", False),
        (18, 0.3, (False, True, True), 0, "all", False),
        (18, 0.3, (False, True, True), 0, "all", True),
        (26, 0.2, (False, False, False), 1, "all", True),
    ],
)
def test_flood_fill_matches_graph_labelling(connectivity, phi, periodic, axis, keep, wrap):
    rng = np.random.default_rng(connectivity * 100 + int(phi * 100))
    checked = 0
    for _ in range(8):
        pore = rng.random((11, 9, 13)) < phi
        ref, count_ref = _reference(pore, axis, connectivity, periodic, keep, wrap)
        if ref is None:
            continue  # two largest clusters of equal size: either is right
        mask, count = spanning_clusters(
            pore, axis, connectivity=connectivity, periodic=periodic, keep=keep, wrap_axis=wrap
        )
        assert count == count_ref
        np.testing.assert_array_equal(mask.astype(bool), ref)
        checked += 1
    assert checked >= 5


def test_in_place_and_tiny_queue_give_the_same_mask():
    # an open box: the fill's front is a whole plane (hundreds of voxels), far above any 1-entry start, so the ring
    # must grow many times and keep its order
    from porepipe._shared import _cluster_kernels as K

    pore = np.ones((24, 20, 18), dtype=np.uint8)
    state = pore.copy()
    size, low, high, queue = K.flood(
        state,
        0,
        np.arange(256) == 1,
        7,
        neighbour_offsets(6),
        np.zeros(3, bool),
        0,
        np.empty(1, np.int64),
    )
    assert (size, low, high) == (pore.size, True, True)
    assert np.all(state == 7) and queue.size >= 2
    work = (np.random.default_rng(3).random((16, 16, 16)) < 0.6).astype(np.uint8)
    copy_mask, _ = spanning_clusters(work, 2)
    same, _ = spanning_clusters(work, 2, in_place=True)
    assert same is work
    np.testing.assert_array_equal(copy_mask, work)


def test_prepare_holds_about_one_byte_per_voxel_beyond_its_input():
    """Peak numpy memory of diffusion.prepare over its input: the 1-byte codes plus small change (was 13+ B/voxel
    with int32/int64 label arrays). tracemalloc sees numpy's allocations; the fill's front (numba) is at most a few
    planes here and is measured separately in benchmarks/diffusion.py --memory.
    """
    from porepipe.diffusion import prepare

    n = 96
    pore = (np.random.default_rng(5).random((n, n, n)) < 0.7).astype(np.uint8)
    prepare(pore[:8, :8, :8], 1.0, (True, True, False), 2)  # compile outside the measurement
    tracemalloc.start()
    geom = prepare(pore, 1.0, (True, True, False), 2)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert geom.codes.nbytes == n**3
    # 1 B/voxel (codes) + 0.25 B/voxel slack for the per-layer temporaries and the inlet/outlet cell lists, plus the
    # fill's initial front ring (2**16 int64 = 0.5 MiB, a constant)
    assert peak <= 1.25 * n**3 + 2**19, f"{peak / n**3:.2f} bytes per voxel"


def test_connectivity_must_be_known():
    from porepipe._shared.errors import PorepipeError

    with pytest.raises(PorepipeError, match="connectivity must be 6, 18 or 26"):
        spanning_clusters(np.ones((2, 2, 2)), 0, connectivity=8)
    assert len(neighbour_offsets(18)) == 18
    assert {tuple(s) for s in neighbour_offsets(6)} == {
        s for s in itertools.product((-1, 0, 1), repeat=3) if sum(map(abs, s)) == 1
    }


def test_prepare_in_place_gives_the_same_geometry():
    from porepipe.diffusion import prepare

    pore = (np.random.default_rng(8).random((20, 18, 24)) < 0.65).astype(np.uint8)
    ref = prepare(pore.copy(), (1.0, 1.0, 2.0), (True, False, False), 2)
    work = pore.copy()
    got = prepare(work, (1.0, 1.0, 2.0), (True, False, False), 2, in_place=True)
    assert got.codes is work
    np.testing.assert_array_equal(got.codes, ref.codes)
    for key in ("total_porosity", "accessible_porosity", "pore_volume", "wall_area"):
        assert getattr(got, key) == getattr(ref, key)
