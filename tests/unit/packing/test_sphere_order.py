"""The engine's sphere order (``build_neighbours(reorder=True)``): a permutation, slab-tiled, the same pairs."""

import numpy as np
import pytest

from porepipe.packing._neighbours import _class_grids, _slab_ids, build_neighbours, slabs

CUT, SKIN = 1.3, 0.3


def _spheres(n, periodic, seed=5):
    """N spheres with radii log-uniform in [1, 4] µm (two radius classes) at a solid fraction of about 0.5."""
    rng = np.random.default_rng(seed)
    r = np.exp(rng.uniform(0.0, np.log(4.0), n))
    box = np.array([1.6, 1.0, 1.2]) * (np.sum(4 / 3 * np.pi * r**3) / 0.5 / 1.92) ** (1 / 3)
    x = rng.random((n, 3)) * box
    args = (np.zeros(n, np.int64), box, np.asarray(periodic), np.ones((1, 1), np.uint8), CUT, SKIN)
    return x, r, box, args


def _pairs(start, idx, ids):
    """The unordered pairs of a CSR half list as sorted (id, id) rows of the original sphere numbers."""
    i = np.repeat(np.arange(start.size - 1), np.diff(start))
    a, b = ids[i], ids[idx]
    pairs = np.column_stack([np.minimum(a, b), np.maximum(a, b)])
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


@pytest.mark.parametrize("periodic", [[True] * 3, [True, False, True]])
def test_reordered_lists_hold_the_same_pairs_in_slab_tiled_order(periodic):
    x, r, box, args = _spheres(3000, periodic)
    plain = build_neighbours(x, r, *args, half=True)
    *tiled, order = build_neighbours(x, r, *args, reorder=True, half=True)
    assert np.array_equal(np.sort(order), np.arange(r.size))  # a permutation
    # the same unordered pairs, each once, whatever the order (the list is exact: independent of the order)
    assert np.array_equal(_pairs(*plain[:2], np.arange(r.size)), _pairs(*tiled[:2], order))

    # slab-tiled: by class, then slab, then cell with the slab axis varying fastest; every slab's spheres of one
    # class form one block of consecutive indices, so the slab lists of the step kernel walk memory in order
    xo, ro = x[order], r[order]
    cls, _, side, ncell, _ = _class_grids(x, r, box, CUT, SKIN)
    cls = cls[order]
    q = np.minimum(np.floor(xo / side[cls, :3]).astype(np.int64), ncell[cls] - 1)
    s_start, s_items = slabs(xo, ro, box, periodic, CUT, SKIN)
    slab = np.repeat(np.arange(s_start.size - 1), np.diff(s_start))[np.argsort(s_items)]
    axis = _slab_ids(xo, ro, box, periodic, CUT, SKIN)[2]
    b, c = (a for a in range(3) if a != axis)
    keys = np.column_stack([cls, slab, q[:, b], q[:, c], q[:, axis]])
    assert s_start.size - 1 >= 3
    steps = np.diff(keys, axis=0)
    first_change = np.argmax(steps != 0, axis=1)
    changed = steps[np.arange(steps.shape[0]), first_change]
    assert (changed >= 0).all()  # keys never decrease lexicographically
    for c_ in np.unique(cls):
        for s in np.unique(slab[cls == c_]):
            block = np.flatnonzero((cls == c_) & (slab == s))
            assert block[-1] - block[0] + 1 == block.size
