"""LBM throughput: MLUPS (pore-node updates per second) against the memory-bandwidth bound.

For BGK / TRT / MRT in float64 and float32 at 1 and 2 threads, on a dense 128³ box and on a porous 128³ sample
(overlapping spheres, porosity ≈ 0.2, only the percolating pore nodes stored). The bound is the measured
STREAM-like copy bandwidth (read + write bytes per second, numba kernel at the same thread count) divided by the
bytes per update: 304 B (float64) or 152 B (float32) — 19 populations read and written. Nodes in regular runs
(all 18 pull sources advance with the node: nearly all of a dense box) stream by offset and read no index; the
others also read 18 uint32 neighbour indices (72 B), which the bound does not count. Population arrays larger
than the cache are written with non-temporal stores, so the kernel can beat a cached copy.
If lbmpy is installed, its D3Q19 SRT kernel runs on the same dense box in the same process for comparison.
The cost of interpolated walls: TRT float64 on the porous sample with halfway bounce-back and with CLI interpolated
walls at the exact sphere surfaces (extra work only at the boundary links), per step and per boundary link.

Timings come from a shared, loaded 2-core machine: treat them as lower bounds of what the code can do. Each row also
gives MLUPS per CPU second of the process (best of the repeats), which other jobs on the machine disturb far less.

Usage: python benchmarks/lbm.py [--size 128] [--steps 10] [--out DIR]
Writes lbm_benchmark.json and lbm_benchmark.md into --out (default: results/benchmarks/ of the checkout).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numba
import numpy as np
from _common import add_out_argument
from numba import njit, prange
from scipy import ndimage

from porepipe.lbm import Settings, SphereWalls, Walls
from porepipe.lbm._domain import build_lattice, periodic_setup
from porepipe.lbm._solver import make_stepper
from porepipe.lbm._walls import build_links

BYTES = {"float64": 304, "float32": 152}


@njit(parallel=True, cache=True)
def _copy(a, b):
    for i in prange(a.size):
        b[i] = a[i]


def bandwidth_gbs(threads: int, n: int = 2**25, repeats: int = 7) -> float:
    """STREAM-like copy bandwidth (2 × bytes / s) of a numba kernel with ``threads`` threads, best of repeats."""
    numba.set_num_threads(threads)
    a = np.ones(n)
    b = np.empty_like(a)
    _copy(a, b)
    best = 0.0
    for _ in range(repeats):
        t0 = time.perf_counter()
        _copy(a, b)
        best = max(best, 2 * a.nbytes / (time.perf_counter() - t0) / 1e9)
    return best


def porous_sample(
    size: int, porosity: float = 0.2, radius: float = 6.0, seed: int = 11, spheres: bool = False
):
    """Pore space of a Boolean model of overlapping spheres (periodic), porosity ≈ ``porosity``; with ``spheres``
    also the spheres themselves (SphereWalls: centres at the seed voxels' centres, the model's radius).
    """
    rng = np.random.default_rng(seed)
    count = int(-np.log(porosity) / (4 / 3 * np.pi * radius**3) * size**3)
    seeds = np.ones((size,) * 3, dtype=bool)
    idx = rng.integers(0, size, size=(count, 3))
    seeds[idx[:, 0], idx[:, 1], idx[:, 2]] = False
    tiled = np.pad(seeds, int(radius) + 1, mode="wrap")
    dist = ndimage.distance_transform_edt(tiled)[(slice(int(radius) + 1, -int(radius) - 1),) * 3]
    pore = dist >= radius
    if not spheres:
        return pore
    return pore, SphereWalls(idx + 0.5, np.full(count, radius), (float(size),) * 3)


def regular_fraction(lat) -> float:
    """Share of the nodes that stream by offset (no neighbour index read)."""
    lengths = np.diff(lat.run_start)
    return float(lengths[lat.run_offset[:, 0] >= 0].sum() / max(lat.n_nodes, 1))


def time_lattice(
    lat, collision: str, precision: str, threads: int, steps: int, repeats: int = 3, links=None
) -> tuple[float, float]:
    """(MLUPS per wall second, MLUPS per CPU second of this process), each the best of ``repeats``.

    On a shared machine the CPU-time figure is the robust one: at 1 thread it is what the kernel does when it has
    a core to itself; at 2 threads it is the throughput per busy core.
    """
    numba.set_num_threads(threads)
    n = lat.n_nodes
    src = np.zeros(19 * n, dtype=precision)
    dst = np.zeros_like(src)
    step = make_stepper(Settings(collision=collision, precision=precision), lat, links)
    none = np.zeros((4, 0))
    step(src, dst, none, False, 2)  # compile / warm up
    wall = cpu = 0.0
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        step(src, dst, none, False, steps)
        wall = max(wall, n * steps / (time.perf_counter() - t0) / 1e6)
        cpu = max(cpu, n * steps / max(time.process_time() - c0, 1e-9) / 1e6)
    return wall, cpu


def wall_cost(size: int, thread_counts, steps: int, repeats: int = 5) -> list[dict]:
    """Per-step CPU cost of CLI interpolated walls against halfway bounce-back on the porous sample (TRT, f64)."""
    pore, geometry = porous_sample(size, spheres=True)
    lat = periodic_setup(pore, mirror=False, lateral_periodic=True, prune=True, keep_wall_links=True).lattice
    links = build_links(lat.pore, lat.periodic, *lat.wall_links, geometry, Walls.cli)
    lat.wall_links = None
    out = []
    for threads in thread_counts:
        best = {}
        for name, lk in (("halfway", None), ("cli", links)):
            best[name] = time_lattice(lat, "trt", "float64", threads, steps, repeats, links=lk)[1]
        half_ms, cli_ms = (lat.n_nodes / best[k] / 1e3 for k in ("halfway", "cli"))  # CPU ms per step
        row = {
            "threads": threads,
            "nodes": lat.n_nodes,
            "links": links.size,
            "links_per_node": links.size / lat.n_nodes,
            "halfway_ms": half_ms,
            "cli_ms": cli_ms,
            "extra": cli_ms / half_ms - 1,
            "ns_per_link": (cli_ms - half_ms) * 1e6 / max(links.size, 1),
        }
        out.append(row)
        print(
            f"walls porous {threads}t: halfway {half_ms:.2f} ms/step, cli {cli_ms:.2f} ms/step "
            f"({row['extra']:+.1%}, {row['links_per_node']:.2f} links per node)",
            flush=True,
        )
    return out


def lbmpy_mlups(size: int, steps: int, threads: int) -> float | None:
    """MLUPS of lbmpy's generated D3Q19 SRT kernel on a periodic dense box (None if lbmpy is unavailable)."""
    try:
        import pystencils as ps
        from lbmpy import LBMConfig, LBStencil, Method, Stencil
        from lbmpy.scenarios import create_fully_periodic_flow
    except ImportError:
        return None
    numba.set_num_threads(threads)
    cfg = LBMConfig(stencil=LBStencil(Stencil.D3Q19), method=Method.SRT, relaxation_rate=1 / 0.857)
    kernel_cfg = ps.CreateKernelConfig(target=ps.Target.CPU)
    try:
        if threads > 1:
            kernel_cfg.cpu.openmp.enable = True
            kernel_cfg.cpu.openmp.num_threads = threads
    except AttributeError:
        if threads > 1:
            return None
    scenario = create_fully_periodic_flow(np.zeros((size,) * 3 + (3,)), lbm_config=cfg, config=kernel_cfg)
    scenario.run(2)
    t0 = time.perf_counter()
    scenario.run(steps)
    return size**3 * steps / (time.perf_counter() - t0) / 1e6


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--steps", type=int, default=10)
    add_out_argument(p)
    p.add_argument("--no-lbmpy", action="store_true")
    p.add_argument(
        "--smoke", action="store_true", help="24^3, 2 steps, no lbmpy (CI smoke; no figures to quote)"
    )
    args = p.parse_args(argv)
    if args.smoke:
        args.size, args.steps, args.no_lbmpy = 24, 2, True
    max_threads = min(2, numba.config.NUMBA_NUM_THREADS)
    thread_counts = list(range(1, max_threads + 1))
    bw = {t: bandwidth_gbs(t) for t in thread_counts}
    for t, v in bw.items():
        print(f"copy bandwidth, {t} thread(s): {v:.1f} GB/s", flush=True)
    size = args.size
    dense = build_lattice(np.ones((size,) * 3, dtype=bool), (True,) * 3, (0, size), (0, size))
    sample = porous_sample(size)
    prep = periodic_setup(sample, mirror=False, lateral_periodic=True, prune=True)
    porous = prep.lattice
    print(
        f"porous sample: porosity {sample.mean():.3f}, {porous.n_nodes} flow nodes after pruning "
        f"({prep.pruned_nodes} dropped)",
        flush=True,
    )
    rows = []
    for geometry, lat in (("dense", dense), ("porous", porous)):
        print(f"{geometry}: {regular_fraction(lat):.0%} of the nodes in offset-streaming runs", flush=True)
        for threads in thread_counts:
            for collision in ("bgk", "trt", "mrt"):
                for precision in ("float64", "float32"):
                    mlups, cpu = time_lattice(lat, collision, precision, threads, args.steps)
                    bound = bw[threads] * 1e3 / BYTES[precision]
                    rows.append(
                        {
                            "geometry": geometry,
                            "threads": threads,
                            "collision": collision,
                            "precision": precision,
                            "regular_fraction": regular_fraction(lat),
                            "nodes": lat.n_nodes,
                            "mlups": mlups,
                            "mlups_per_cpu_s": cpu,
                            "bound_mlups": bound,
                            "fraction": mlups / bound,
                        }
                    )
                    print(
                        f"{geometry:6s} {threads}t {collision} {precision}: {mlups:7.1f} MLUPS "
                        f"({cpu:5.1f} per CPU s), bound {bound:6.1f} ({mlups / bound:.0%})",
                        flush=True,
                    )
    walls = wall_cost(size, thread_counts, args.steps)
    peer = []
    if not args.no_lbmpy:
        for threads in thread_counts:
            value = lbmpy_mlups(size, args.steps, threads)
            peer.append({"threads": threads, "mlups": value})
            print(
                f"lbmpy SRT dense {threads}t: " + (f"{value:.1f} MLUPS" if value else "not available"),
                flush=True,
            )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "lbm_benchmark.json").write_text(
        json.dumps({"bandwidth_gbs": bw, "rows": rows, "walls": walls, "lbmpy": peer}, indent=1)
    )
    md = [
        "# LBM throughput (shared, loaded 2-core machine)",
        "",
        "copy bandwidth: " + ", ".join(f"{t} thread(s) {v:.1f} GB/s" for t, v in bw.items()),
        "",
        "| geometry | threads | collision | precision | nodes | MLUPS | MLUPS per CPU s | bound | fraction |",
        "|---" * 9 + "|",
    ]
    md += [
        f"| {r['geometry']} | {r['threads']} | {r['collision']} | {r['precision']} | {r['nodes']} | "
        f"{r['mlups']:.1f} | {r['mlups_per_cpu_s']:.1f} | {r['bound_mlups']:.1f} | {r['fraction']:.0%} |"
        for r in rows
    ]
    md += [
        "",
        "Interpolated walls (porous sample, TRT float64, CPU time per step; best of the repeats):",
        "",
        "| threads | links per node | halfway ms/step | cli ms/step | extra | ns per link |",
        "|---" * 6 + "|",
    ]
    md += [
        f"| {w['threads']} | {w['links_per_node']:.2f} | {w['halfway_ms']:.2f} | {w['cli_ms']:.2f} | "
        f"{w['extra']:+.1%} | {w['ns_per_link']:.2f} |"
        for w in walls
    ]
    md += [
        "",
        "lbmpy SRT (dense box): "
        + ", ".join(
            f"{r['threads']}t {r['mlups']:.1f} MLUPS" if r["mlups"] else f"{r['threads']}t n/a" for r in peer
        ),
    ]
    (out / "lbm_benchmark.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    print(f"record: {out / 'lbm_benchmark.json'} and lbm_benchmark.md")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
