"""Slow, obviously-right references for the minkowski kernels and weight tables (test oracles only).

None of these uses the per-cell weight tables: histograms are built with ``np.roll``, Euler numbers by counting the
vertices, edges, squares and cubes of the cubical complex of the whole volume, section Euler numbers by cutting the
volume into its lattice planes and counting each plane's complex.
"""

import numpy as np


def histogram_naive(volume, periodic):
    """Configuration histogram via 8 shifted copies of the volume (periodic: 3 flags)."""
    v = (np.asarray(volume) != 0).astype(np.int64)
    shape = [n if w else n - 1 for n, w in zip(v.shape, periodic)]
    code = np.zeros(shape, dtype=np.int64)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                shifted = np.roll(v, (-dx, -dy, -dz), axis=(0, 1, 2))
                code += shifted[: shape[0], : shape[1], : shape[2]] << (dx + 2 * dy + 4 * dz)
    return np.bincount(code.ravel(), minlength=256)


def _and_shift(v, offsets):
    """Product of v rolled by each offset (periodic), i.e. 'all these voxels are foreground'."""
    out = np.ones_like(v)
    for off in offsets:
        out = out * np.roll(v, tuple(-o for o in off), axis=(0, 1, 2))
    return out


def euler6_periodic_naive(volume):
    """χ of the cubical complex K6 of a periodic volume: #vertices - #edges + #squares - #cubes."""
    v = (np.asarray(volume) != 0).astype(np.int64)
    e = np.eye(3, dtype=int)
    edges = sum(_and_shift(v, [(0, 0, 0), e[a]]).sum() for a in range(3))
    squares = sum(
        _and_shift(v, [(0, 0, 0), e[a], e[b], e[a] + e[b]]).sum() for a, b in ((0, 1), (0, 2), (1, 2))
    )
    cube = [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    return int(v.sum() - edges + squares - _and_shift(v, cube).sum())


def euler2d_square_naive(image, adjacency8=False):
    """χ of a 2-D image (background outside) with 4- or 8-adjacency, counted on the padded plane complex."""
    a = np.pad((np.asarray(image) != 0).astype(np.int64), 1)
    if adjacency8:  # 8-adjacency = dual of the 4-complex of the complement (padded frame is one component)
        return 1 - euler2d_square_naive_complex(1 - a)
    return euler2d_square_naive_complex(a)


def euler2d_square_naive_complex(a):
    """V - E + F of the 4-adjacency complex of a (no wrap: the padded frame keeps the roll harmless)."""
    edges = (a[1:, :] * a[:-1, :]).sum() + (a[:, 1:] * a[:, :-1]).sum()
    faces = (a[1:, 1:] * a[:-1, 1:] * a[1:, :-1] * a[:-1, :-1]).sum()
    return int(a.sum() - edges + faces)


def euler2d_triangular_naive(image):
    """V - E + T of a triangular-lattice image: neighbours (1,0), (0,1), (1,-1); triangles up and down."""
    a = np.pad((np.asarray(image) != 0).astype(np.int64), 1)
    edges = (a[1:, :] * a[:-1, :]).sum() + (a[:, 1:] * a[:, :-1]).sum() + (a[1:, :-1] * a[:-1, 1:]).sum()
    up = (a[:-1, :-1] * a[1:, :-1] * a[:-1, 1:]).sum()
    down = (a[1:, :-1] * a[:-1, 1:] * a[1:, 1:]).sum()
    return int(a.sum() - edges + up + down)


def section_sums_naive(volume):
    """Σ over lattice planes of the sections' Euler numbers, for the families with normals x, (0,1,1), (1,1,1).

    ``volume`` must be surrounded by background. Returns (χ4 sum, χ8 sum) for the axis and face-diagonal families
    and the triangular χ sum for the space diagonal.
    """
    v = (np.asarray(volume) != 0).astype(np.int64)
    nx, ny, nz = v.shape
    axis4 = sum(euler2d_square_naive(v[i]) for i in range(nx))
    axis8 = sum(euler2d_square_naive(v[i], True) for i in range(nx))
    diag4 = diag8 = 0
    j = np.arange(ny)
    for m in range(ny + nz - 1):  # plane y + z = m: points (x, j, m - j)
        ok = (m - j >= 0) & (m - j < nz)
        plane = v[:, j[ok], m - j[ok]]
        diag4 += euler2d_square_naive(plane)
        diag8 += euler2d_square_naive(plane, True)
    tri = 0
    ii, jj = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    for m in range(nx + ny + nz - 2):  # plane x + y + z = m: points (i, j, m - i - j)
        k = m - ii - jj
        ok = (k >= 0) & (k < nz)
        plane = np.zeros((nx, ny), dtype=np.int64)
        plane[ok] = v[ii[ok], jj[ok], k[ok]]
        tri += euler2d_triangular_naive(plane)
    return (axis4, axis8), (diag4, diag8), tri
