"""Resolution guidance: the narrowest throat that carries flow, from the Euclidean distance map.

The critical radius r_c is the largest distance-map value d such that the pore voxels with EDT ≥ d still connect
the inlet to the outlet face (the throat every flow path must pass). With the wall halfway between a pore and a
solid node, a throat of that EDT at its centre is w = 2 r_c − 1 voxels wide (a square duct of B nodes has r_c =
(B + 1)/2 on its axis for odd B).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from porepipe.lbm._percolation import flow_paths
from porepipe.lbm._settings import Lateral, Settings

#: below this throat width (voxels) the run warns.
WARN_BELOW_VOXELS = 4.0
#: RMS relative κ̂ error of halfway bounce-back in circular ducts of diameter B ∈ [w − ½, w + ½] (steps of ¼; disc of
#: voxel centres inside B/2; TRT Λ = 3/16, τ = 0.857) against Hagen-Poiseuille B²/32, by width w in voxels. The
#: sign flips with the staircase (e.g. +25 % at B = 2, −36 % at 2.75): `python benchmarks/lbm_calibration.py
#: --throats` recomputes it; tests/validation/test_lbm_spheres.py checks the B = 4 bin.
HALFWAY_DUCT_RMS_ERROR = {2.0: 0.196, 3.0: 0.269, 4.0: 0.188, 5.0: 0.147, 6.0: 0.132, 7.0: 0.075, 8.0: 0.063}


def critical_throat(pore: np.ndarray, lateral_periodic: bool) -> float:
    """Width w = 2 r_c − 1 (voxels) of the narrowest throat along axis 0; 0 if the pore space does not span, inf if
    no solid bounds it (all pore, laterally periodic: there is no throat, and the distance map no wall to measure to).
    """
    pad = [(0, 0)] + [(0, 0) if lateral_periodic else (1, 1)] * 2
    padded = np.pad(pore, pad)
    if padded.all():
        return float("inf")
    edt = ndimage.distance_transform_edt(padded)
    edt = edt[:, 1:-1, 1:-1] if not lateral_periodic else edt
    values = np.unique(edt[pore])
    if values.size == 0 or flow_paths(pore, lateral_periodic, False)[1] == 0:
        return 0.0
    lo, hi = 0, values.size - 1  # values[lo] spans; find the largest index that does
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if flow_paths(edt >= values[mid], lateral_periodic, False)[1] > 0:
            lo = mid
        else:
            hi = mid - 1
    return float(2 * values[lo] - 1)


def expected_error(width: float) -> float:
    """RMS halfway-bounce-back κ̂ error at a throat of ``width`` voxels (:data:`HALFWAY_DUCT_RMS_ERROR`)."""
    b = np.array(sorted(HALFWAY_DUCT_RMS_ERROR))
    e = np.array([HALFWAY_DUCT_RMS_ERROR[k] for k in b])
    return float(np.interp(width, b, e))


def throat_warning(pore_internal: np.ndarray, settings: Settings, interpolated: bool) -> tuple[float, str]:
    """(throat width in voxels, warning text or "") for a sample with flow along axis 0."""
    width = critical_throat(pore_internal, settings.lateral is Lateral.periodic)
    if width <= 0 or width >= WARN_BELOW_VOXELS:
        return width, ""
    err = expected_error(width)
    walls = "interpolated walls reduce this where the geometry is known" if interpolated else "halfway walls"
    return width, (
        f"the narrowest flow-carrying throat is ~{width:.1f} voxels wide (< {WARN_BELOW_VOXELS:g}): "
        f"circular ducts that narrow are off by ±{100 * err:.0f} % (RMS) with halfway bounce-back ({walls}); "
        "use a finer resolution for an accurate κ"
    )
