"""Voxelisation throughput: the shell method (``boundary``) vs brute force (216 points per voxel), same packing.

Prints Mvoxel/s of both methods at 1 and 2 threads, the speed-up of the kernel alone and of the whole ``voxelize()``
call (both timed interleaved in one process, best of 3, with the load average: the machine is shared; the whole
shell-method call also in steady state, see STEADY_ROUNDS), and checks the two grey volumes are identical.
Usage: python benchmarks/voxelize.py [--smoke] [--out DIR] [--reference FILE]
(writes voxelize.json into --out, default results/benchmarks/). ``--reference`` names a copy of an earlier
``porepipe/voxelize/_kernels.py`` (for instance ``git show main:src/porepipe/voxelize/_kernels.py > old_kernels.py``):
its shell-method kernel is timed in the same rounds, and its grey values are asserted identical. The run also says
whether each kernel's machine code was compiled in this process or loaded from numba's cache (see
:func:`code_origin`): compare kernels only in a run where both come from the cache.
"""

from __future__ import annotations

import argparse
import os
import time

import numba
import numpy as np
from _common import add_out_argument, write_record
from _reference import load_module

from porepipe._shared.sample_points import SUB
from porepipe.voxelize import VoxelizeMethod, grid_shape, voxelize
from porepipe.voxelize._api import _Prepared, run_slab
from porepipe.voxelize._kernels import _voxelize_slab

#: extra rounds of the whole shell-method call for its steady-state time. Its first calls in a process write into
#: fresh output memory and pay its page faults (10-20 voxel spheres, 1 thread: 421-930 minor faults, 33-47 ms per call
#: against 31.7-31.9 ms once the allocator reuses the freed 8 MB); brute force pays the same faults in ~600 ms
STEADY_ROUNDS = 6
#: :func:`code_origin` of a kernel loaded from numba's on-disk cache
FROM_CACHE = "numba's cache"


def packing(n, box, r_min, r_max, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, box, (n, 3)), rng.uniform(r_min, r_max, n)


def kernel(prep, shape, a, boundary, slab=None):
    """The slab kernel alone on the whole volume (no sphere images, no allocation of the result); ``slab``: an
    earlier module's ``_voxelize_slab``, called as it was (its default blocks of planes), else the current one.
    """
    out = np.zeros(shape, np.uint8)
    if slab is None:
        return lambda: run_slab(0, shape[0], prep, a / SUB, shape, boundary, out) or out
    args = (prep.images, prep.order, prep.xmin_sorted, prep.r_max, a / SUB, shape[1], shape[2], boundary, out)
    return lambda: slab(0, shape[0], *args) or out


def code_origin(slab):
    """Where this process got the machine code of ``slab`` (a numba dispatcher): FROM_CACHE or "compiled in this run".

    Same source, other code: a kernel compiled in this process calls the copy of its non-inlined helper
    (``_ball_plane``) that numba compiled on its own, one loaded from the cache the copy linked into the kernel's
    cached library. On spheres 10-20 voxels wide (1 thread, idle-ish machine, load 1.7-1.9) main's kernel ran 30.4-30.6
    ms with the linked copy and 32.1-32.2 ms with the other; a variant of it 32.8-32.9 vs 29.8 ms, the other way round.
    The first run after an edit compiles the current kernel but loads an unchanged reference from the cache.
    """
    return "compiled in this run" if sum(slab.stats.cache_misses.values()) else FROM_CACHE


def best_interleaved(fns, rounds=3):
    """Best wall time, best CPU time and last result of each of ``fns`` over ``rounds`` rounds run one after the other.

    CPU time (all threads of the process) is what other processes on a shared machine disturb least.
    """
    best, best_cpu, results = [np.inf] * len(fns), [np.inf] * len(fns), [None] * len(fns)
    for _ in range(rounds):
        for n, fn in enumerate(fns):
            t0, c0 = time.perf_counter(), time.process_time()
            results[n] = fn()
            best[n] = min(best[n], time.perf_counter() - t0)
            best_cpu[n] = min(best_cpu[n], time.process_time() - c0)
    return best, best_cpu, results


def run_case(box, n, a, r_min, r_max, threads, reference=None):
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    c, r = packing(n, box, r_min, r_max)
    shape = grid_shape((box,) * 3, a)
    prep = _Prepared(c, r, (box,) * 3, True)
    nvox = float(np.prod(shape))
    fns = [
        kernel(prep, shape, a, True),
        kernel(prep, shape, a, False),
        lambda: voxelize(c, r, (box,) * 3, a, method=VoxelizeMethod.boundary),
        lambda: voxelize(c, r, (box,) * 3, a, method=VoxelizeMethod.brute),
    ]
    if reference is not None:
        fns.append(kernel(prep, shape, a, True, reference._voxelize_slab))
    (t_kb, t_kf, t_b, t_f, *t_ref), (c_kb, c_kf, _, _, *c_ref), (k_b, k_f, g_b, g_f, *k_ref) = (
        best_interleaved(fns)
    )
    assert np.array_equal(g_b, g_f) and np.array_equal(k_b, g_b) and np.array_equal(k_f, g_f), (
        "methods differ"
    )
    assert all(np.array_equal(k, k_b) for k in k_ref), "reference kernel differs"
    # the whole shell-method call in STEADY_ROUNDS more rounds: its first calls fault in fresh output pages
    (t_steady,), _, _ = best_interleaved(fns[2:3], STEADY_ROUNDS)
    extra = {}
    if k_ref:
        extra = {"reference_kernel_speedup": t_kf / t_ref[0], "reference_kernel_cpu_speedup": c_kf / c_ref[0]}
    return extra | {
        "threads": threads,
        "voxel_um": a,
        "span_voxels": f"{2 * r_min / a:g}-{2 * r_max / a:g}",
        "mvoxel": nvox / 1e6,
        "boundary_mvox_s": nvox / t_b / 1e6,
        "brute_mvox_s": nvox / t_f / 1e6,
        "speedup": t_f / t_b,
        "steady_speedup": t_f / min(t_b, t_steady),
        "kernel_speedup": t_kf / t_kb,
        "kernel_cpu_speedup": c_kf / c_kb,
        "load_1min": os.getloadavg()[0],
        "mixed_fraction": float(((g_b > 0) & (g_b < 216)).mean()),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--smoke", action="store_true", help="tiny sizes, for CI")
    ap.add_argument("--reference", help="earlier _kernels.py whose shell-method kernel is timed alongside")
    add_out_argument(ap)
    args = ap.parse_args()
    reference = load_module(args.reference) if args.reference else None
    r_min, r_max = 5.0, 10.0
    # same packing density (number of spheres per volume) at every resolution; ~8 Mvoxel per case
    cases = [(40.0, 12, 1.0)] if args.smoke else [(200.0, 1500, 1.0), (100.0, 188, 0.5), (50.0, 24, 0.25)]
    voxelize(np.zeros((1, 3)), np.ones(1), (4.0,) * 3, 1.0)  # compile
    rows = [
        run_case(box, n, a, r_min, r_max, threads, reference) for box, n, a in cases for threads in (1, 2)
    ]
    print(
        f"voxelize: spheres r = {r_min}-{r_max} µm, ~19 % of the box covered, 6^3 sample points per voxel; "
        "timings on a shared, loaded machine"
    )
    print(
        "| a µm | sphere span (voxels) | threads | Mvoxel | shell method Mvoxel/s | brute force Mvoxel/s | speed-up |"
        " speed-up, steady | kernel alone speed-up | kernel alone, CPU time | mixed voxels | load (1 min) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        print(
            f"| {row['voxel_um']} | {row['span_voxels']} | {row['threads']} | {row['mvoxel']:.1f} | "
            f"{row['boundary_mvox_s']:.1f} | {row['brute_mvox_s']:.2f} | {row['speedup']:.1f}x | "
            f"{row['steady_speedup']:.1f}x | "
            f"{row['kernel_speedup']:.1f}x | {row['kernel_cpu_speedup']:.1f}x | {row['mixed_fraction']:.3f} | "
            f"{row['load_1min']:.1f} |"
        )
    print(
        "machine limit: writing a uint8 volume once runs at ~1000+ Mvoxel/s (memory bandwidth); brute force = all "
        "216 point tests for every voxel in a sphere's bounding box; grey values of both are asserted identical; "
        "speed-up = whole voxelize() call, best of the 3 rounds interleaved with brute force (its first calls fault in "
        f"fresh output pages), steady = best of {3 + STEADY_ROUNDS} (the allocator reuses the output's memory: a process "
        "that voxelises more than once); kernel alone = the slab kernel without sphere images and allocation (wall "
        "time, and CPU time of all threads: the steadier figure on a loaded machine); "
        "goal (issue #22): speed-up >= 20x at every sphere span"
    )
    if reference is not None:
        print(f"reference kernel ({args.reference}), same rounds, kernel alone speed-up over brute force:")
        for row in rows:
            print(
                f"  {row['span_voxels']} voxels, {row['threads']} thread(s): reference "
                f"{row['reference_kernel_speedup']:.1f}x (CPU time {row['reference_kernel_cpu_speedup']:.1f}x), "
                f"current {row['kernel_speedup']:.1f}x ({row['kernel_cpu_speedup']:.1f}x); grey values identical"
            )
    origins = {"current": code_origin(_voxelize_slab)}
    if reference is not None:
        origins["reference"] = code_origin(reference._voxelize_slab)
    print("kernel machine code: " + ", ".join(f"{name}: {origin}" for name, origin in origins.items()))
    if set(origins.values()) != {FROM_CACHE}:
        print("  a kernel compiled in this run may run other code than its cached copy: run again to compare")
    for row in rows:
        row["kernel_code"] = origins
    write_record(args.out, "voxelize.json", rows)


if __name__ == "__main__":
    main()
