"""numba kernels of the acquisition statistics: chord lengths along lines and per-label moments."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from porepipe._shared.numba_config import FASTMATH


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _chords(vol, out):
    """Chord-length histogram of the lines along the last axis of ``vol`` (any strides).

    ``out`` (n0, 2, n_last + 1) int64 receives, per first index, counts of complete chords (runs not touching either
    end of the line) by phase (0 = value 0, 1 = non-zero) and length in voxels. Reduced by the caller.
    """
    n0, n1, n2 = vol.shape
    for i in prange(n0):
        for j in range(n1):
            start = 0
            cur = vol[i, j, 0] != 0
            for k in range(1, n2):
                v = vol[i, j, k] != 0
                if v != cur:
                    if start > 0:
                        out[i, np.int64(cur), k - start] += 1
                    start = k
                    cur = v


@njit(cache=True, fastmath=FASTMATH)
def _label_moments(labels, n_labels, out):
    """Zeroth to second moments of every label: out[l] = (n, Σx, Σy, Σz, Σxx, Σyy, Σzz, Σxy, Σxz, Σyz) (float64).

    Coordinates are voxel centres in voxel units; label 0 is background and ignored. Serial: one pass over memory.
    """
    nx, ny, nz = labels.shape
    for i in range(nx):
        x = i + 0.5
        for j in range(ny):
            y = j + 0.5
            for k in range(nz):
                lab = labels[i, j, k]
                if lab <= 0 or lab > n_labels:
                    continue
                z = k + 0.5
                row = out[lab]
                row[0] += 1.0
                row[1] += x
                row[2] += y
                row[3] += z
                row[4] += x * x
                row[5] += y * y
                row[6] += z * z
                row[7] += x * y
                row[8] += x * z
                row[9] += y * z
