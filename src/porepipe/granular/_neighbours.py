"""Broad phase (Schinner 2001, §2.4.1-2.4.2): candidate pairs for the narrow phase, as a Verlet list with a skin.

Every mobile particle is bounded by its circumscribed circle about the centroid (radius R_i, rotation-invariant),
padded by half the skin. Two particles are candidates when the padded circles overlap; the list stays valid until
some particle has moved by more than half the skin since the build. Two ways to find the candidates:

- ``cells``: a uniform cell list with cells of edge 2 max R + skin;
- ``sweep``: sort-and-sweep on the x-extents of the padded boxes, with the persistent order re-sorted by
  insertion sort at each rebuild (nearly sorted, so O(N), the thesis's argument for insertion sort), then a sweep
  that tests the y-extents and the circle distance;
- ``swap``: gc2d's incremental sort-and-sweep (§2.4.2, Tabs. 2.1/2.3): the begin/end points of the padded boxes
  are kept sorted per axis by insertion sort, and every adjacent swap updates a persistent set of box-overlapping
  pairs (end passes begin: remove; begin passes end: add if the boxes overlap on the other axis); no sweep.
  The candidates are the set's pairs whose padded circles overlap, i.e. the same list as the other two.

Walls are tested against every particle's padded box (there are few walls). The list is CSR by the lower index i,
sorted by j (walls, which have the highest indices, come last), so per-contact state can be carried over to the
next list by merging.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange, types
from numba.typed import Dict

from porepipe._shared.numba_config import FASTMATH


@njit(cache=True, fastmath=FASTMATH)
def _insertion_sort(order, key):
    """Sort ``order`` (permutation) by ``key[order]`` in place; returns the number of swaps (O(N) if nearly sorted)."""
    swaps = 0
    for a in range(1, order.shape[0]):
        o = order[a]
        k = key[o]
        b = a - 1
        while b >= 0 and key[order[b]] > k:
            order[b + 1] = order[b]
            b -= 1
            swaps += 1
        order[b + 1] = o
    return swaps


@njit(cache=True, fastmath=FASTMATH)
def _sort_rows(start, idx):
    for i in prange(start.shape[0] - 1):
        lo = start[i]
        for a in range(lo + 1, start[i + 1]):
            v = idx[a]
            b = a - 1
            while b >= lo and idx[b] > v:
                idx[b + 1] = idx[b]
                b -= 1
            idx[b + 1] = v


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _sweep_pairs(order, x, rad, active, cut, count_only, counts, offsets, pi, pj):
    """For each position a of the sorted order, the later particles whose padded x-interval starts before a's
    ends and whose padded circles overlap; counts[a] in the first pass, (pi, pj) at offsets[a] in the second.
    """
    n = order.shape[0]
    for a in prange(n):
        i = order[a]
        if active[i] == 0:
            counts[a] = 0
            continue
        hi = x[i, 0] + rad[i] + cut
        c = 0
        for b in range(a + 1, n):
            j = order[b]
            if x[j, 0] - rad[j] - cut > hi:
                break
            if active[j] == 0:
                continue
            rr = rad[i] + rad[j] + 2.0 * cut
            dy = x[j, 1] - x[i, 1]
            if abs(dy) > rr:
                continue
            dx = x[j, 0] - x[i, 0]
            if dx * dx + dy * dy <= rr * rr:
                if not count_only:
                    pi[offsets[a] + c] = min(i, j)
                    pj[offsets[a] + c] = max(i, j)
                c += 1
        counts[a] = c


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _cell_pairs(x, rad, active, cut, lo, cell, nx, ny, cstart, cidx, count_only, counts, offsets, pj):
    """Cell-list candidates of each particle i among j > i (counts[i] first, then pj at offsets[i])."""
    n = x.shape[0]
    for i in prange(n):
        if active[i] == 0:
            counts[i] = 0
            continue
        cx = min(max(int((x[i, 0] - lo[0]) / cell), 0), nx - 1)
        cy = min(max(int((x[i, 1] - lo[1]) / cell), 0), ny - 1)
        c = 0
        for ox in range(max(cx - 1, 0), min(cx + 2, nx)):
            for oy in range(max(cy - 1, 0), min(cy + 2, ny)):
                k = ox * ny + oy
                for q in range(cstart[k], cstart[k + 1]):
                    j = cidx[q]
                    if j <= i:
                        continue
                    rr = rad[i] + rad[j] + 2.0 * cut
                    dx = x[j, 0] - x[i, 0]
                    dy = x[j, 1] - x[i, 1]
                    if dx * dx + dy * dy <= rr * rr:
                        if not count_only:
                            pj[offsets[i] + c] = j
                        c += 1
        counts[i] = c


@njit(cache=True, fastmath=FASTMATH)
def _bin_cells(x, active, lo, cell, nx, ny):
    n = x.shape[0]
    cnt = np.zeros(nx * ny + 1, np.int64)
    key = np.full(n, -1, np.int64)
    for i in range(n):
        if active[i] == 0:
            continue
        cx = min(max(int((x[i, 0] - lo[0]) / cell), 0), nx - 1)
        cy = min(max(int((x[i, 1] - lo[1]) / cell), 0), ny - 1)
        key[i] = cx * ny + cy
        cnt[key[i] + 1] += 1
    for k in range(nx * ny):
        cnt[k + 1] += cnt[k]
    fill = cnt[:-1].copy()
    idx = np.empty(cnt[-1], np.int64)
    for i in range(n):
        if key[i] >= 0:
            idx[fill[key[i]]] = i
            fill[key[i]] += 1
    return cnt, idx


@njit(cache=True, fastmath=FASTMATH)
def _wall_counts(x, rad, active, cut, wall_box, counts):
    for i in range(x.shape[0]):
        c = 0
        if active[i] != 0:
            for w in range(wall_box.shape[0]):
                r = rad[i] + cut
                if (
                    x[i, 0] + r >= wall_box[w, 0]
                    and x[i, 0] - r <= wall_box[w, 1]
                    and x[i, 1] + r >= wall_box[w, 2]
                    and x[i, 1] - r <= wall_box[w, 3]
                ):
                    c += 1
        counts[i] = c


@njit(cache=True, fastmath=FASTMATH)
def _merge_lists(n, start_p, pj_p, counts_w, x, rad, active, cut, wall_box, n_mob):
    """CSR by i: particle partners (sorted) followed by wall partners (index n_mob + w)."""
    start = np.zeros(n + 1, np.int64)
    for i in range(n):
        start[i + 1] = start[i] + (start_p[i + 1] - start_p[i]) + counts_w[i]
    out = np.empty(start[n], np.int64)
    for i in range(n):
        o = start[i]
        for a in range(start_p[i], start_p[i + 1]):
            out[o] = pj_p[a]
            o += 1
        if counts_w[i] > 0:
            r = rad[i] + cut
            for w in range(wall_box.shape[0]):
                if (
                    x[i, 0] + r >= wall_box[w, 0]
                    and x[i, 0] - r <= wall_box[w, 1]
                    and x[i, 1] + r >= wall_box[w, 2]
                    and x[i, 1] - r <= wall_box[w, 3]
                ):
                    out[o] = n_mob + w
                    o += 1
    return start, out


@njit(cache=True, fastmath=FASTMATH)
def _transpose(n_mob, start, nb_j):
    """For each mobile particle, the pair indices p in which it is the partner j (sorted by the owner i)."""
    cnt = np.zeros(n_mob + 1, np.int64)
    for p in range(nb_j.shape[0]):
        j = nb_j[p]
        if j < n_mob:
            cnt[j + 1] += 1
    for k in range(n_mob):
        cnt[k + 1] += cnt[k]
    fill = cnt[:-1].copy()
    out = np.empty(cnt[-1], np.int64)
    for i in range(n_mob):
        for p in range(start[i], start[i + 1]):
            j = nb_j[p]
            if j < n_mob:
                out[fill[j]] = p
                fill[j] += 1
    return cnt, out


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _carry_state(old_start, old_j, old_ft, old_a, old_out, new_start, new_j, new_ft, new_a, new_out):
    """Copy every surviving pair's (spring, previous overlap, last forces) from the old list to the new one
    (a sorted merge per particle).
    """
    for i in prange(new_start.shape[0] - 1):
        a = old_start[i]
        ae = old_start[i + 1]
        for p in range(new_start[i], new_start[i + 1]):
            j = new_j[p]
            while a < ae and old_j[a] < j:
                a += 1
            if a < ae and old_j[a] == j:
                new_ft[p] = old_ft[a]
                new_a[p] = old_a[a]
                for c in range(new_out.shape[1]):
                    new_out[p, c] = old_out[a, c]
            else:
                new_ft[p] = 0.0
                new_a[p] = 0.0
                for c in range(new_out.shape[1]):
                    new_out[p, c] = 0.0


#: box half-widths are padded by this relative amount so that box overlap contains circle overlap despite rounding
_BOX_PAD = 1e-9
#: begin/end points of particles not in the simulation (they overlap nothing that is)
_FAR = 1e300


@njit(cache=True, fastmath=FASTMATH)
def _endpoint_values(x, rad, active, cut, axis, ep_id, ep_val, lo, hi):
    """Current begin (id 2p) and end (id 2p + 1) points of the padded boxes on one axis, in sorted-list order."""
    for p in range(x.shape[0]):
        if active[p] == 0:
            lo[p] = _FAR
            hi[p] = _FAR
        else:
            r = (rad[p] + cut) * (1.0 + _BOX_PAD)
            lo[p] = x[p, axis] - r
            hi[p] = x[p, axis] + r
    for k in range(ep_id.shape[0]):
        p = ep_id[k] >> 1
        ep_val[k] = hi[p] if ep_id[k] & 1 else lo[p]


@njit(cache=True, fastmath=FASTMATH)
def _swap_sort(ep_id, ep_val, olo, ohi, n, pairs):
    """Insertion sort of one axis's end points; each adjacent swap applies the swap rule of Tab. 2.3 to ``pairs``
    (key i * n + j, i < j), with the other axis's intervals (olo, ohi). Returns the number of swaps.
    """
    swaps = 0
    for a in range(1, ep_id.shape[0]):
        e = ep_id[a]
        v = ep_val[a]
        pe = e >> 1
        b = a - 1
        while b >= 0 and ep_val[b] > v:
            f = ep_id[b]
            pf = f >> 1
            if pe != pf:
                key = min(pe, pf) * n + max(pe, pf)
                if (e & 1) == 0 and (f & 1) == 1:  # begin of pe moves before end of pf: overlap starts
                    if olo[pe] <= ohi[pf] and olo[pf] <= ohi[pe]:
                        pairs[key] = 1
                elif (e & 1) == 1 and (f & 1) == 0 and key in pairs:  # end passes begin: overlap ends
                    del pairs[key]
            ep_id[b + 1] = f
            ep_val[b + 1] = ep_val[b]
            b -= 1
            swaps += 1
        ep_id[b + 1] = e
        ep_val[b + 1] = v
    return swaps


@njit(cache=True, fastmath=FASTMATH)
def _box_pairs_init(order, xlo, xhi, ylo, yhi, n, pairs):
    """All pairs of overlapping boxes from scratch (particles sorted by xlo): the set's starting state."""
    for a in range(order.shape[0]):
        i = order[a]
        if xlo[i] >= _FAR:
            break
        for b in range(a + 1, order.shape[0]):
            j = order[b]
            if xlo[j] > xhi[i]:
                break
            if ylo[i] <= yhi[j] and ylo[j] <= yhi[i]:
                pairs[min(i, j) * n + max(i, j)] = 1


@njit(cache=True, fastmath=FASTMATH)
def _padded_circles_meet(i, j, x, rad, active, cut):
    """Both particles active and their circles, each padded by ``cut``, overlap."""
    if active[i] == 0 or active[j] == 0:
        return False
    rr = rad[i] + rad[j] + 2.0 * cut
    dx = x[j, 0] - x[i, 0]
    dy = x[j, 1] - x[i, 1]
    return dx * dx + dy * dy <= rr * rr


@njit(cache=True, fastmath=FASTMATH)
def _swap_candidates(pairs, n, x, rad, active, cut):
    """The set's pairs whose padded circles overlap, as CSR by i (rows sorted by j)."""
    counts = np.zeros(n + 1, np.int64)
    for key in pairs:
        i = key // n
        j = key - i * n
        if _padded_circles_meet(i, j, x, rad, active, cut):
            counts[i + 1] += 1
    for k in range(n):
        counts[k + 1] += counts[k]
    fill = counts[:-1].copy()
    pj = np.empty(counts[n], np.int64)
    for key in pairs:
        i = key // n
        j = key - i * n
        if _padded_circles_meet(i, j, x, rad, active, cut):
            pj[fill[i]] = j
            fill[i] += 1
    _sort_rows(counts, pj)
    return counts, pj


class SwapState:
    """Persistent state of the ``swap`` broad phase: sorted end points per axis and the box-overlap pair set."""

    def __init__(self, n: int):
        self.n = n
        self.ready = False
        self.ep_id = [np.arange(2 * n, dtype=np.int64) for _ in range(2)]
        self.ep_val = [np.zeros(2 * n) for _ in range(2)]
        self.lo = [np.zeros(n) for _ in range(2)]
        self.hi = [np.zeros(n) for _ in range(2)]
        self.pairs = Dict.empty(key_type=types.int64, value_type=types.int64)
        self.swaps = 0

    def update(self, x, rad, active, cut):
        """Bring the end points and the pair set to the current boxes (from scratch on the first call)."""
        for axis in range(2):
            _endpoint_values(
                x, rad, active, cut, axis, self.ep_id[axis], self.ep_val[axis], self.lo[axis], self.hi[axis]
            )
        if not self.ready:
            for axis in range(2):
                o = np.argsort(self.ep_val[axis], kind="stable")
                self.ep_id[axis] = np.ascontiguousarray(self.ep_id[axis][o])
                self.ep_val[axis] = np.ascontiguousarray(self.ep_val[axis][o])
            self.pairs.clear()
            order = np.argsort(self.lo[0], kind="stable")
            _box_pairs_init(order, self.lo[0], self.hi[0], self.lo[1], self.hi[1], self.n, self.pairs)
            self.ready = True
            return
        for axis in range(2):
            other = 1 - axis
            self.swaps += _swap_sort(
                self.ep_id[axis], self.ep_val[axis], self.lo[other], self.hi[other], self.n, self.pairs
            )


def _csr_from_pairs(n, pi, pj):
    order = np.lexsort((pj, pi))
    start = np.zeros(n + 1, np.int64)
    np.add.at(start, pi + 1, 1)
    return np.cumsum(start), pj[order].astype(np.int64)


def candidate_pairs(
    method: str,
    x,
    rad,
    active,
    skin_m: float,
    wall_box,
    n_mob: int,
    order=None,
    swap: SwapState | None = None,
):
    """Candidate pair list (CSR by i, sorted by j) of the mobile particles and walls.

    Parameters
    ----------
    method : {"cells", "sweep", "swap"}
        Broad-phase algorithm.
    x : (n_mob, 2) ndarray
        Centroids in m.
    rad : (n_mob,) ndarray
        Circumscribed radii about the centroid in m.
    active : (n_mob,) uint8 ndarray
        1 for particles in the simulation (not yet inserted ones are 0).
    skin_m : float
        Verlet skin in m (circles are padded by skin/2).
    wall_box : (W, 4) ndarray
        Wall bounding boxes (x_lo, x_hi, y_lo, y_hi) in m, padded for their motion.
    n_mob : int
        Number of mobile particles (wall w has body index n_mob + w).
    order : (n_mob,) int64 ndarray, optional
        The sweep's persistent order (updated in place by insertion sort).
    swap : SwapState, optional
        The ``swap`` method's persistent end points and pair set (updated in place).

    Returns
    -------
    start : (n_mob + 1,) int64 ndarray
    partner : (P,) int64 ndarray
    """
    cut = 0.5 * skin_m
    n = x.shape[0]
    counts = np.zeros(n, np.int64)
    if n == 0:
        start_p, pj_p = np.zeros(1, np.int64), np.zeros(0, np.int64)
    elif method == "swap":
        if swap is None or swap.n != n:
            swap = SwapState(n)
        swap.update(x, rad, active, cut)
        start_p, pj_p = _swap_candidates(swap.pairs, n, x, rad, active, cut)
    elif method == "sweep":
        _insertion_sort(order, x[:, 0] - rad)
        offsets = np.zeros(n, np.int64)
        dummy = np.zeros(0, np.int64)
        _sweep_pairs(order, x, rad, active, cut, True, counts, offsets, dummy, dummy)
        offsets[1:] = np.cumsum(counts)[:-1]
        total = int(counts.sum())
        pi = np.empty(total, np.int64)
        pj = np.empty(total, np.int64)
        _sweep_pairs(order, x, rad, active, cut, False, counts, offsets, pi, pj)
        start_p, pj_p = _csr_from_pairs(n, pi, pj)
    else:
        live = active != 0
        lo = x[live].min(axis=0) if live.any() else np.zeros(2)
        hi = x[live].max(axis=0) if live.any() else np.zeros(2)
        cell = 2.0 * float(rad[live].max(initial=0.0)) + skin_m
        nx, ny = (max(1, min(int((hi[k] - lo[k]) / cell) + 1, 1 << 20)) for k in range(2))
        cstart, cidx = _bin_cells(x, active, lo, cell, nx, ny)
        offsets = np.zeros(n, np.int64)
        dummy = np.zeros(0, np.int64)
        _cell_pairs(x, rad, active, cut, lo, cell, nx, ny, cstart, cidx, True, counts, offsets, dummy)
        offsets[1:] = np.cumsum(counts)[:-1]
        pj_p = np.empty(int(counts.sum()), np.int64)
        _cell_pairs(x, rad, active, cut, lo, cell, nx, ny, cstart, cidx, False, counts, offsets, pj_p)
        start_p = np.zeros(n + 1, np.int64)
        start_p[1:] = np.cumsum(counts)
        _sort_rows(start_p, pj_p)
    counts_w = np.zeros(n, np.int64)
    _wall_counts(x, rad, active, cut, wall_box, counts_w)
    return _merge_lists(n, start_p, pj_p, counts_w, x, rad, active, cut, wall_box, n_mob)
