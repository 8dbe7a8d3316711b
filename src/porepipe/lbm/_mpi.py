"""Domain decomposition of the LBM run over processes: one process (:class:`Serial`) or MPI slabs (:class:`Slabs`).

The solver asks its decomposition for the lattice it steps, the nodes it owns, the sums and maxima over all
processes, and for its checkpoint file; with one process every answer is the trivial one. Under ``mpirun -n P``
the flow axis (axis 0, periodic in both set-ups) is cut into P slabs of whole layers holding about equal numbers of
pore nodes. Each rank builds the sparse lattice of its slab with one ghost layer on either side (the neighbours'
boundary layers, the geometry included, so bounce-back at the slab faces is the global one) and steps it with the
one-process kernel; after every step it sends the populations that cross a slab face (the five with c_x = ±1) of
its first and last layer to the neighbours' ghost layers. The ghost nodes are stepped too (two layers of waste)
but nothing reads what they compute. Every reduction sums per-layer tables, and a layer lies on one rank, so κ̂ is
the one-process κ̂ to the last bit as long as the kernel computes each node alike (it does: no node's arithmetic
depends on its neighbours' order). mpi4py is imported only when a run asks for MPI.
"""

from __future__ import annotations

import dataclasses
import re
import sys
import time
from pathlib import Path

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.lbm._darcy import Sampler
from porepipe.lbm._domain import Lattice, build_lattice
from porepipe.lbm._lattice import C

#: seconds a rank other than 0 waits, on an error every rank raises alike, for rank 0 to report it and end the run
#: (one line instead of one per rank); past it the rank reports and ends the run itself
SHARED_GRACE_S = 10.0


class SharedError(PorepipeError):
    """An error every rank of an MPI run raises alike (decided from the same reduced numbers or gathered data)."""


#: populations that cross a slab face towards higher layers (c_x = +1) and towards lower ones (c_x = −1)
UP = np.flatnonzero(C[:, 0] == 1)
DOWN = np.flatnonzero(C[:, 0] == -1)


class Serial:
    """One process: the whole lattice, reductions are the identity."""

    rank, size, root, distributed = 0, 1, True, False

    def build(self, pore, periodic, force_layers, sample_layers, window=None, *, keep_wall_links=False):
        """The lattice of the whole domain (:func:`porepipe.lbm._domain.build_lattice`)."""
        return build_lattice(
            pore, periodic, force_layers, sample_layers, window, keep_wall_links=keep_wall_links
        )

    def owned(self, lat: Lattice) -> slice:
        """The node range this process owns."""
        return slice(0, lat.n_nodes)

    def sampler(self, lat: Lattice) -> Sampler:
        """Layer layout of the owned nodes."""
        return Sampler.of(lat)

    def sum(self, value):
        """Sum over the processes (arrays element by element)."""
        return value

    def max(self, value: float) -> float:
        """Maximum over the processes."""
        return value

    def wrap(self, step):
        """The stepper with the halo exchange after every step (none with one process)."""
        return step

    def has_walls(self, lat: Lattice) -> bool:
        """Whether the domain has any bounce-back link."""
        return lat.n_wall_links > 0

    def n_nodes(self, lat: Lattice) -> int:
        """Pore nodes of the whole domain."""
        return lat.n_nodes

    def local_geometry(self, geometry):
        """The wall geometry in the coordinates of this process's lattice."""
        return geometry

    def owned_links(self, links, lat: Lattice) -> int:
        """Interpolated links of the whole domain."""
        return links.size

    def key(self) -> str:
        """The decomposition, for checkpoint keys."""
        return ""

    def checkpoint_path(self, path: Path) -> Path:
        """The checkpoint file of this process."""
        return path

    def agree(self, step: int, path: Path) -> None:
        """Check that every process resumes from the same step (one process agrees with itself)."""


#: the decomposition of a run in one process
ONE_PROCESS = Serial()


@dataclasses.dataclass
class _Halo:
    """Node ranges of the first and last owned layer and of the two ghost layers of a slab lattice."""

    n_nodes: int
    first: tuple[int, int]
    last: tuple[int, int]
    ghost_low: tuple[int, int]
    ghost_high: tuple[int, int]

    @classmethod
    def of(cls, lat: Lattice) -> _Halo:
        s = [int(x) for x in lat.layer_start]
        return cls(s[-1], (s[1], s[2]), (s[-3], s[-2]), (s[0], s[1]), (s[-2], s[-1]))


def split_layers(counts: np.ndarray, parts: int) -> np.ndarray:
    """Bounds (parts + 1,) of ``parts`` slabs of whole layers with about equal sums of ``counts`` (≥ 1 layer each)."""
    n = counts.size
    if n < parts:
        raise PorepipeError(
            f"the domain has {n} layers along the flow, fewer than the {parts} MPI ranks: run with at most {n}"
        )
    cum = np.concatenate([[0], np.cumsum(counts)])
    target = cum[-1] * np.arange(1, parts) / parts
    above = np.searchsorted(cum, target)  # first layer boundary at or past each target
    below = np.maximum(above - 1, 0)
    inner = np.where(target - cum[below] < cum[above] - target, below, above)  # the nearer boundary
    bounds = [0]
    for k, x in enumerate(inner, start=1):
        bounds.append(int(min(max(x, bounds[-1] + 1), n - (parts - k))))
    return np.array(bounds + [n])


def ghost_padded(pore: np.ndarray, a: int, b: int, periodic: bool) -> np.ndarray:
    """Layers a−1 … b of ``pore`` (wrapped if ``periodic``, else solid beyond the ends)."""
    n = pore.shape[0]
    idx = np.arange(a - 1, b + 1)
    out = pore[idx % n].copy()
    if not periodic:
        out[(idx < 0) | (idx >= n)] = False
    return out


def _local(layers, a: int, b: int) -> tuple[int, int]:
    """A global half-open layer range in the numbering of the slab [a, b) with its ghost layer first."""
    lo, hi = (min(max(x, a), b) - a + 1 for x in layers)
    return lo, hi


class Slabs:
    """MPI decomposition into slabs along the flow axis (see the module docstring)."""

    def __init__(self, comm=None):
        from mpi4py import MPI

        self.comm = comm if comm is not None else MPI.COMM_WORLD
        self.rank, self.size = self.comm.Get_rank(), self.comm.Get_size()
        self.root = self.rank == 0
        self.distributed = True
        self._proc_null = MPI.PROC_NULL
        self._max = MPI.MAX
        self.bounds = None

    def build(self, pore, periodic, force_layers, sample_layers, window=None, *, keep_wall_links=False):
        """The lattice of this rank's slab with its two ghost layers (periodic along the flow only through them)."""
        pore = np.ascontiguousarray(pore, dtype=bool)
        counts = np.count_nonzero(pore.reshape(pore.shape[0], -1), axis=1)
        self.bounds = split_layers(counts, self.size)
        a, b = (int(x) for x in self.bounds[self.rank : self.rank + 2])
        self._layout = (a, b, pore.shape[0], tuple(sample_layers), tuple(force_layers) == (0, pore.shape[0]))
        self._open = bool(pore.all()) and all(periodic)
        self._neighbours(bool(periodic[0]))
        lat = build_lattice(
            ghost_padded(pore, a, b, bool(periodic[0])),
            (False, periodic[1], periodic[2]),
            _local(force_layers, a, b),
            _local(sample_layers, a, b),
            window,
            keep_wall_links=keep_wall_links,
        )
        self._halo = _Halo.of(lat)
        return lat

    def _neighbours(self, periodic: bool) -> None:
        below, above = self.rank - 1, self.rank + 1
        if periodic:
            below, above = below % self.size, above % self.size
        self._below = below if below >= 0 else self._proc_null
        self._above = above if above < self.size else self._proc_null

    def owned(self, lat: Lattice) -> slice:
        """The nodes of the slab without its ghost layers."""
        return slice(self._halo.first[0], self._halo.last[1])

    def sampler(self, lat: Lattice) -> Sampler:
        """Global layer numbers and sample membership of the owned nodes."""
        a, b, n_layers, (s0, s1), everywhere = self._layout
        counts = np.diff(lat.layer_start)[1:-1]
        layer = np.repeat(np.arange(a, b, dtype=np.int64), counts)
        win = lat.node_window()[self.owned(lat)]
        return Sampler(layer, win & (layer >= s0) & (layer < s1), n_layers, (s0, s1), everywhere)

    def sum(self, value):
        """Sum over the ranks (arrays element by element)."""
        if np.ndim(value):
            out = np.empty_like(value)
            self.comm.Allreduce(np.ascontiguousarray(value), out)
            return out
        return self.comm.allreduce(value)

    def max(self, value: float) -> float:
        """Maximum over the ranks."""
        return self.comm.allreduce(value, op=self._max)

    def has_walls(self, lat: Lattice) -> bool:
        """Whether the whole domain has a bounce-back link (a solid voxel or a non-periodic face)."""
        return not self._open

    def n_nodes(self, lat: Lattice) -> int:
        """Pore nodes of the whole domain (the owned nodes of every rank)."""
        owned = self.owned(lat)
        return int(self.sum(owned.stop - owned.start))

    def local_geometry(self, geometry):
        """The domain's wall geometry seen from the slab lattice (its layer 0 is the domain's layer a − 1)."""
        a, _, n_layers, *_ = self._layout
        return SlabWalls(geometry, a - 1, n_layers)

    def owned_links(self, links, lat: Lattice) -> int:
        """Interpolated links of the owned nodes of every rank."""
        nodes, _ = links.nodes_and_populations()
        owned = self.owned(lat)
        return int(self.sum(int(np.count_nonzero((nodes >= owned.start) & (nodes < owned.stop)))))

    def exchange(self, pops: np.ndarray) -> None:
        """Send the crossing populations of the first and last owned layer into the neighbours' ghost layers."""
        f = pops.reshape(19, self._halo.n_nodes)
        h = self._halo
        self._shift(f, UP, h.last, self._above, h.ghost_low, self._below)
        self._shift(f, DOWN, h.first, self._below, h.ghost_high, self._above)

    def _shift(self, f, pops, send, dest, recv, source) -> None:
        out = np.ascontiguousarray(f[pops, send[0] : send[1]])
        into = np.empty((pops.size, recv[1] - recv[0]), dtype=f.dtype)
        self.comm.Sendrecv(out, dest=dest, recvbuf=into, source=source)
        if source != self._proc_null:
            f[pops, recv[0] : recv[1]] = into

    def wrap(self, step):
        """The stepper, one step at a time with the halo exchange after each."""

        def stepped(src, dst, fields, store, n):
            for s in range(n):
                a, b = (src, dst) if s % 2 == 0 else (dst, src)
                step(a, b, fields, store and s == n - 1, 1)
                self.exchange(b)

        return stepped

    def key(self) -> str:
        """Rank, size and slab bounds, for checkpoint keys."""
        return f"rank {self.rank} of {self.size}, slabs {self.bounds.tolist()}"

    def checkpoint_path(self, path: Path) -> Path:
        """``<stem>.rank<r>of<P><suffix>`` beside ``path``."""
        return rank_checkpoint(path, self.rank, self.size)

    def agree(self, step: int, path: Path) -> None:
        """Refuse to go on unless every rank resumes from the same step (−1: none resumes)."""
        steps = self.comm.allgather(step)
        if len(set(steps)) > 1:
            raise SharedError(
                f"the {self.size} ranks' checkpoints ({path.name} and its siblings) disagree: steps "
                f"{steps} (−1: none or stale); delete them or rerun with --no-resume"
            )


@dataclasses.dataclass(frozen=True)
class SlabWalls:
    """A domain's wall geometry seen from a slab lattice whose layer 0 is the domain's layer ``offset`` (wrapped)."""

    inner: object
    offset: int
    n_layers: int

    def fractions(self, nodes: np.ndarray, pops: np.ndarray) -> np.ndarray:
        """Wall distances q of the links (node voxel, population) given in slab coordinates."""
        domain = nodes.copy()
        domain[:, 0] = (domain[:, 0] + self.offset) % self.n_layers
        return self.inner.fractions(domain, pops)


def rank_checkpoint(path: Path, rank: int, size: int) -> Path:
    """The checkpoint file of rank ``rank`` of a ``size``-rank run with checkpoint name ``path``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.rank{rank}of{size}{path.suffix}")


def other_checkpoints(path: Path, size: int) -> list[Path]:
    """Checkpoints beside ``path`` of runs with another number of ranks (``size`` = 1: one process, ``path``)."""
    path = Path(path)
    pattern = re.compile(re.escape(path.stem) + r"\.rank\d+of(\d+)" + re.escape(path.suffix) + "$")
    found = [
        p for p in sorted(path.parent.glob(f"{path.stem}.rank*of*{path.suffix}")) if pattern.match(p.name)
    ]
    others = [p for p in found if size == 1 or int(pattern.match(p.name).group(1)) != size]
    return ([path] if size > 1 and path.is_file() else []) + others


def abort_world(message: str, code: int = 2, shared: bool = False) -> None:
    """Print ``message`` as this rank's one line and end every rank of the run (MPI_Abort: no rank waits for a
    dead one; the result file is written only after the last collective step, so none is left). ``shared``: every
    rank has the same error, rank 0 alone reports it (the others wait :data:`SHARED_GRACE_S` to be ended).
    """
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    if shared and world.rank != 0:
        time.sleep(SHARED_GRACE_S)
    print(f"{message} (MPI rank {world.rank} of {world.size}; ending all ranks)", file=sys.stderr, flush=True)
    world.Abort(code)


def decomposition(mpi: bool):
    """:class:`Slabs` over MPI_COMM_WORLD if ``mpi``, else :class:`Serial`; a clear error without mpi4py."""
    if not mpi:
        return Serial()
    try:
        return Slabs()
    except ImportError:
        raise PorepipeError(
            "--mpi needs mpi4py and an MPI library: pip install 'porepipe[mpi]' (and Open MPI, e.g. Debian's "
            "openmpi-bin libopenmpi-dev)"
        ) from None
