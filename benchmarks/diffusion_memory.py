"""Peak memory of the Knudsen engine's geometry preparation (accessible cluster, wall area, distance codes).

    python benchmarks/diffusion_memory.py            # 320^3 Boolean-sphere sample (porosity ~0.35) and an open box
    python benchmarks/diffusion_memory.py --edge 400
    python benchmarks/diffusion_memory.py --smoke    # 96^3, seconds

The volume is made and loaded first, then ``prepare`` runs in this process while a thread samples the resident set
(psutil, every millisecond); the peak above the resident set just before ``prepare`` is what the preparation needs
beyond its 1-byte input (``in_place``: as ``porepipe diffusion`` runs it, the input becomes the codes). Printed as bytes per voxel and extrapolated linearly to 1000^3 (the fill's front grows like
a surface, so it is small at any size). Writes ``diffusion_memory.json`` into ``--out`` (default
``results/benchmarks/``) and a markdown table to stdout.
"""

from __future__ import annotations

import argparse
import functools
import gc
import threading
import time

import numpy as np
import psutil
from _common import add_out_argument, write_record

from porepipe.diffusion._api import prepare


def boolean_spheres(edge: int, radius: int = 8, porosity: float = 0.35, seed: int = 0) -> np.ndarray:
    """uint8 pore volume: the complement of overlapping balls of ``radius`` voxels (porosity about ``porosity``)."""
    rng = np.random.default_rng(seed)
    n = int(-np.log(porosity) * edge**3 / (4 / 3 * np.pi * radius**3))
    r = np.arange(-radius, radius + 1)
    ball = (r[:, None, None] ** 2 + r[None, :, None] ** 2 + r[None, None, :] ** 2) <= radius * radius
    pore = np.ones((edge,) * 3, dtype=np.uint8)
    for c in rng.integers(0, edge, (n, 3)):
        lo = c - radius
        sl = tuple(slice(max(0, lo[d]), min(edge, lo[d] + 2 * radius + 1)) for d in range(3))
        bsl = tuple(slice(s.start - lo[d], s.stop - lo[d]) for d, s in enumerate(sl))
        pore[sl][ball[bsl]] = 0
    return pore


def peak_above_baseline(func) -> tuple[float, float]:
    """(peak RSS increase in bytes while ``func()`` runs, seconds)."""
    proc = psutil.Process()
    gc.collect()
    base = proc.memory_info().rss
    peak = [base]
    done = threading.Event()

    def sample():
        while not done.is_set():
            peak[0] = max(peak[0], proc.memory_info().rss)
            time.sleep(0.001)

    watcher = threading.Thread(target=sample, daemon=True)
    watcher.start()
    t0 = time.perf_counter()
    result = func()
    seconds = time.perf_counter() - t0
    done.set()
    watcher.join()
    peak[0] = max(peak[0], proc.memory_info().rss)
    del result
    return float(peak[0] - base), seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edge", type=int, default=320)
    parser.add_argument("--smoke", action="store_true", help="96^3 only")
    add_out_argument(parser)
    args = parser.parse_args()
    edge = 96 if args.smoke else args.edge
    prepare(
        np.ones((8, 8, 8), dtype=np.uint8), 1.0, (True, True, False), 2
    )  # compile outside the measurement
    rows = []
    cases = (
        ("Boolean spheres", boolean_spheres, False),
        ("open box", lambda e: np.ones((e,) * 3, np.uint8), False),
        ("Boolean spheres, in place (porepipe diffusion)", boolean_spheres, True),
    )
    for name, make, in_place in cases:
        pore = make(edge)
        porosity = float(pore.mean())
        extra, seconds = peak_above_baseline(
            functools.partial(prepare, pore, 1.0, (True, True, False), 2, in_place=in_place)
        )
        per_voxel = extra / pore.size
        rows.append(
            {
                "sample": name,
                "edge": edge,
                "porosity": porosity,
                "peak_extra_bytes_per_voxel": per_voxel,
                "prepare_s": seconds,
                "extrapolated_1000_cubed_GB": (1.0 + per_voxel) * 1e9 / 1e9,
            }
        )
        del pore
    print("| sample | edge | porosity | peak beyond input [B/voxel] | prepare [s] | 1000³ incl. input [GB] |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['sample']} | {r['edge']}³ | {r['porosity']:.3f} | {r['peak_extra_bytes_per_voxel']:.2f} | "
            f"{r['prepare_s']:.1f} | {r['extrapolated_1000_cubed_GB']:.2f} |"
        )
    write_record(args.out, "diffusion_memory.json", rows)


if __name__ == "__main__":
    main()
