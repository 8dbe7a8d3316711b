"""Slow, obviously-right references for the grain voxeliser: every sample point of every voxel against every grain
image (all 27 periodic shifts), with the same floating-point expression as the kernels."""

import itertools

import numpy as np

from porepipe.decorate import world_grains
from porepipe.decorate._kernels import KIND_SPHERE


def sample_coords(n, voxel_um):
    """(6 n,) sample coordinates (6 i + k + 0.5) · (a / 6), computed as the kernels do."""
    h = voxel_um / 6
    i = np.repeat(np.arange(n), 6)
    k = np.tile(np.arange(6), n)
    return (6 * i + k + 0.5) * h


def naive_grey(deco, box_um, voxel_um, periodic=True):
    shape = [round(b / voxel_um) for b in box_um]
    xs, ys, zs = (sample_coords(n, voxel_um) for n in shape)
    world = world_grains(deco)
    inside = np.zeros((len(xs), len(ys), len(zs)), dtype=bool)
    shifts = list(itertools.product((-1, 0, 1), repeat=3)) if periodic else [(0, 0, 0)]
    for g in range(len(deco)):
        for s in shifts:
            c = deco.centres_um[g] + np.array(s) * np.asarray(box_um)
            dx = (xs - c[0])[:, None, None]
            dy = (ys - c[1])[None, :, None]
            dz = (zs - c[2])[None, None, :]
            if world.kind[g] == KIND_SPHERE:
                r = world.radius[g]
                hit = (dx * dx + dy * dy) + dz * dz <= r * r
            else:
                hit = np.ones_like(inside)
                for n0, n1, n2, d in world.planes[world.plane_ptr[g] : world.plane_ptr[g + 1]]:
                    hit &= (n0 * dx + n1 * dy) + n2 * dz <= d
            inside |= hit
    return inside.reshape(shape[0], 6, shape[1], 6, shape[2], 6).sum(axis=(1, 3, 5)).astype(np.uint8)
