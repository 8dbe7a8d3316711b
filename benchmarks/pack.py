"""Benchmark of the DEM packing step: sphere-steps per second, cost of each optional effect, engine overhead.

    python benchmarks/pack.py            # ~10^6 polydisperse spheres
    python benchmarks/pack.py --small    # 20 000 spheres (CI smoke)

Prints a markdown table and writes benchmarks/pack.json. Reference: LAMMPS's granular chute benchmark runs about
1.1e7 particle-steps/s per core (frictional Hooke/history pair style, half neighbour lists with Newton's 3rd law);
porepipe's kernel computes each pair from both ends (a race-free gather), so its pair work per sphere-step is double.
Timings are taken on a shared, loaded machine (2 cores shared by several jobs): treat them as lower bounds.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numba
import numpy as np

from porepipe.packing import Settings, build_neighbours, pack_spheres
from porepipe.packing import _kernels as K
from porepipe.packing._api import pair_tables

LAMMPS_CHUTE_PER_CORE = 1.1e7


def polydisperse(n: int, seed: int = 0):
    """n spheres, radii log-uniform in [1, 4] µm, random centres at a nominal solid fraction of 0.6."""
    rng = np.random.default_rng(seed)
    r = np.exp(rng.uniform(np.log(1.0), np.log(4.0), n))
    edge = (np.sum(4 / 3 * np.pi * r**3) / 0.6) ** (1 / 3)
    box = np.full(3, edge)
    return rng.random((n, 3)) * box, r, box


def time_kernel(x, r, box, nbr, flags, steps, threads):
    numba.set_num_threads(threads)
    n = r.size
    kernel = K.make_step_kernel(*flags)
    types = np.zeros(n, np.int64)
    ids = np.arange(n, dtype=np.int64)
    per = np.ones(3, bool)
    args = dict(frozen=np.zeros(n, np.uint8), k=np.array([20.0]), sig=np.array([0.3]), cm=np.array([0.9]),
                cp=np.array([1.1]), fmax=np.zeros(1))
    xa, xb = x.copy(), np.empty_like(x)
    v, fa, fb = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    sig, conv, aux = np.empty(n), np.empty(n, np.uint8), np.empty((n, 3))
    tables = pair_tables(args["k"], args["sig"])

    def one(s):
        kernel(xa, xb, v, fa, fb, r, types, ids, args["frozen"], nbr[0], nbr[1], box, per, *tables, args["sig"],
               args["cm"], args["cp"], args["fmax"], 1.3, 0.01, 1.0, 7, s, x, r, sig, conv, aux)

    one(0)  # compile / load from cache
    t0 = time.perf_counter()
    for s in range(1, steps + 1):
        one(s)
    return (time.perf_counter() - t0) / steps


def time_engine(n, steps, threads, seed=0):
    """Per-step wall time of the full engine on a scene without optional effects (lists built once)."""
    numba.set_num_threads(threads)
    _, r, box = polydisperse(n, seed)
    settings = Settings.model_validate({
        "types": [{"name": "a", "count": n, "radius_um": {"min_um": 1.0, "max_um": 4.0}, "max_overlap": 0.3}],
        "stages": [{"name": "bench", "insert": ["a"], "steps": steps, "dt": 0.01, "k": {"a": 20},
                    "damping": {"a": 10}}],
        "rebuild_interval": 10**9, "parallel_min_spheres": 0})
    one = settings.model_copy(update={"stages": [settings.stages[0].model_copy(update={"steps": 1})]})
    pack_spheres(one, box, True, seed)  # compile / load caches
    t0 = time.perf_counter()
    pack_spheres(one, box, True, seed)
    setup = time.perf_counter() - t0   # insertion, list build, one step, final overlap evaluation
    t0 = time.perf_counter()
    p = pack_spheres(settings, box, True, seed)
    total = time.perf_counter() - t0
    return total - setup, int(p.history["step"].size) - 1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", action="store_true", help="20 000 spheres instead of 10^6 (CI smoke)")
    ap.add_argument("--smoke", action="store_true", help="2 000 spheres, 3 steps (CI smoke, no figures to quote)")
    ap.add_argument("--steps", type=int, default=None)
    args = ap.parse_args()
    n = 2_000 if args.smoke else 20_000 if args.small else 1_000_000
    steps = args.steps or (3 if args.smoke else 20 if args.small else 5)
    x, r, box = polydisperse(n)
    t0 = time.perf_counter()
    *nbr, order = build_neighbours(x, r, np.zeros(n, np.int64), box, np.ones(3, bool), np.ones((1, 1), np.uint8),
                                   1.3, 0.3, reorder=True)
    build_s = time.perf_counter() - t0
    x, r = x[order], r[order]  # the engine keeps spheres in cell order (memory locality), and so does the benchmark
    rows = []
    variants = {"bare (no effects)": (False, False, False), "freezing": (True, False, False),
                "stochastic forces": (False, True, False), "walls": (False, False, True),
                "all compiled in, switched off": (True, True, True)}
    for threads in (1, 2):
        base = None
        for label, flags in variants.items():
            dt_step = time_kernel(x, r, box, nbr, flags, steps, threads)
            base = dt_step if base is None else base
            rows.append({"threads": threads, "kernel": label, "s_per_step": dt_step, "sphere_steps_per_s": n / dt_step,
                         "vs_bare": dt_step / base})
    eng = {}
    for threads in (1, 2):
        total, done = time_engine(n, steps, threads)
        eng[threads] = total / done
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    pairs = nbr[1].size / 2 / n
    print(f"# porepipe pack benchmark: N = {n} polydisperse spheres (r in [1, 4] µm), {pairs:.1f} list pairs per "
          f"sphere, list build {build_s:.2f} s\n# shared, loaded machine: timings are lower bounds\n")
    print("| threads | kernel | s/step | sphere-steps/s | vs bare | vs LAMMPS chute (1.1e7/core) |")
    print("|---|---|---|---|---|---|")
    for row in rows:
        frac = row["sphere_steps_per_s"] / (LAMMPS_CHUTE_PER_CORE * row["threads"])
        print(f"| {row['threads']} | {row['kernel']} | {row['s_per_step']:.4g} | {row['sphere_steps_per_s']:.3g} | "
              f"{row['vs_bare']:.3f} | {frac:.2f} |")
    print()
    for threads, per_step in eng.items():
        bare = next(r_["s_per_step"] for r_ in rows if r_["threads"] == threads)
        print(f"engine, scene without effects, {threads} thread(s): {per_step:.4g} s/step = {per_step / bare:.3f} x "
              "the bare kernel (step loop incl. ramps, reductions, guards)")
    out = {"n": n, "pairs_per_sphere": pairs, "build_s": build_s, "kernels": rows,
           "engine_s_per_step": {str(k): v for k, v in eng.items()}}
    if not args.smoke:
        Path(__file__).with_suffix(".json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
