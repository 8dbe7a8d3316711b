"""LBM throughput: MLUPS (pore-node updates per second) against the memory-bandwidth bound and against lbmpy.

Head to head (issue 22), in one run and interleaved round by round, so that the load of a shared machine hits every
engine alike: the STREAM-like copy bandwidth (numba, same thread count) and the roofline it gives, 304 B per
float64 update (19 populations read and written); porepipe's step kernel as it was before issue 22 (``old``,
``LEGACY``: every tile pulled into an L1 scratch, collided, copied out with element-wise stores, which on x86
compile to cached scalar stores), its two-array pull kernel now (``pull``: regular runs collide straight from the
population array, one cache line per non-temporal vector store) and in place (``aa``, the default for halfway and
float64 CLI/BFL walls: AA-pattern step pairs in one array, every store into a line just read, cached); lbmpy's generated D3Q19 SRT stream-collide kernel alone (no periodic ghost-layer
copy, no Python time loop; the ``bench`` extra) and its full step. Dense periodic 128³ box and a porous 128³ sample
(overlapping spheres, porosity ≈ 0.2, only the percolating pore nodes stored; MLUPS per fluid node). Each figure is
the best of the rounds (short bursts catch the quiet moments of a loaded machine), with the 1-minute load average
beside it. Before timing it checks that the pull and in-place kernels write the same bits as the old one after
four steps (dense and porous, every operator).

Then, the default kernel only (in place: halfway walls): BGK / TRT / MRT in float64 and float32 at 1 and 2 threads on both geometries (float32
stores 152 B per update: the bound doubles), and the cost of interpolated walls (TRT float64 on the porous sample,
halfway bounce-back against CLI and MR1 walls at the exact sphere surfaces, at porosity 0.2 and 0.46; pulled with
two arrays, and halfway and CLI in place). Regular runs (all 18 pull sources advance with
the node) read no index; the others also read 18 uint32 neighbour indices (72 B), which the bound does not count.

Timings come from a shared, loaded 2-core machine: treat them as lower bounds of what the code can do, and compare
only within one run. Each table row also gives MLUPS per CPU second of the process.

Usage: python benchmarks/lbm.py [--size 128] [--steps 4] [--rounds 5] [--out DIR] [--no-lbmpy] [--smoke]
Writes lbm_benchmark.json and lbm_benchmark.md into --out (default: results/benchmarks/ of the checkout). The
default run takes 3–5 minutes here; --rounds 15 for steadier head-to-head figures.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numba
import numpy as np
from _common import add_out_argument
from numba import njit, prange
from scipy import ndimage

from porepipe.lbm import Settings, SphereWalls, Walls
from porepipe.lbm._domain import build_lattice, periodic_setup
from porepipe.lbm._kernels import IN_PLACE, LEGACY
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


def _wall_steppers(lat, geometry) -> tuple[dict, dict]:
    """(steppers, links): TRT float64 steps of ``lat`` with halfway, CLI and MR1 walls (τ̂ = 0.857), all three with
    the two-array pull kernel, and halfway and CLI walls in place (AA; MR1 cannot run in place).
    """
    wall_links = lat.wall_links
    links = {w: build_links(lat.pore, lat.periodic, *wall_links, geometry, Walls(w)) for w in ("cli", "mr1")}
    lat.wall_links = None
    steppers = {"halfway": make_stepper(Settings(walls="halfway", streaming="pull"), lat)}
    steppers.update({w: make_stepper(Settings(walls=w, streaming="pull"), lat, links[w]) for w in links})
    steppers["halfway in place"] = make_stepper(Settings(walls="halfway", streaming="aa"), lat)
    steppers["cli in place"] = make_stepper(Settings(walls="cli", streaming="aa"), lat, links["cli"])
    return steppers, links


def wall_cost(size: int, thread_counts, steps: int, rounds: int = 5, porosities=(0.2, 0.46)) -> list[dict]:
    """Per-step CPU cost of CLI and MR1 interpolated walls against halfway bounce-back on porous samples (TRT, f64,
    exact sphere walls, all three with the two-array pull kernel), timed in interleaved rounds (best of each), and the extra CPU time per interpolated link.
    """
    out = []
    for porosity in porosities:
        pore, geometry = porous_sample(size, porosity=porosity, spheres=True)
        lat = periodic_setup(
            pore, mirror=False, lateral_periodic=True, prune=True, keep_wall_links=True
        ).lattice
        steppers, links = _wall_steppers(lat, geometry)
        n = lat.n_nodes
        src, dst, none = np.zeros(19 * n), np.zeros(19 * n), np.zeros((4, 0))
        for threads in thread_counts:
            numba.set_num_threads(threads)
            for step in steppers.values():
                step(src, dst, none, False, 2)  # compile / warm up
            best = dict.fromkeys(steppers, float("inf"))
            for _ in range(rounds):
                for name, step in steppers.items():
                    c0 = time.process_time()
                    step(src, dst, none, False, steps)
                    best[name] = min(best[name], (time.process_time() - c0) / steps * 1e3)  # CPU ms per step
            half = best["halfway"]
            row = {
                "porosity": float(pore.mean()),
                "threads": threads,
                "nodes": n,
                "halfway_ms": half,
                "load": os.getloadavg()[0],
                "in_place": {
                    "halfway_ms": best["halfway in place"],
                    "cli_ms": best["cli in place"],
                    "cli_extra": best["cli in place"] / best["halfway in place"] - 1,
                    "cli_vs_pull": best["cli"] / best["cli in place"],
                },
            }
            for w, lk in links.items():
                row[w] = {
                    "links": lk.size,
                    "links_per_node": lk.size / n,
                    "ms": best[w],
                    "extra": best[w] / half - 1,
                    "ns_per_link": (best[w] - half) * 1e6 / max(lk.size, 1),
                }
            out.append(row)
            print(
                f"walls porous phi={row['porosity']:.2f} {threads}t: halfway {half:.2f} ms/step, "
                + ", ".join(
                    f"{w} {row[w]['ms']:.2f} ({row[w]['extra']:+.1%}, {row[w]['ns_per_link']:.1f} ns per link, "
                    f"{row[w]['links_per_node']:.2f} links per node)"
                    for w in links
                )
                + f"; in place: halfway {best['halfway in place']:.2f}, cli {best['cli in place']:.2f} ms/step "
                f"({row['in_place']['cli_extra']:+.1%}; {row['in_place']['cli_vs_pull']:.2f}x cli pulled)",
                flush=True,
            )
    return out


def _burst_bandwidth(a, b) -> float:
    """One timed copy a -> b: GB/s counting read and write bytes."""
    t0 = time.perf_counter()
    _copy(a, b)
    return 2 * a.nbytes / (time.perf_counter() - t0) / 1e9


def lbmpy_engines(size: int, threads: int):
    """(kernel, full): callables ``run(steps)`` for lbmpy's generated D3Q19 SRT kernel alone (stream-collide and
    swap, no ghost-layer copy) and its full time step (with periodic copy and Python time loop) on a periodic dense
    box, or None if lbmpy is unavailable or cannot run OpenMP.
    """
    try:
        import pystencils as ps
        from lbmpy import LBMConfig, LBStencil, Method, Stencil
        from lbmpy.scenarios import create_fully_periodic_flow
    except ImportError:
        return None
    cfg = LBMConfig(stencil=LBStencil(Stencil.D3Q19), method=Method.SRT, relaxation_rate=1 / 0.857)
    kernel_cfg = ps.CreateKernelConfig(target=ps.Target.CurrentCPU)  # -O3 -march=native
    try:
        if threads > 1:
            kernel_cfg.cpu.openmp.enable = True
            kernel_cfg.cpu.openmp.num_threads = threads
    except AttributeError:
        if threads > 1:
            return None
    sc = create_fully_periodic_flow(np.zeros((size,) * 3 + (3,)), lbm_config=cfg, config=kernel_cfg)
    sc.run(2)
    dh, kernel = sc.data_handling, sc._lbmKernels[0]

    def run_kernel(steps: int) -> None:
        for _ in range(steps):
            dh.run_kernel(kernel, **sc.kernel_params)
            dh.swap(sc._pdf_arr_name, sc._tmp_arr_name)

    return run_kernel, sc.run


#: the porepipe kernels of the head-to-head: (streaming setting, store mode)
KERNELS = {"old": ("pull", LEGACY), "pull": ("pull", None), "aa": ("aa", None)}


def porepipe_engine(lat, collision: str, kernel: str):
    """``run(steps)`` of porepipe's float64 step kernel on ``lat``: ``kernel`` "old" (the kernel before issue 22),
    "pull" (two arrays) or "aa" (in place; an even number of steps stays in place).
    """
    streaming, stores = KERNELS[kernel]
    src = np.zeros(19 * lat.n_nodes)
    dst = np.zeros_like(src)
    step = make_stepper(
        Settings(collision=collision, walls="halfway", streaming=streaming), lat, stores=stores
    )
    none = np.zeros((4, 0))

    def run(steps: int) -> None:
        step(src, dst, none, False, steps)

    return run


def same_bits(lat, collision: str, steps: int = 4) -> bool:
    """Whether the pull, in-place and LEGACY kernels give identical populations after an even number of ``steps``
    from random populations with a body force (the new kernels must be at least as accurate: here they do the same
    arithmetic; in place, the array holds the pull layout after each step pair).
    """
    start = 1e-3 * np.random.default_rng(1).standard_normal(19 * lat.n_nodes)
    out = []
    for stores in (None, IN_PLACE, LEGACY):
        src, dst = start.copy(), np.zeros_like(start)
        make_stepper(Settings(collision=collision, body_force=1e-5, streaming="pull"), lat, stores=stores)(
            src, dst, np.zeros((4, 0)), False, steps
        )
        out.append(src)
    return all(bool(np.array_equal(out[0], o)) for o in out[1:])


def head_to_head(engines: dict, threads: int, rounds: int, steps: int) -> dict:
    """Best MLUPS of each engine (name -> (nodes, run)) and of the copy bandwidth (GB/s, key "copy"), interleaved:
    every round times each once, in the same order; with the 1-minute load average at each engine's best.
    """
    numba.set_num_threads(threads)
    a = np.ones(2**25)
    b = np.empty_like(a)
    _copy(a, b)
    for _nodes, run in engines.values():
        run(1)  # compiled and warm
    best = dict.fromkeys(["copy", *engines], (0.0, 0.0))
    for _ in range(rounds):
        for name in best:
            if name == "copy":
                value = max(_burst_bandwidth(a, b) for _ in range(3))
            else:
                nodes, run = engines[name]
                t0 = time.perf_counter()
                run(steps)
                value = nodes * steps / (time.perf_counter() - t0) / 1e6
            if value > best[name][0]:
                best[name] = (value, os.getloadavg()[0])
    return best


def compare(
    size: int,
    dense,
    porous,
    thread_counts,
    rounds: int,
    steps: int,
    use_lbmpy: bool,
    collisions=("bgk", "trt"),
) -> list[dict]:
    """Head-to-head rows per thread count: roofline, old, pull and in-place porepipe kernels (operators
    ``collisions``), lbmpy's kernel and full step.
    """
    rows = []
    for threads in thread_counts:
        engines = {}
        for geometry, lat in (("dense", dense), ("porous", porous)):
            for collision in collisions:
                for kernel in KERNELS:
                    engines[f"{kernel} {collision} {geometry}"] = (
                        lat.n_nodes,
                        porepipe_engine(lat, collision, kernel),
                    )
        peer = lbmpy_engines(size, threads) if use_lbmpy else None
        if peer is not None:
            engines["lbmpy kernel srt dense"] = (size**3, peer[0])
            engines["lbmpy step srt dense"] = (size**3, peer[1])
        best = head_to_head(engines, threads, rounds, steps)
        roof = best["copy"][0] * 1e3 / BYTES["float64"]
        lbmpy_kernel = best.get("lbmpy kernel srt dense", (None,))[0]
        print(
            f"-- {threads} thread(s): copy {best['copy'][0]:.1f} GB/s -> roofline {roof:.1f} MLUPS (float64)"
        )
        for name, (value, load) in best.items():
            if name == "copy":
                continue
            row = {
                "threads": threads,
                "engine": name,
                "mlups": value,
                "load": load,
                "roofline_mlups": roof,
                "of_roofline": value / roof,
                "of_lbmpy_kernel": value / lbmpy_kernel if lbmpy_kernel else None,
            }
            rows.append(row)
            vs = f", {row['of_lbmpy_kernel']:.2f} of lbmpy's kernel" if lbmpy_kernel else ""
            print(
                f"{name:24s} {value:7.1f} MLUPS = {row['of_roofline']:.0%} of the roofline{vs} (load {load:.1f})"
            )
        rows.append({"threads": threads, "engine": "copy", "gbs": best["copy"][0], "load": best["copy"][1]})
        if peer is None and use_lbmpy:
            print("lbmpy: not available (pip install -e '.[bench]')")
    return rows


def _table(rows, wall_rows, peer_rows, bw) -> list[str]:
    md = [
        "# LBM throughput (shared, loaded 2-core machine)",
        "",
        "## Head to head (interleaved rounds, best of each; float64; MLUPS per fluid node)",
        "",
        "| threads | engine | MLUPS | of roofline | of lbmpy kernel | load |",
        "|---" * 6 + "|",
    ]
    for r in peer_rows:
        if r["engine"] == "copy":
            md.append(f"| {r['threads']} | copy bandwidth {r['gbs']:.1f} GB/s | | | | {r['load']:.1f} |")
            continue
        vs = f"{r['of_lbmpy_kernel']:.2f}" if r["of_lbmpy_kernel"] else "n/a"
        md.append(
            f"| {r['threads']} | {r['engine']} | {r['mlups']:.1f} | {r['of_roofline']:.0%} | {vs} | {r['load']:.1f} |"
        )
    md += [
        "",
        "## Default kernel (in place), every operator and precision",
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
        "Interpolated walls (porous samples, exact sphere walls, TRT float64, CPU time per step; best of interleaved "
        "rounds; ns per link = extra CPU time over halfway per interpolated link; the first columns pull with two "
        "arrays, the in-place columns stream in place (AA), where CLI links are kept per link between the steps "
        "of a pair):",
        "",
        "| porosity | threads | halfway ms/step | cli ms/step | cli extra | cli ns/link | mr1 ms/step | mr1 extra | "
        "mr1 ns/link | cli links/node | in place: halfway ms/step | cli ms/step | cli extra | cli in place vs pulled "
        "| load |",
        "|---" * 15 + "|",
    ]
    md += [
        f"| {w['porosity']:.2f} | {w['threads']} | {w['halfway_ms']:.2f} | {w['cli']['ms']:.2f} | "
        f"{w['cli']['extra']:+.1%} | {w['cli']['ns_per_link']:.2f} | {w['mr1']['ms']:.2f} | {w['mr1']['extra']:+.1%} | "
        f"{w['mr1']['ns_per_link']:.2f} | {w['cli']['links_per_node']:.2f} | {w['in_place']['halfway_ms']:.2f} | "
        f"{w['in_place']['cli_ms']:.2f} | {w['in_place']['cli_extra']:+.1%} | {w['in_place']['cli_vs_pull']:.2f}x | "
        f"{w['load']:.1f} |"
        for w in wall_rows
    ]
    return md


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=int, default=128)
    p.add_argument(
        "--steps", type=int, default=4, help="steps per timed burst (even: in place, an odd last step pulls)"
    )
    p.add_argument("--rounds", type=int, default=5, help="interleaved head-to-head rounds")
    add_out_argument(p)
    p.add_argument("--no-lbmpy", action="store_true")
    p.add_argument(
        "--smoke",
        action="store_true",
        help="24^3, 2 steps, 1 round, no lbmpy, TRT float64 only (CI smoke; no figures to quote)",
    )
    args = p.parse_args(argv)
    if args.steps < 2 or args.steps % 2:
        p.error(f"--steps {args.steps}: give an even number ≥ 2 (the in-place kernel steps in pairs)")
    collisions, precisions = ("bgk", "trt", "mrt"), ("float64", "float32")
    # each operator and precision is a step kernel of its own to compile: the smoke runs TRT float64
    if args.smoke:
        args.size, args.steps, args.rounds, args.no_lbmpy = 24, 2, 1, True
        collisions, precisions = ("trt",), ("float64",)
    max_threads = min(2, numba.config.NUMBA_NUM_THREADS)
    thread_counts = list(range(1, max_threads + 1))
    size = args.size
    dense = build_lattice(np.ones((size,) * 3, dtype=bool), (True,) * 3, (0, size), (0, size))
    sample = porous_sample(size)
    prep = periodic_setup(sample, mirror=False, lateral_periodic=True, prune=True)
    porous = prep.lattice
    print(
        f"porous sample: porosity {sample.mean():.3f}, {porous.n_nodes} flow nodes after pruning "
        f"({prep.pruned_nodes} dropped); offset-streaming runs hold {regular_fraction(dense):.0%} (dense) and "
        f"{regular_fraction(porous):.0%} (porous) of the nodes",
        flush=True,
    )
    checks = {
        f"{geometry} {collision}": same_bits(lat, collision)
        for geometry, lat in (("dense", dense), ("porous", porous))
        for collision in collisions
    }
    print(
        "pull and in-place kernels = old kernel bit for bit (4 steps, body force): "
        + ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in checks.items()),
        flush=True,
    )
    if not all(checks.values()):
        raise SystemExit("a new kernel differs from the old one: its figures would not be comparable")
    peer = compare(
        size, dense, porous, thread_counts, args.rounds, args.steps, not args.no_lbmpy, collisions[:2]
    )
    bw = {t: bandwidth_gbs(t) for t in thread_counts}
    rows = []
    for geometry, lat in (("dense", dense), ("porous", porous)):
        for threads in thread_counts:
            for collision in collisions:
                for precision in precisions:
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
                            "load": os.getloadavg()[0],
                        }
                    )
                    print(
                        f"{geometry:6s} {threads}t {collision} {precision}: {mlups:7.1f} MLUPS "
                        f"({cpu:5.1f} per CPU s), bound {bound:6.1f} ({mlups / bound:.0%})",
                        flush=True,
                    )
    walls = wall_cost(size, thread_counts, args.steps, args.rounds)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    record = {"bandwidth_gbs": bw, "checks": checks, "head_to_head": peer, "rows": rows, "walls": walls}
    (out / "lbm_benchmark.json").write_text(json.dumps(record, indent=1))
    md = _table(rows, walls, peer, bw)
    (out / "lbm_benchmark.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    print(f"record: {out / 'lbm_benchmark.json'} and lbm_benchmark.md")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
