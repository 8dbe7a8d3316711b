"""Benchmark of the DEM packing step: sphere-steps per second, cost of each optional effect, engine overhead.

    python benchmarks/pack.py            # kernel on 10^6 spheres, engine effects on 2·10^5 (a few minutes)
    python benchmarks/pack.py --full     # engine effects on 10^6 spheres too (over 10 minutes here)
    python benchmarks/pack.py --small    # 20 000 spheres

Prints a markdown table and writes pack.json into --out (default results/benchmarks/). Reference: LAMMPS's granular
chute benchmark (frictional Hooke/history pair style, half neighbour lists with Newton's 3rd law, 3 neighbours per
atom) ran 1.67e7 atom-steps/s per core on the 2-core development machine, i.e. about 5e7 pair evaluations/s. porepipe's
kernel also evaluates each listed pair once (half list, Newton's 3rd law; listed pairs include the skin region), so
compare pair evaluations per second: it prints both. Timings are taken on a shared, loaded machine (2 cores shared by
several jobs): treat them as lower bounds.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from _common import add_out_argument, write_record

from porepipe.packing import Settings, build_neighbours, pack_spheres
from porepipe.packing import _kernels as K
from porepipe.packing._api import pair_tables

#: LAMMPS chute benchmark on the development machine: atom-steps/s per core and neighbours (unique pairs) per atom
LAMMPS_CHUTE_PER_CORE = 1.67e7
LAMMPS_CHUTE_PAIRS_PER_ATOM = 3.0
#: spheres of the engine-effect runs by default (the kernel table always uses the full N)
ENGINE_SPHERES = 200_000


def polydisperse(n: int, seed: int = 0):
    """N spheres, radii log-uniform in [1, 4] µm, random centres at a nominal solid fraction of 0.6."""
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
    args = dict(
        frozen=np.zeros(n, np.uint8),
        k=np.array([20.0]),
        sig=np.array([0.3]),
        cm=np.array([0.9]),
        cp=np.array([1.1]),
        fmax=np.zeros(1),
    )
    xa, xb = x.copy(), np.empty_like(x)
    v, fa, fb = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    sig, conv, aux = np.empty(n), np.empty(n, np.uint8), np.empty((n, 3))
    tables = pair_tables(args["k"], args["sig"])

    bufs = [xa, xb, fa, fb]

    def one(s):
        # like the engine: positions and forces alternate between two buffers (so does the memory traffic)
        x_old, x_new, f_old, f_new = bufs
        kernel(
            x_old,
            x_new,
            v,
            f_old,
            f_new,
            r,
            types,
            ids,
            args["frozen"],
            *nbr,
            box,
            per,
            *tables,
            args["sig"],
            args["cm"],
            args["cp"],
            args["fmax"],
            1.3,
            0.01,
            1.0,
            7,
            s,
            x,
            r,
            sig,
            conv,
            aux,
        )
        bufs[:] = [x_new, x_old, f_new, f_old]

    one(0)  # compile / load from cache
    t0 = time.perf_counter()
    for s in range(1, steps + 1):
        one(s)
    return (time.perf_counter() - t0) / steps


#: effects switched on in the benchmark scene, one at a time (the stage block, or a closed axis for walls)
ENGINE_EFFECTS = {
    "none": {},
    "ramps": {"k": {"a": {"start": 20, "end": 40, "from_step": 0, "to_step": 10**6}}},
    "stochastic_forces": {"stochastic_forces": {"step_size": 0.05}},
    "adaptive_radii": {"adaptive_radii": {"types": ["a"], "trigger": 1.0}},
    "freezing": {"freezing": {"lock_step": 0}},
    "walls": {},
}


def time_engine(xyzr, box, steps, threads, effect="none", repeats=4):
    """Per-step wall time of the whole engine (step loop, reductions, guards, protocol) on the benchmark packing
    (read from ``xyzr``, the same spheres as the kernel runs) with one optional effect switched on (lists built
    once); the median step of the best of ``repeats`` runs.
    """
    numba.set_num_threads(threads)
    stage = {
        "name": "bench",
        "insert_file": {"path": str(xyzr), "type": "a"},
        "steps": steps,
        "dt": 0.01,
        "k": {"a": 20},
        "damping": {"a": 10},
        **ENGINE_EFFECTS[effect],
    }
    settings = Settings.model_validate(
        {
            "types": [
                {"name": "a", "count": 0, "radius_um": {"min_um": 1.0, "max_um": 4.0}, "max_overlap": 0.3}
            ],
            "stages": [stage],
            "rebuild_interval": 10**9,
            "parallel_min_spheres": 0,
        }
    )
    periodic = [True, True, effect != "walls"]
    one = settings.model_copy(update={"stages": [settings.stages[0].model_copy(update={"steps": 2})]})
    pack_spheres(one, box, periodic)  # compile / load caches
    best = np.inf
    for _ in range(repeats):
        wall = pack_spheres(settings, box, periodic).history["wall_s"]
        best = min(best, float(np.median(wall[1:])))  # step 1 builds the lists
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", action="store_true", help="20 000 spheres instead of 10^6 (CI smoke)")
    ap.add_argument(
        "--smoke", action="store_true", help="2 000 spheres, 3 steps (CI smoke, no figures to quote)"
    )
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument(
        "--full", action="store_true", help="time the engine's effects on all 10^6 spheres (default: 2·10^5)"
    )
    add_out_argument(ap)
    args = ap.parse_args()
    n = 2_000 if args.smoke else 20_000 if args.small else 1_000_000
    steps = args.steps or (10 if args.smoke else 50 if args.small else 10)
    x, r, box = polydisperse(n)
    t0 = time.perf_counter()
    *nbr, order = build_neighbours(
        x,
        r,
        np.zeros(n, np.int64),
        box,
        np.ones(3, bool),
        np.ones((1, 1), np.uint8),
        1.3,
        0.3,
        reorder=True,
        half=True,
    )
    build_s = time.perf_counter() - t0
    x, r = (
        x[order],
        r[order],
    )  # the engine keeps spheres in cell order (memory locality), and so does the benchmark
    rows = []
    variants = {
        "bare (no effects)": (False, False, False),
        "freezing": (True, False, False),
        "stochastic forces": (False, True, False),
        "walls": (False, False, True),
        "all compiled in, switched off": (True, True, True),
    }
    time_kernel(x, r, box, nbr, (False, False, False), steps, 1)  # warm-up: first touch of every page
    for threads in (1, 2):
        base = None
        for label, flags in variants.items():
            dt_step = min(time_kernel(x, r, box, nbr, flags, steps, threads) for _ in range(4))
            base = dt_step if base is None else base
            rows.append(
                {
                    "threads": threads,
                    "kernel": label,
                    "s_per_step": dt_step,
                    "sphere_steps_per_s": n / dt_step,
                    "vs_bare": dt_step / base,
                }
            )
    # the whole engine per effect: 2 thread counts x 6 effects x 5 runs; on 10^6 spheres that alone takes over
    # 10 minutes here, so by default it runs on a smaller packing of the same distribution (--full: all of them)
    n_engine = n if args.full else min(n, ENGINE_SPHERES)
    x_e, r_e, box_e = (x, r, box) if n_engine == n else polydisperse(n_engine)
    with tempfile.TemporaryDirectory() as tmp:
        xyzr = Path(tmp) / "bench.xyzr"
        np.savetxt(xyzr, np.column_stack([x_e, r_e]), fmt="%.17g")
        eng = {
            threads: {e: time_engine(xyzr, box_e, steps, threads, e) for e in ENGINE_EFFECTS}
            for threads in (1, 2)
        }
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    pairs = nbr[1].size / n
    print(
        f"# porepipe pack benchmark: N = {n} polydisperse spheres (r in [1, 4] µm), {pairs:.1f} list pairs per "
        f"sphere, list build {build_s:.2f} s; best of 4 runs of {steps} steps\n"
    )
    lammps_pairs = LAMMPS_CHUTE_PER_CORE * LAMMPS_CHUTE_PAIRS_PER_ATOM
    print(
        "| threads | kernel (compiled effects, none active) | s/step | sphere-steps/s | pair evaluations/s | "
        f"vs bare | pairs/s vs LAMMPS chute ({lammps_pairs:.3g} per core) |"
    )
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        row["pairs_per_s"] = row["sphere_steps_per_s"] * pairs
        frac = row["pairs_per_s"] / (lammps_pairs * row["threads"])
        print(
            f"| {row['threads']} | {row['kernel']} | {row['s_per_step']:.4g} | {row['sphere_steps_per_s']:.3g} | "
            f"{row['pairs_per_s']:.3g} | {row['vs_bare']:.3f} | {frac:.2f} |"
        )
    print(f"\nEngine runs on {n_engine} spheres (per-step times scaled to N = {n} for the comparison).")
    print("\n| threads | engine, effect switched on | s/step | vs bare kernel | vs engine without effects |")
    print("|---|---|---|---|---|")
    for threads, per_effect in eng.items():
        bare = next(r_["s_per_step"] for r_ in rows if r_["threads"] == threads)
        for effect, per_step_engine in per_effect.items():
            per_step = per_step_engine * n / n_engine
            print(
                f"| {threads} | {effect} | {per_step:.4g} | {per_step / bare:.3f} | "
                f"{per_step_engine / per_effect['none']:.3f} |"
            )
    print(
        "\n'none' vs bare kernel = what the engine adds to a scene without optional effects (target <= 1.05)."
    )
    out = {
        "n": n,
        "pairs_per_sphere": pairs,
        "build_s": build_s,
        "kernels": rows,
        "engine_spheres": n_engine,
        "engine_s_per_step": {str(k): v for k, v in eng.items()},
    }
    write_record(args.out, "pack_smoke.json" if args.smoke else "pack.json", out)


if __name__ == "__main__":
    main()
