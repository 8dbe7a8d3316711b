"""Throughput of the 2x2x2 configuration histogram (the one pass behind all Minkowski functionals).

Prints Mvoxel/s on a 512³ binary volume at 1 and 2 threads, next to the time to merely read the volume once
(memory-bandwidth floor), a plain numpy configuration histogram, and a peer tool (quantimpy, if installed) on a
smaller volume. Timings come from a shared, loaded machine (several agents on 2 cores): best of ``--repeat`` runs.
Writes ``minkowski.json`` into ``--out`` (default ``results/benchmarks/``) and a markdown table to stdout.

    python benchmarks/minkowski.py [--n 512] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np
from _common import add_out_argument, write_record

from porepipe.minkowski import configuration_histogram
from porepipe.minkowski._kernels import _touch_all


def best_of(fn, repeat):
    fn()  # compile / warm caches
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def numpy_histogram(volume):
    """Plain numpy configuration histogram (8 shifted views summed into a uint8 code, then bincount)."""
    v = volume.view(np.uint8)
    code = np.zeros(tuple(n - 1 for n in v.shape), np.uint8)
    for b in range(8):
        dx, dy, dz = b & 1, (b >> 1) & 1, (b >> 2) & 1
        code |= v[dx : dx + code.shape[0], dy : dy + code.shape[1], dz : dz + code.shape[2]] << b
    return np.bincount(code.ravel(), minlength=256)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=3)
    add_out_argument(parser)
    parser.add_argument("--smoke", action="store_true", help="64^3, one repeat (CI)")
    args = parser.parse_args()
    if args.smoke:
        args.n, args.repeat = 64, 1
    rng = np.random.default_rng(0)
    # a porous-medium-like volume: smoothed noise thresholded at porosity 0.2 (pure cells dominate, as in rock)
    small = rng.random((args.n // 8,) * 3)
    volume = (np.kron(small, np.ones((8, 8, 8))) + 0.3 * rng.random((args.n,) * 3) < 0.35).astype(np.uint8)
    nvox = volume.size
    rows = []
    for threads in (1, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        t_hist = best_of(lambda: configuration_histogram(volume, True), args.repeat)
        t_read = best_of(lambda threads=threads: _touch_all(volume, threads), args.repeat)
        rows.append(
            {
                "tool": "porepipe configuration_histogram",
                "threads": threads,
                "seconds": t_hist,
                "mvox_per_s": nvox / t_hist / 1e6,
                "read_once_mvox_per_s": nvox / t_read / 1e6,
            }
        )
    t_np = best_of(lambda: numpy_histogram(volume), 1)
    rows.append(
        {
            "tool": "numpy (8 shifted views + bincount)",
            "threads": 1,
            "seconds": t_np,
            "mvox_per_s": nvox / t_np / 1e6,
            "read_once_mvox_per_s": None,
        }
    )
    try:
        from quantimpy import minkowski as qmk

        m = min(args.n, 256)
        sub = volume[:m, :m, :m].astype(bool)
        t_q = best_of(lambda: qmk.functionals(sub), 1)
        numba.set_num_threads(1)
        t_ours = best_of(lambda: configuration_histogram(sub, False), args.repeat)
        rows.append(
            {
                "tool": f"quantimpy.minkowski.functionals ({m}³)",
                "threads": 1,
                "seconds": t_q,
                "mvox_per_s": sub.size / t_q / 1e6,
                "read_once_mvox_per_s": None,
                "porepipe_same_volume_mvox_per_s": sub.size / t_ours / 1e6,
            }
        )
    except ImportError:
        rows.append({"tool": "quantimpy not installed", "threads": None, "seconds": None, "mvox_per_s": None})
    print(
        f"# minkowski benchmark, {args.n}³ uint8 volume (shared, loaded 2-core machine; best of {args.repeat})\n"
    )
    print("| tool | threads | s | Mvoxel/s | read-once floor Mvoxel/s |")
    print("|---|---|---|---|---|")
    for r in rows:
        fmt = lambda v, f: "-" if v is None else format(v, f)  # noqa: E731
        extra = (
            f" (porepipe on the same volume: {r['porepipe_same_volume_mvox_per_s']:.0f})"
            if "porepipe_same_volume_mvox_per_s" in r
            else ""
        )
        print(
            f"| {r['tool']}{extra} | {fmt(r['threads'], 'd')} | {fmt(r['seconds'], '.3f')} | "
            f"{fmt(r['mvox_per_s'], '.0f')} | {fmt(r.get('read_once_mvox_per_s'), '.0f')} |"
        )
    write_record(args.out, "minkowski.json", {"n": args.n, "rows": rows})


if __name__ == "__main__":
    main()
