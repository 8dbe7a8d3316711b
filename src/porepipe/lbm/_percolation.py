"""Which pore voxels can carry flow along the flow axis (axis 0): percolation and pruning.

Connectivity is the D3Q19 link set (faces and edges, 18-neighbourhood), found by the shared in-place flood fill
(:mod:`porepipe._shared.clusters`). A cluster *spans* the sample if it
touches the first and the last layer. With a body force on every node (periodic set-up) a cluster that does
not wind around the periodic flow axis is static in steady Stokes flow (the uniform force is the gradient of a
single-valued potential on it), so dropping it is exact; such a component winds iff it contains a spanning
cluster of the unwrapped sample.
"""

from __future__ import annotations

import numpy as np

from porepipe._shared.clusters import spanning_clusters


def flow_paths(pore: np.ndarray, lateral_periodic: bool, wrap_flow_axis: bool) -> tuple[np.ndarray, int]:
    """Pore voxels that belong to flow paths along axis 0, and the number of spanning clusters.

    Parameters
    ----------
    pore : (L0, L1, L2) bool ndarray
        Pore space, flow along axis 0.
    lateral_periodic : bool
        Whether axes 1 and 2 wrap.
    wrap_flow_axis : bool
        True for the periodic body-force set-up: keep whole wrapped components that contain a spanning cluster
        (exact). False for the chamber set-up: keep only the spanning clusters themselves.

    Returns
    -------
    keep : (L0, L1, L2) bool ndarray
    n_spanning : int
    """
    keep, n_spanning = spanning_clusters(
        pore,
        0,
        connectivity=18,
        periodic=(False, lateral_periodic, lateral_periodic),
        keep="all",
        wrap_axis=wrap_flow_axis,
    )
    return keep.view(bool), n_spanning
