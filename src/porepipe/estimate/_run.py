"""File in, compute, file out: ``estimate.h5`` from the grey histograms of all resolutions."""

from __future__ import annotations

import xarray as xr

from porepipe._shared.grey import read_grey_histogram
from porepipe._shared.store import ResultWriter, read_attrs, result_hash
from porepipe.estimate._api import estimate_from_histograms


def run(grey_paths, out) -> xr.Dataset:
    """Write ``estimate.h5`` from the grey histograms stored in the ``grey_a{a}.h5`` files.

    Parameters
    ----------
    grey_paths : sequence of path-like
        One grey volume per resolution.
    out : path-like
        The result file.

    Returns
    -------
    xarray.Dataset
        The estimators (:func:`porepipe.estimate.estimate_from_histograms`).
    """
    attrs = [read_attrs(p) for p in grey_paths]
    hists, voxels = zip(*(read_grey_histogram(p) for p in grey_paths), strict=True)
    ds = estimate_from_histograms(list(voxels), list(hists))
    digest = result_hash("estimate", inputs=sorted(grey_paths, key=str))
    with ResultWriter(out, stage="estimate", scene=attrs[0].get("scene", ""), scene_hash=digest) as w:
        w.write_table(ds)
    return ds
