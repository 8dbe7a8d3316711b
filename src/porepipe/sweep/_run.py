"""File in, compute, file out: ``sweep.h5`` (gather + extrapolation) and corner sub-samples of binary volumes."""

from __future__ import annotations

import xarray as xr

from porepipe._shared.store import ResultWriter, result_hash
from porepipe.sweep._api import build_sweep
from porepipe.sweep._crop import crop_corner
from porepipe.sweep._settings import Exponent


def run(
    inputs,
    out,
    *,
    volumes=(),
    cost_dir=None,
    exponent: Exponent | str = Exponent.free,
    confidence: float = 0.95,
    scene_name: str = "",
) -> xr.Dataset:
    """Gather every result of a scene into ``sweep.h5`` (quantity x resolution x sample size) with the limits a -> 0.

    Parameters
    ----------
    inputs : sequence of path-like
        Result files (``*_a{a}*.h5``, ``estimate.h5``).
    out : path-like
        ``sweep.h5``.
    volumes : sequence of path-like
        Grey/binary volumes behind them (upstream cost, voxel counts).
    cost_dir : path-like, optional
        Snakemake benchmark TSVs (``results/<scene>/cost``).
    exponent : Exponent or str
        Convergence exponent of the fits (``free`` or a fixed form).
    confidence : float
        Confidence level of the error bars.
    scene_name : str
        Recorded in the file.

    Returns
    -------
    xarray.Dataset
    """
    exponent = Exponent(exponent)
    ds = build_sweep(inputs, volumes, cost_dir, exponent, confidence)
    digest = result_hash(
        "sweep", inputs=sorted(inputs, key=str), exponent=exponent.value, confidence=confidence
    )
    with ResultWriter(out, stage="sweep", scene=scene_name, scene_hash=digest) as w:
        w.write_table(ds)
    return ds


def run_subsample(binary, edge_um: float, out, index: int = 0, count: int = 1) -> tuple[int, int, int]:
    """Cut sub-sample ``index`` of ``count`` cubes of edge ``edge_um`` (µm) from ``binary`` into ``out``; its shape."""
    return crop_corner(binary, edge_um, out, index=index, count=count)
