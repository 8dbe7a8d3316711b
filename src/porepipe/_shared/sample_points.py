"""Sample-point voxelisation: the 6x6x6 sample points of a voxel and the bit masks that count them (§4.7.2).

The library that the sphere voxeliser (:mod:`porepipe.voxelize`) and the grain voxeliser (:mod:`porepipe.decorate`)
share, so that both put sample point k (0..5) of voxel i along an axis at ``(6*i + k + 0.5) * h`` with ``h = a/6``
(:func:`sample_coord`), in exactly this order of operations — what keeps their boundary-only methods bit-identical to
brute force and to each other. Every function here is an ``@njit`` helper meant to be called from kernels (no
validation); the names are public because two stages import them.

A voxel's 216 sample points are 36 rows of 6 points along z; row q = 6·sx + sy is held in bits 6·(q mod 10) .. +5 of
uint64 word q // 10 (:data:`WORDS` words per voxel). A voxel's state while a plane is classified is
:data:`UNTOUCHED`, :data:`PARTIAL` (its mask is being filled) or :data:`FULL` (all 216 points in the matrix).
"""

import numpy as np
from numba import njit

from porepipe._shared.grey import N_SAMPLES, SUB
from porepipe._shared.numba_config import FASTMATH

__all__ = [
    "FULL",
    "FULL_ROW",
    "MARGIN",
    "N_SAMPLES",
    "PARTIAL",
    "ROWS_PER_WORD",
    "SUB",
    "UNTOUCHED",
    "WORDS",
    "axis_range",
    "grey_from_status",
    "hull_gap",
    "or_row",
    "plane_candidates",
    "popcount64",
    "sample_coord",
]

ROWS_PER_WORD = 10  # 36 rows of 6 sample points, 10 rows (60 bits) per uint64 word
WORDS = 4  # ceil(36 / 10) words per voxel
FULL_ROW = (1 << SUB) - 1
#: relative margin on squared distances for the whole-voxel shortcuts; far above rounding (1e-16), far below
#: any geometric scale, so a voxel whose sample hull is within it of the sphere surface is sampled point by point.
MARGIN = 1e-9

UNTOUCHED, PARTIAL, FULL = 0, 1, 2


@njit(cache=True, fastmath=FASTMATH, inline="always")
def sample_coord(voxel, k, h):
    """Coordinate (µm) of sample point ``k`` (0..5) of voxel ``voxel`` along one axis; ``h`` = voxel edge / 6."""
    return (SUB * voxel + k + 0.5) * h


@njit(cache=True, fastmath=FASTMATH)
def axis_range(c, r, h, n):
    """Voxels [lo, hi) whose sample-point hull can meet the interval [c - r, c + r] (hull = (6i+0.5..6i+5.5)·h)."""
    lo = int(np.floor((c - r) / (SUB * h))) - 1
    hi = int(np.floor((c + r) / (SUB * h))) + 2
    return max(lo, 0), min(hi, n)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def hull_gap(c, voxel, h):
    """Smallest and largest |p - c| over the sample hull of ``voxel`` along one axis."""
    p0 = sample_coord(voxel, 0, h)
    p1 = sample_coord(voxel, SUB - 1, h)
    # branch-free, the same value as the case split c < p0, c > p1, else 0 (the shell method of porepipe.voxelize,
    # which finds a gap per voxel row: 0.5-3 % less time there than with the branches, same run)
    near = max(max(p0 - c, c - p1), 0.0)
    far = max(abs(c - p0), abs(c - p1))
    return near, far


@njit(cache=True, fastmath=FASTMATH)
def popcount64(x):
    """Number of set bits of the uint64 ``x`` (SWAR popcount)."""
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (x * np.uint64(0x0101010101010101)) >> np.uint64(56)


@njit(cache=True, fastmath=FASTMATH)
def grey_from_status(status, mask, out):
    """Grey values of a plane: 216 for FULL voxels, the popcount of the sample mask for PARTIAL ones, else 0."""
    for j in range(status.shape[0]):
        for k in range(status.shape[1]):
            st = status[j, k]
            if st == FULL:
                out[j, k] = N_SAMPLES
            elif st == PARTIAL:
                count = 0
                for w in range(WORDS):
                    count += popcount64(mask[j, k, w])
                out[j, k] = count
            else:
                out[j, k] = 0


@njit(cache=True, fastmath=FASTMATH)
def plane_candidates(i, h, xmin_sorted, half_extent_max):
    """Sample-hull start of plane x = i and the range [first, last) of bodies whose x-extent can meet its hull.

    Parameters
    ----------
    i : int
        The voxel plane.
    h : float
        Voxel edge / 6 (µm).
    xmin_sorted : (N,) float64
        x-min (= cx - half extent) of the bodies, ascending.
    half_extent_max : float
        Largest half extent of any body (µm).

    Returns
    -------
    (float, int, int)
        x of the plane's first sample point, and first, last: the bodies ``first .. last - 1`` of the sorted order.
    """
    plane_lo = sample_coord(i, 0, h)
    plane_hi = sample_coord(i, SUB - 1, h)
    first = np.searchsorted(xmin_sorted, plane_lo - 2.0 * half_extent_max, side="left")
    last = np.searchsorted(xmin_sorted, plane_hi, side="right")
    return plane_lo, first, last


@njit(cache=True, fastmath=FASTMATH, inline="always")
def or_row(words, sx, sy, row):
    """OR the 6-bit ``row`` of sample points (sx, sy, 0..5) into a voxel's mask.

    Parameters
    ----------
    words : (WORDS,) uint64
        The voxel's sample mask; row q = 6·sx + sy occupies bits 6·(q mod 10) .. +5 of word q // 10, so a row never
        straddles two words.
    sx, sy : int
        Sample indices (0..5) along x and y.
    row : int
        Bit k set = sample point (sx, sy, k) is in the matrix; 0 leaves the mask unchanged.
    """
    if row:
        q = SUB * sx + sy
        words[q // ROWS_PER_WORD] |= np.uint64(row) << np.uint64(SUB * (q % ROWS_PER_WORD))
