"""Make config/scenes/data/image-to-model.tif: a small synthetic "µ-CT" image for the image-to-model scene.

Independent of porepipe (NumPy + SciPy + tifffile only): random sequential addition of spheres, radii uniform in
[8, 14] µm, each new sphere overlapping an existing one by at most 30 % of the smaller radius (20000 tries
in all); rendered at 2 µm voxels (64³), grains bright (170), pore dark (60), blurred (σ = 0.7 voxel) with Gaussian
noise (σ = 8 grey levels), as 8-bit ImageJ TIFF with its voxel size in the metadata. Run:
    python config/scenes/data/image-to-model_make.py
"""

from pathlib import Path

import numpy as np
import tifffile
from scipy import ndimage

VOXEL_UM = 2.0
N = 64
R_MIN_UM, R_MAX_UM, MAX_OVERLAP = 8.0, 14.0, 0.3


def spheres(rng, box_um, tries=20000):
    centres, radii = np.empty((0, 3)), np.empty(0)
    for _ in range(tries):
        r = rng.uniform(R_MIN_UM, R_MAX_UM)
        c = rng.uniform(0, box_um, 3)
        d = np.abs(centres - c)
        d = np.linalg.norm(np.minimum(d, box_um - d), axis=1)  # periodic distance
        if np.all(d >= r + radii - MAX_OVERLAP * np.minimum(r, radii)):
            centres, radii = np.vstack([centres, c]), np.append(radii, r)
    return centres, radii


def render(centres, radii, box_um):
    x = (np.arange(N) + 0.5) * VOXEL_UM
    solid = np.zeros((N, N, N), bool)
    for c, r in zip(centres, radii):
        d2 = np.zeros((N, N, N))
        for ax in range(3):
            dx = np.abs(x - c[ax])
            dx = np.minimum(dx, box_um - dx)
            d2 = d2 + (dx**2).reshape([-1 if i == ax else 1 for i in range(3)])
        solid |= d2 <= r * r
    return solid


def main(out=Path(__file__).with_name("image-to-model.tif"), seed=2020):
    rng = np.random.default_rng(seed)
    box_um = N * VOXEL_UM
    solid = render(*spheres(rng, box_um), box_um)
    grey = ndimage.gaussian_filter(np.where(solid, 170.0, 60.0), 0.7) + rng.normal(0, 8, solid.shape)
    grey = np.clip(np.rint(grey), 0, 255).astype(np.uint8)
    # TIFF pages are z, rows y, columns x
    tifffile.imwrite(
        out,
        grey.transpose(2, 1, 0),
        imagej=True,
        resolution=(1 / VOXEL_UM, 1 / VOXEL_UM),
        metadata={"spacing": VOXEL_UM, "unit": "um"},
        compression="zlib",
    )
    print(f"{out}: porosity {1 - solid.mean():.4f}, {N}^3 voxels of {VOXEL_UM} µm")


if __name__ == "__main__":
    main()
