"""REV sub-samples (Zauner 2020 §7.4, Table 7.4, Fig. 7.8): each quantity on the sweep's sub-samples, mean ± spread.

``sweep.subsamples: 8 | 64`` cuts that many cubes of every edge in ``sweep.sample_um``; the sweep stores their mean
(``value``), their standard deviation (``rev_spread``, ddof = 1) and their number (``rev_count``). The spread is the
thesis's REV error bar: how much a sample of that edge can differ from another of the same material.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from porepipe.report import _labels
from porepipe.sweep import FULL

#: columns of the REV table (values in the quantity's own unit)
COLUMNS = ["quantity", "unit", "a [um]", "L [um]", "sub-samples", "mean", "REV spread (std)", "whole volume"]


def rev_rows(ds: xr.Dataset) -> list[list]:
    """One row per (quantity, a, sub-sample edge) with more than one sub-sample: the mean, spread and count, and the
    whole volume's value where it was run. Duplicates (matrix twins, κ in other units) are left out.
    """
    if "rev_count" not in ds or not np.any(ds.rev_count.values > 1):
        return []
    rows = []
    for q in _labels.distinct(ds.quantity.values):
        for a in ds.a_um.values:
            for s in ds.sample_um.values:
                if s == FULL:
                    continue
                at = ds.sel(quantity=q, a_um=a, sample_um=s)
                count = int(at.rev_count) if "rev_count" in at else 0
                if count < 2 or not np.isfinite(float(at.value)):
                    continue
                whole = (
                    float(ds.value.sel(quantity=q, a_um=a, sample_um=FULL))
                    if FULL in ds.sample_um
                    else np.nan
                )
                rows.append(
                    [
                        q,
                        _labels.pretty_unit(_labels.unit_of(ds, q)),
                        float(a),
                        float(s),
                        count,
                        float(at.value),
                        float(at.rev_spread),
                        whole,
                    ]
                )
    return rows
