"""The simulation domain: sparse pore-node lattice and the two set-ups (periodic body force, thesis chambers).

Internally the flow is always along axis 0; callers move the sample's flow axis there first
(D3Q19 and the three collision operators are invariant under axis permutations). Nodes are numbered in C order,
so each layer across the flow is a contiguous node range and the force zone is one range ``[force_lo, force_hi)``.
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.lbm._kernels import (
    _compact_columns,
    _gather_table,
    _node_ids,
    _runs,
    _wall_link_list,
    _wall_links,
)
from porepipe.lbm._percolation import flow_paths

#: beyond this many populations the gather index needs 64 bits
_INT32_LIMIT = 2**31 - 1
#: runs of at least this many nodes stream by offset (no index load); shorter ones use the gather table: a short
#: offset segment costs more in loop overhead than its 18 index loads (porous φ = 0.2, 128³, 1 thread: 8 -> 16 is
#: 24 -> 27 MLUPS; 16, 24, 32 and "never" agree within the noise)
MIN_RUN = 16


@dataclasses.dataclass
class Lattice:
    """Sparse D3Q19 lattice of the pore nodes of one domain (flow along axis 0).

    The pull source of population q (1..18) of node n is a flat index into the population array (bounce-back
    encoded: the node's own opposite population when the upstream node is solid). Nodes come in runs: in a regular
    run the source is ``run_offset[r, q - 1] + n`` (no table); an irregular run reads it from ``gather``, which holds
    only the irregular nodes, column ``n + run_base[r]``.

    Attributes
    ----------
    pore : (L0, L1, L2) bool ndarray
        Fluid nodes actually simulated.
    periodic : tuple of 3 bool
        Which axes wrap; a non-periodic face is a halfway bounce-back wall.
    gather : (18, N_irregular) uint32 or uint64 ndarray
        Pull sources of the nodes of the irregular runs.
    layer_start : (L0 + 1,) int64 ndarray
        Nodes of layer ℓ are ``layer_start[ℓ]:layer_start[ℓ + 1]``.
    force_layers, sample_layers : (int, int)
        Half-open layer ranges of the force zone F and the sample S.
    run_start : (R + 1,) int64 ndarray
        Node ranges ``run_start[r]:run_start[r + 1]`` (see :func:`porepipe.lbm._kernels._runs`).
    run_offset : (R, 18) int64 ndarray
        Offsets of a regular run; −1 marks an irregular run.
    run_base : (R,) int64 ndarray
        Column of node n of irregular run r in ``gather`` is ``n + run_base[r]``.
    n_wall_links : int
        Number of bounce-back links (populations whose pull source is their own node).
    window : (L1, L2) bool ndarray or None
        Part of the cross-section that belongs to S (None = all of it).
    wall_links : ((K,), (K,), (K,), (K,)) int64 ndarrays or None
        Node, population, the pull source of the opposite population (−1: solid behind) and that of the node
        behind it (−1: solid) of every bounce-back link, by node (see
        :func:`porepipe.lbm._kernels._wall_link_list`); kept only if asked for.
    """

    pore: np.ndarray
    periodic: tuple[bool, bool, bool]
    gather: np.ndarray
    layer_start: np.ndarray
    force_layers: tuple[int, int]
    sample_layers: tuple[int, int]
    run_start: np.ndarray = dataclasses.field(repr=False)
    run_offset: np.ndarray = dataclasses.field(repr=False)
    run_base: np.ndarray = dataclasses.field(repr=False)
    n_wall_links: int = 0
    window: np.ndarray | None = None
    wall_links: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = dataclasses.field(
        default=None, repr=False
    )

    @property
    def n_nodes(self) -> int:
        return int(self.layer_start[-1])

    def full_gather(self) -> np.ndarray:
        """(18, N) int64 pull source of every node (the table the runs compress; tests and diagnostics)."""
        out = np.empty((18, self.n_nodes), dtype=np.int64)
        for r in range(self.run_start.size - 1):
            a, b = int(self.run_start[r]), int(self.run_start[r + 1])
            if self.run_offset[r, 0] >= 0:
                out[:, a:b] = self.run_offset[r][:, None] + np.arange(a, b)
            else:
                out[:, a:b] = self.gather[:, a + self.run_base[r] : b + self.run_base[r]]
        return out

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(int(s) for s in self.pore.shape)

    @property
    def force_nodes(self) -> tuple[int, int]:
        lo, hi = self.force_layers
        return int(self.layer_start[lo]), int(self.layer_start[hi])

    @property
    def body_force_everywhere(self) -> bool:
        return self.force_layers == (0, self.shape[0])

    def node_window(self) -> np.ndarray:
        """(N,) bool: node lies in the sample's lateral window."""
        if self.window is None:
            return np.ones(self.n_nodes, dtype=bool)
        return np.broadcast_to(self.window, self.pore.shape)[self.pore]

    def key(self) -> str:
        """Hash of the geometry (for checkpoints)."""
        h = hashlib.sha256(np.packbits(self.pore).tobytes())
        h.update(repr((self.shape, self.periodic, self.force_layers, self.sample_layers)).encode())
        if self.window is not None:
            h.update(np.packbits(self.window).tobytes())
        return h.hexdigest()[:16]


def build_lattice(
    pore: np.ndarray, periodic, force_layers, sample_layers, window=None, *, keep_wall_links: bool = False
) -> Lattice:
    """Number the pore nodes and build the pull/bounce-back tables (runs + gather table of the irregular runs).

    Parameters
    ----------
    pore : (L0, L1, L2) bool ndarray
        Fluid nodes; flow along axis 0.
    periodic : 3 bools
        Wrapping axes (non-periodic faces are walls halfway outside the last node).
    force_layers, sample_layers : (int, int)
        Half-open layer ranges of the force zone and of the sample.
    window : (L1, L2) bool ndarray, optional
        Lateral part of the sample used for averages.
    keep_wall_links : bool
        Also list the bounce-back links (for interpolated walls).
    """
    pore = np.ascontiguousarray(pore, dtype=bool)
    if pore.ndim != 3 or min(pore.shape) < 1:
        raise PorepipeError(f"pore volume must be 3-D with positive sizes, got shape {pore.shape}")
    full = _full_gather(pore, periodic)
    start, offset = _node_runs(full)
    lengths = np.diff(start)
    irregular = offset[: lengths.size, 0] < 0
    base = np.zeros(lengths.size, dtype=np.int64)
    base[irregular] = np.cumsum(lengths * irregular)[irregular] - lengths[irregular] - start[:-1][irregular]
    walls = int(_wall_links(full))
    links = _list_wall_links(full, walls) if keep_wall_links else None
    gather = _irregular_columns(full, np.repeat(irregular, lengths))
    del full
    counts = np.count_nonzero(pore.reshape(pore.shape[0], -1), axis=1)
    layer_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return Lattice(
        pore,
        tuple(bool(p) for p in periodic),
        gather,
        layer_start,
        (int(force_layers[0]), int(force_layers[1])),
        (int(sample_layers[0]), int(sample_layers[1])),
        start,
        offset,
        base,
        walls,
        window,
        links,
    )


def _list_wall_links(full: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    node, pop, behind, far = (np.empty(count, dtype=np.int64) for _ in range(4))
    _wall_link_list(full, node, pop, behind, far)
    return node, pop, behind, far


def _full_gather(pore: np.ndarray, periodic) -> np.ndarray:
    """(18, N) pull-source table of every pore node (uint32 when 19 N fits, else uint64).

    The voxel → node map is int32 (4 B per voxel) unless the volume has 2³¹ voxels or more.
    """
    ids = np.empty(pore.size, dtype=np.int32 if pore.size <= _INT32_LIMIT else np.int64)
    n = int(_node_ids(pore.reshape(-1), ids))
    # unsigned: numba skips its negative-index wrap-around test, so the gather loop vectorises (2x faster)
    index_dtype = np.uint32 if 19 * n <= _INT32_LIMIT else np.uint64
    full = np.empty((18, n), dtype=index_dtype)
    if n:
        _gather_table(
            ids.reshape(pore.shape),
            np.array(pore.shape, dtype=np.int64),
            np.array([bool(p) for p in periodic]),
            n,
            full,
        )
    return full


def _irregular_columns(full: np.ndarray, irregular: np.ndarray) -> np.ndarray:
    """The columns of the irregular nodes, C-contiguous either way (the step kernel compiles once per array layout):
    packed in place into the front of the table (no second table) when they are most of it, else copied so that the
    full table can be freed.
    """
    k = int(np.count_nonzero(irregular))
    if 2 * k > full.shape[1]:
        _compact_columns(full, irregular)
        return full.reshape(-1)[: full.shape[0] * k].reshape(full.shape[0], k)
    return np.ascontiguousarray(full[:, irregular])


def _node_runs(full: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(run_start (R + 1,), run_offset (R, 18)) of a full pull-source table (one row per run, −1 = irregular)."""
    n = full.shape[1]
    start = np.empty(n + 1, dtype=np.int64)
    regular = np.empty(max(n, 1), dtype=np.bool_)
    r = int(_runs(full, MIN_RUN, start, regular))
    start, regular = start[: r + 1].copy(), regular[:r]
    offset = np.full((max(r, 1), 18), -1, dtype=np.int64)
    heads = start[:r][regular]
    offset[:r][regular] = full[:, heads].T.astype(np.int64) - heads[:, None]
    return start, offset


@dataclasses.dataclass
class Prepared:
    """A set-up ready to run, or the reason it need not run."""

    lattice: Lattice | None
    sample_voxels: int  # |S|, solid included (denominator of the superficial velocity)
    sample_area: int  # voxels in one cross-section of S
    n_spanning: int
    pruned_nodes: int
    reason: str = ""


def _prune(sample: np.ndarray, lateral_periodic: bool, wrap: bool, enabled: bool):
    keep, n_span = flow_paths(sample, lateral_periodic, wrap)
    if not enabled:
        keep = sample
    return keep, n_span, int(np.count_nonzero(sample)) - int(np.count_nonzero(keep))


def periodic_setup(
    sample: np.ndarray,
    *,
    mirror: bool,
    lateral_periodic: bool,
    prune: bool,
    keep_wall_links: bool = False,
    build=build_lattice,
) -> Prepared:
    """Body force on every node, periodic along the flow (optionally sample + its mirror image).

    ``build``: the lattice builder (:func:`build_lattice`, or a process's slab of it, :mod:`porepipe.lbm._mpi`).
    """
    domain = np.concatenate([sample, sample[::-1]], axis=0) if mirror else sample
    keep, n_span, pruned = _prune(domain, lateral_periodic, True, prune)
    area = domain.shape[1] * domain.shape[2]
    if n_span == 0:
        return Prepared(
            None,
            domain.size,
            area,
            0,
            0,
            reason="no pore path connects the inlet face to the outlet face: κ = 0",
        )
    lat = build(
        keep,
        (True, lateral_periodic, lateral_periodic),
        (0, domain.shape[0]),
        (0, domain.shape[0]),
        keep_wall_links=keep_wall_links,
    )
    return Prepared(lat, domain.size, area, n_span, pruned)


def chamber_setup(
    sample: np.ndarray,
    *,
    inlet_layers: int,
    outlet_layers: int,
    force_layers: int,
    lateral_periodic: bool,
    prune: bool,
    keep_wall_links: bool = False,
    build=build_lattice,
) -> Prepared:
    """Thesis §6.1.4: open inlet chamber (force zone in its first layers), sample, open outlet chamber."""
    keep, n_span, pruned = _prune(sample, lateral_periodic, False, prune)
    area = sample.shape[1] * sample.shape[2]
    if n_span == 0:
        return Prepared(
            None,
            sample.size,
            area,
            0,
            0,
            reason="no pore path connects the inlet face to the outlet face: κ = 0",
        )
    cross = sample.shape[1:]
    domain = np.concatenate(
        [np.ones((inlet_layers, *cross), bool), keep, np.ones((outlet_layers, *cross), bool)], axis=0
    )
    lat = build(
        domain,
        (True, lateral_periodic, lateral_periodic),
        (0, force_layers),
        (inlet_layers, inlet_layers + sample.shape[0]),
        keep_wall_links=keep_wall_links,
    )
    return Prepared(lat, sample.size, area, n_span, pruned)
