"""Grey volumes: the number of a voxel's 6x6x6 sample points in the matrix (0..216), and the one writer of them.

A grey volume (``grey_a{a}.h5``) holds volume ``grey`` (uint8) and, as its root table, the grey histogram M(g, a)
(Zauner 2020, §4.7.2). Both grey stages (:mod:`porepipe.voxelize` for spheres, :mod:`porepipe.decorate` for grains)
write it with :func:`write_grey_volume`. No numba here: the constants are read by light modules too.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_attrs, read_table

__all__ = ["N_SAMPLES", "SUB", "read_grey_histogram", "write_grey_volume"]

#: sample points per voxel edge
SUB = 6
#: sample points per voxel (216): the largest grey value
N_SAMPLES = SUB**3


def write_grey_volume(
    writer: ResultWriter,
    slabs: Iterable[tuple[int, np.ndarray]],
    shape: Sequence[int],
    voxel_um: float,
    periodic: bool,
    attrs: dict,
) -> np.ndarray:
    """Write volume ``grey`` slab by slab and the grey histogram M(g, a) as the root table.

    Parameters
    ----------
    writer : ResultWriter
        The open result file.
    slabs : iterable of (int, (P, Y, Z) ndarray of uint8)
        ``(i0, slab)`` pairs: grey values of x planes ``i0 .. i0 + P - 1``.
    shape : (3,) int
        Voxels per axis of the whole volume.
    voxel_um : float
        Voxel edge a in µm.
    periodic : bool
        Whether the volume wraps across opposite faces (all three axes alike).
    attrs : dict
        Written to the table and the root (e.g. the number of spheres or grains).

    Returns
    -------
    (217,) ndarray of int64
        The histogram M(g, a), g = 0..216.
    """
    hist = np.zeros(N_SAMPLES + 1, dtype=np.int64)
    dset = writer.create_volume(
        "grey",
        shape,
        np.uint8,
        voxel_um=voxel_um,
        periodic=(periodic,) * 3,
        attrs={"meaning": "number of the 6x6x6 sample points in the matrix (0..216)"},
    )
    for i0, slab in slabs:
        dset[i0 : i0 + len(slab)] = slab
        hist += np.bincount(slab.ravel(), minlength=N_SAMPLES + 1)
    writer.write_table(
        xr.Dataset(
            {"grey_histogram": ("g", hist, {"long_name": "M(g, a)"})},
            coords={"g": np.arange(N_SAMPLES + 1)},
            attrs={"voxel_um": voxel_um, **attrs},
        )
    )
    writer.attrs.update(voxel_um=voxel_um, shape=np.asarray(shape), **attrs)
    return hist


def read_grey_histogram(path) -> tuple[np.ndarray, float]:
    """The grey histogram M(g, a) and voxel edge a (µm) of a grey volume file, refusing any other file by name.

    Parameters
    ----------
    path : path-like
        A ``grey_a{a}.h5`` written by :func:`write_grey_volume`.

    Returns
    -------
    hist : (217,) ndarray of int64
        M(g, a), g = 0..216.
    voxel_um : float
        The voxel edge a in µm.

    Raises
    ------
    PorepipeError
        The file is unreadable, or another stage's result, or lacks the histogram or ``voxel_um``.
    """
    attrs = read_attrs(path)
    table = read_table(path)
    hist = table["grey_histogram"].values if "grey_histogram" in table else None
    voxel_um = attrs.get("voxel_um")
    if hist is None or hist.shape != (N_SAMPLES + 1,) or not isinstance(voxel_um, (int, float)):
        raise PorepipeError(
            f"{path} is not a grey volume file (stage {attrs.get('stage')!r}, no {N_SAMPLES + 1}-bin "
            "grey_histogram with voxel_um); give a grey_a{a}.h5 written by voxelize or voxelize-grains"
        )
    if hist.dtype.kind not in "iu" or np.any(hist < 0):
        raise PorepipeError(
            f"{path}: grey_histogram holds {hist.dtype} or negative counts; recompute the file"
        )
    return hist.astype(np.int64), float(voxel_um)
