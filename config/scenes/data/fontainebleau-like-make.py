"""Make ``fontainebleau-like.xyzr``: overlapping spheres whose quartz decoration has porosity ≈ 0.135 (thesis §7.1).

Spheres (r uniform in [20, 40] µm) are placed at random in a periodic 320 µm box; a new centre closer than
0.45 (r_i + r_j) to an existing one is rejected (no grain swallows another). The count is chosen by bisection so that
the decorated model's Monte Carlo porosity (2·10^5 points) is 0.135. Run: python fontainebleau-like-make.py
"""

from pathlib import Path

import numpy as np
import yaml

from porepipe.decorate import decorate, points_in_grains
from porepipe.decorate._settings import Settings
from porepipe.voxelize import write_xyzr

HERE = Path(__file__).resolve().parent
BOX = 320.0
TARGET_PHI = 0.135


def candidates(rng, n_max=4000):
    centres, radii = [], []
    while len(radii) < n_max:
        c, r = rng.uniform(0, BOX, 3), rng.uniform(20.0, 40.0)
        if radii:
            d = np.asarray(centres) - c
            d -= BOX * np.round(d / BOX)
            if (np.linalg.norm(d, axis=1) < 0.45 * (np.asarray(radii) + r)).any():
                continue
        centres.append(c)
        radii.append(r)
    return np.array(centres), np.array(radii)


def main():
    rng = np.random.default_rng(2020)
    scene = yaml.safe_load((HERE.parent / "fontainebleau-like.yaml").read_text())
    settings = Settings(**scene["decoration"])
    centres, radii = candidates(rng, 800)
    points = rng.uniform(0, BOX, (200_000, 3))
    lo, hi = 100, len(radii)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        deco = decorate(centres[:mid], radii[:mid], settings, seed=scene["seed"])
        phi = 1 - points_in_grains(points, deco, (BOX,) * 3).mean()
        print(mid, phi)
        lo, hi = (mid, hi) if phi > TARGET_PHI else (lo, mid)
    write_xyzr(HERE / "fontainebleau-like.xyzr", centres[:hi], radii[:hi])


if __name__ == "__main__":
    main()
