"""The MPI decomposition's pure parts, without MPI: slab bounds, ghost layers, checkpoint names, a missing mpi4py."""

import sys

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.lbm._mpi import decomposition, ghost_padded, other_checkpoints, rank_checkpoint, split_layers


def test_slabs_hold_about_equal_node_counts_and_at_least_one_layer():
    counts = np.array([10, 0, 0, 10, 10, 10, 40, 0])
    bounds = split_layers(counts, 3)
    assert bounds[0] == 0 and bounds[-1] == counts.size and np.all(np.diff(bounds) >= 1)
    per_slab = np.add.reduceat(counts, bounds[:-1])
    assert per_slab.sum() == counts.sum() and per_slab.max() <= 40  # the 40-node layer alone is one third
    assert split_layers(np.zeros(4, dtype=int), 4).tolist() == [0, 1, 2, 3, 4]  # no nodes: one layer each


def test_more_ranks_than_layers_is_refused_with_both_numbers():
    with pytest.raises(PorepipeError, match="has 3 layers along the flow, fewer than the 4 MPI ranks"):
        split_layers(np.ones(3), 4)


def test_ghost_layers_are_the_neighbouring_layers_wrapped_or_solid():
    pore = np.arange(5)[:, None, None] * np.ones((1, 2, 2), dtype=int) % 2 == 1  # layers 1 and 3 are pore
    wrapped = ghost_padded(pore, 0, 2, periodic=True)
    assert [bool(layer.all()) for layer in wrapped] == [False, False, True, False]  # layers 4, 0, 1, 2
    open_ends = ghost_padded(pore, 3, 5, periodic=False)
    assert [bool(layer.any()) for layer in open_ends] == [False, True, False, False]  # 2, 3, 4, outside


def test_checkpoints_of_another_decomposition_are_found(tmp_path):
    base = tmp_path / "c.h5"
    assert rank_checkpoint(base, 1, 12).name == "c.rank1of12.h5"
    for rank in range(2):
        rank_checkpoint(base, rank, 12).write_text("")
    assert other_checkpoints(base, 2) == [
        tmp_path / "c.rank0of12.h5",
        tmp_path / "c.rank1of12.h5",
    ]  # not "of2"
    assert other_checkpoints(base, 12) == []
    base.write_text(
        ""
    )  # a one-process checkpoint: another decomposition for any MPI run, not for one process
    assert other_checkpoints(base, 12) == [base]
    assert len(other_checkpoints(base, 1)) == 2


def test_mpi_without_mpi4py_is_one_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "mpi4py", None)  # import mpi4py raises ImportError
    with pytest.raises(PorepipeError, match=r"--mpi needs mpi4py .*pip install 'porepipe\[mpi\]'"):
        decomposition(True)
    assert decomposition(False).size == 1
