"""Make ``thesis-5.6.1-{fp,pp}-sub100.xyzr``: the origin corner [0, 100]³ µm of §5.6.1's final and primary packing.

Table 5.1's a = 0.25 µm row needs 1200³ voxels of the whole 300 µm box (1.7 GB of grey values, ~15 CPU min to
voxelise per model here, times the load of a shared 2-core machine), so the sub-sample scenes ``thesis-5.6.1-sub`` /
``thesis-5.6.1-pp-sub`` voxelise 1/27 of it at a = 1, 0.5 and 0.25 µm instead. Every sphere (or periodic image of
one) that reaches into the cube is kept, with its centre as it lies, so the cube's content is exactly the packing's;
the primary packing PP is the final packing's grains (type ``grain``), which phase 2 holds frozen.

Run: python thesis-5.6.1-sub-make.py results/thesis-5.6.1/pack/packing.h5   (the packing of ``porepipe run
thesis-5.6.1``; the shipped files come from that scene at seed 7)
"""

import sys
from itertools import product
from pathlib import Path

import numpy as np

from porepipe.packing import read_packing
from porepipe.voxelize import write_xyzr

HERE = Path(__file__).resolve().parent
CUBE_UM = 100.0


def corner(centres: np.ndarray, radii: np.ndarray, box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The spheres and periodic images that reach into [0, CUBE_UM]³ (centres wrapped into the box first)."""
    c = np.mod(centres, box)
    keep_c, keep_r = [], []
    for shift in product((-1, 0), repeat=3):  # a cube at the origin sees only images shifted by -box
        s = c + np.asarray(shift) * box
        gap = np.maximum(0.0, np.maximum(-s, s - CUBE_UM))  # distance from the centre to the cube, per axis
        near = np.sqrt((gap * gap).sum(1)) < radii
        keep_c.append(s[near])
        keep_r.append(radii[near])
    return np.concatenate(keep_c), np.concatenate(keep_r)


def main(packing_h5: str) -> None:
    d = read_packing(packing_h5)
    grain = np.asarray(d["types"]) == d["type_names"].index("grain")
    for model, mask in (("fp", np.ones_like(grain)), ("pp", grain)):
        c, r = corner(np.asarray(d["centres_um"])[mask], np.asarray(d["radii_um"])[mask], d["box_um"])
        write_xyzr(HERE / f"thesis-5.6.1-{model}-sub100.xyzr", c, r)
        print(f"{model}: {len(r)} spheres reach into the {CUBE_UM:g} µm corner")


if __name__ == "__main__":
    main(*sys.argv[1:])
