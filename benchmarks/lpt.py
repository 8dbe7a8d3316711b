"""Benchmark of the lpt stage: μ(φ, L) for all positions and λ_α(φ, L) on a stride grid, on a 512³ volume.

Usage: python benchmarks/lpt.py [--n 512] [--sizes 16 32 64 128] [--lambda-cells 100000] [--threads 1 2]
       [--out DIR] [--smoke]   (writes lpt.json into --out, default results/benchmarks/)

The volume is a thresholded Gaussian random field (correlation length ~ 3 voxels, porosity 0.2), a stand-in for a
sandstone image. Prints cells per second and wall time per L and thread count, a peer comparison for the
percolation search (scipy.ndimage.label on the same cells), and writes a JSON record plus a markdown table.
Timings are taken on whatever machine runs this; on the shared development machine (2 cores, several agents at
work) they are noisy and pessimistic.
"""

from __future__ import annotations

import argparse
import platform
import time

import numba
import numpy as np
from _common import add_out_argument, write_record
from scipy import ndimage

from porepipe._shared.numba_config import set_threads
from porepipe.lpt import auto_stride, cell_grid, local_porosity_histogram, percolation_bits


def make_volume(n: int, porosity: float = 0.2, seed: int = 1) -> np.ndarray:
    field = np.random.default_rng(seed).standard_normal((n, n, n), dtype=np.float32)
    ndimage.gaussian_filter(field, 3.0, output=field, mode="wrap")
    cut = np.quantile(field[:: max(1, n // 64)], 1 - porosity)
    return (field > cut).astype(np.uint8)


def warm_up() -> None:
    pore = make_volume(16)
    h = local_porosity_histogram(pore, 4, wrap=(True,) * 3, max_bins=101, record_stride=2)
    percolation_bits(pore, 4, cell_grid(pore.shape, 4, (True,) * 3).origins(2), h.records, directions=["3"])


def peer_label_rate(pore: np.ndarray, size: int, origins: np.ndarray, budget_s: float = 10.0) -> float:
    """Cells per second for scipy.ndimage.label + face check (Λ_3) on the same cells, within a time budget."""
    t0 = time.perf_counter()
    done = 0
    for o in origins:
        cell = pore[o[0] : o[0] + size, o[1] : o[1] + size, o[2] : o[2] + size]
        labels, _ = ndimage.label(cell)
        for axis in range(3):
            near, far = np.take(labels, 0, axis=axis), np.take(labels, -1, axis=axis)
            if not np.intersect1d(near[near > 0], far[far > 0]).size:
                break
        done += 1
        if time.perf_counter() - t0 > budget_s:
            break
    return done / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--n", type=int, default=512)
    parser.add_argument("--sizes", type=int, nargs="+", default=[16, 32, 64, 128])
    parser.add_argument(
        "--lambda-cells",
        type=int,
        default=100_000,
        help="percolation cells per L up to L = 64; for larger L scaled by (64/L)^3 (same voxel work)",
    )
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    add_out_argument(parser)
    parser.add_argument("--smoke", action="store_true", help="64^3, L = 8 and 16, 2000 cells, 1 thread (CI)")
    args = parser.parse_args()
    if args.smoke:
        args.n, args.sizes, args.lambda_cells, args.threads = 64, [8, 16], 2000, [1]

    t0 = time.perf_counter()
    pore = make_volume(args.n)
    print(
        f"volume {args.n}^3, porosity {pore.mean():.4f}, built in {time.perf_counter() - t0:.1f} s; "
        f"numba {numba.__version__}, {numba.config.NUMBA_NUM_THREADS} hardware threads; "
        "NOTE: shared, loaded machine -> timings are noisy upper bounds"
    )
    warm_up()
    rows = []
    for threads in args.threads:
        set_threads(threads)
        mu_total = lam_total = 0.0
        for size in args.sizes:
            grid = cell_grid(pore.shape, size)  # cells fully inside (no wrapping): the conservative case
            stride = auto_stride(grid, max(1, int(args.lambda_cells * min(1.0, (64 / size) ** 3))))
            t = time.perf_counter()
            h = local_porosity_histogram(pore, size, max_bins=1001, record_stride=stride)
            t_mu = time.perf_counter() - t
            origins = grid.origins(stride)
            t = time.perf_counter()
            bits = percolation_bits(pore, size, origins, h.records, directions=["3"])
            t_lam = time.perf_counter() - t
            mu_total += t_mu
            lam_total += t_lam
            row = {
                "threads": threads,
                "L": size,
                "mu_cells": h.n_cells,
                "mu_s": t_mu,
                "mu_cells_per_s": h.n_cells / t_mu,
                "lambda_stride": stride,
                "lambda_cells": len(origins),
                "lambda_s": t_lam,
                "lambda_cells_per_s": len(origins) / t_lam,
                "p3": float(((bits & 8) > 0).mean()),
            }
            rows.append(row)
            print(
                f"threads {threads}  L {size:4d}  mu: {h.n_cells:11d} cells (stride 1) {t_mu:7.2f} s "
                f"{h.n_cells / t_mu / 1e6:7.1f} Mcells/s | lambda_3: {len(origins):7d} cells (stride {stride}) "
                f"{t_lam:7.2f} s {len(origins) / t_lam:9.0f} cells/s  p_3 = {row['p3']:.3f}",
                flush=True,
            )
        print(
            f"threads {threads}  total: mu {mu_total:.2f} s for {len(args.sizes)} sizes (target < 10 s), "
            f"lambda_3 {lam_total:.2f} s"
        )
    size = 64 if 64 in args.sizes else args.sizes[-1]
    grid = cell_grid(pore.shape, size)
    origins = grid.origins(auto_stride(grid, max(1, int(args.lambda_cells * min(1.0, (64 / size) ** 3)))))
    peer = peer_label_rate(pore, size, origins[:: max(1, len(origins) // 2000)])
    ours = [r for r in rows if r["L"] == size]
    print(
        f"peer: scipy.ndimage.label + face check, L = {size}: {peer:.0f} cells/s (1 thread) vs ours "
        + ", ".join(f"{r['lambda_cells_per_s']:.0f} cells/s ({r['threads']} thr)" for r in ours)
    )
    record = {
        "n": args.n,
        "porosity": float(pore.mean()),
        "machine": platform.platform(),
        "note": "shared loaded machine",
        "rows": rows,
        "peer_scipy_label_cells_per_s": peer,
        "peer_L": size,
    }
    write_record(args.out, "lpt.json", record)
    print(
        "\n| threads | L | mu cells | mu s | Mcells/s | lambda stride | lambda cells | lambda_3 s | cells/s |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['threads']} | {r['L']} | {r['mu_cells']} | {r['mu_s']:.2f} | {r['mu_cells_per_s'] / 1e6:.1f} | "
            f"{r['lambda_stride']} | {r['lambda_cells']} | {r['lambda_s']:.2f} | {r['lambda_cells_per_s']:.0f} |"
        )


if __name__ == "__main__":
    main()
