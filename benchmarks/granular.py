"""Throughput of the granular DEM (gc2d polygons): polygon-steps per second in a dense pile.

A pile of N random 8-10-gons (RAND1 shapes on ellipses, semi-axes 5 mm ± I) is laid out row by row with
neighbours overlapping slightly inside a box, under gravity, with friction and damping; it is stepped a little
to build the contact state, then timed (best of 3). That is a compressed lattice in its first few ms after
release, not a pile at rest: coordination 4.6 at I = 0.1 (the measured value is printed; the thesis's heaps
have 3.6, its monodisperse piles ~4), and left alone it expands (coordination below 1 after 60 ms, grains at
~1 m/s), so it has more contacts and more list builds than a settled pile. ``benchmarks/granular_settled.py``
times the same grains settled (coordination 3.6, cached after its first run) beside this lattice: 1.3-1.4x
faster. Reported for 1 and 2 threads, the three neighbour searches (sweep, swap, cells; their list-build times
first), a monodisperse (I = 0.1) and a wide (I = 0.5, sizes 1:3) size distribution, next to two peers'
published figures. A last row compares the bare kernel with one that has every optional effect compiled in
(with neutral values), i.e. what the compile-time switches save, the narrow phase against the whole-polygon
clipping it replaced, and, with ``--reference``, an earlier step kernel file with the default skin of before
issue 15's speed work (0.3 R_min; same pile, interleaved, trajectories checked bit for bit);
``--reference-skin 0.6`` gives it today's skin, so that the row times the kernels alone.
``--contact-reference`` times the narrow phase alone (one call per candidate pair whose boxes overlap, on the
pile, 1 thread) of an earlier ``_contact.py`` beside the current one: a few ns per pair, far less noisy than
whole steps on a shared machine.

    python benchmarks/granular.py            # N = 10 000
    python benchmarks/granular.py --smoke    # N = 300, 1 thread, no effect row: seconds once compiled
    git show 8390a4f:src/porepipe/granular/_kernels.py > old_granular_kernels.py
    python benchmarks/granular.py --reference old_granular_kernels.py   # also time that kernel beside this one
    git show main:src/porepipe/granular/_contact.py > old_granular_contact.py
    python benchmarks/granular.py --contact-reference old_granular_contact.py --methods swap   # narrow phase alone
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numba
import numpy as np
from _common import add_out_argument, write_record
from _reference import load_module
from numba import njit

from porepipe._shared.numba_config import openmp_wait_for_idle_cores
from porepipe.granular import Settings, Simulation, polygon_properties
from porepipe.granular import _contact as C
from porepipe.granular import _kernels as K
from porepipe.granular._settings import Shape
from porepipe.granular._system import generate_shapes

#: published peer figures (particle-steps per second)
PEERS = {
    "LAMMPS body/rounded/polygon (32 squares, no friction history)": 8.3e5,
    "LAMMPS granular spheres (chute, per core)": 1.1e7,
}
TARGET = 5e6
#: semi-axis of the grains' ellipses (m)
GRAIN_M = 0.005


def pile_shapes(n: int, spread: float, seed: int = 1) -> tuple[list, np.ndarray]:
    """Outlines and orientations of the benchmark's N random 8-10-gons (RAND1 on ellipses, semi-axes 5 mm ± I)."""
    a = GRAIN_M
    shape = Shape(
        size_m=(a, a),
        size_spread=spread,
        size_dist="EQUAL",
        corners=9,
        corners_spread=1,
        corners_dist="EQUAL",
        angle_mode="RAND1",
        orientation_dist="EQUAL",
    )
    return generate_shapes(shape, n, np.random.default_rng(seed))


def pile_settings(parts: list, width: float, top: float, method: str, dt_s: float = 2e-6) -> Settings:
    """The benchmark's box (``width`` wide, 4 grain sizes above ``top``), material and step for ``parts``."""
    a = GRAIN_M
    return Settings.model_validate(
        {
            "dt_s": dt_s,
            "neighbour_search": method,
            "material": {"young_N_m": 1e7, "density_kg_m2": 5000.0, "damping": 0.5, "friction": 0.6},
            "box": {"lower_m": (0.0, 0.0), "upper_m": (width + 2 * a, top + 4 * a)},
            "guard": {"max_overlap": 2.0},
            "particles": parts,
        }
    )


def pile_width(n: int) -> float:
    """Inner width of the benchmark's box for N grains (m)."""
    return 2.0 * GRAIN_M * math.sqrt(n) * 1.1


def pile(n: int, spread: float, method: str, seed: int = 1) -> Settings:
    """N random 8-10-gons packed row by row so that neighbours overlap slightly (coordination 4.6 just after release)."""
    outlines, phis = pile_shapes(n, spread, seed)
    r = np.array([math.sqrt(polygon_properties(v)["area_m2"] / math.pi) for v in outlines])
    width = pile_width(n)
    parts, row_r, prev_r, odd = [], [], 0.0, False
    x, y = 0.0, r.max()
    for v, phi, ri in zip(outlines, phis, r, strict=True):
        x += 0.98 * (prev_r + ri) if row_r else ri
        if x + ri > width:  # next row, offset by half a particle, at the triangular lattice's row distance
            y += 0.97 * math.sqrt(3.0) * float(np.mean(row_r))
            odd = not odd
            x, row_r = ri + (float(np.mean(r)) if odd else 0.0), []
        parts.append({"vertices_m": v.tolist(), "position_m": (x, y), "angle_rad": float(phi)})
        row_r.append(ri)
        prev_r = ri
    return pile_settings(parts, width, y, method)


def _time(sim: Simulation, steps: int, repeats: int) -> tuple[float, float]:
    """Best polygon-steps per wall second and per CPU second (all threads' CPU time) over ``repeats`` runs; on a
    shared machine the CPU figure is the one that does not depend on the other users.
    """
    best, best_cpu = math.inf, math.inf
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        sim.advance(steps)
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return sim.n_mob * steps / best, sim.n_mob * steps / max(best_cpu, 1e-9)


def measure(
    n: int, spread: float, method: str, threads: int, warm: int, steps: int, repeats: int, settings=None
) -> dict:
    """Polygon-steps per second of the pile (or of ``settings``, the same grains placed otherwise) after ``warm``."""
    numba.set_num_threads(threads)
    sim = Simulation(settings if settings is not None else pile(n, spread, method), seed=1)
    sim.advance(warm)
    rate, rate_cpu = _time(sim, steps, repeats)
    c = sim.contacts()
    coord = 2.0 * np.sum(c["j"] < sim.n_mob) / sim.n_mob
    return {
        "n": sim.n_mob,
        "spread": spread,
        "method": method,
        "threads": threads,
        "rate": rate,
        "rate_per_cpu_s": rate_cpu,
        "coordination": float(coord),
        "rebuilds": sim.rebuilds,
    }


def list_build_cost(n: int, spread: float, method: str, warm: int, repeats: int) -> float:
    """Seconds per candidate-list build (1 thread) after the pile has moved for ``warm`` steps: the part of the
    run in which the broad phases differ (the swap rule's set follows the motion since the previous build).
    """
    numba.set_num_threads(1)
    sim = Simulation(pile(n, spread, method), seed=1)
    best = math.inf
    for _ in range(repeats + 1):
        sim.advance(warm)
        t0 = time.perf_counter()
        sim.rebuild()
        best = min(best, time.perf_counter() - t0)
    return best


def effect_cost(n: int, warm: int, steps: int, repeats: int) -> dict:
    """Bare kernel vs every effect compiled in with neutral values, on the same pile (1 thread, interleaved
    rounds, best of each, so that the machine's load drifts hit both alike).
    """
    numba.set_num_threads(1)
    sims = {}
    for label, flags in (("bare", (False,) * 8), ("all effects compiled in", (True,) * 8)):
        sim = Simulation(pile(n, 0.1, "sweep"), seed=1)
        sim.mat[5] = 1e30  # weakening floor: (max(|v|, 1e30))^-0.1 = 1e-3 everywhere ...
        sim._stepper = K.make_stepper(*flags)
        sim.gpar = np.array([0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0])  # CONSTANT, g(t)/g = 1
        sim.heat[:] = (0.0, 1.0, 1.0, 0.0, 1.0)  # s(t) = 1 (amplitude 0); no wall is a piston
        if flags[1]:
            sim.mat[2] *= 1e30**0.1  # ... compensated in mu: the weakening law is evaluated but neutral
        sim.advance(warm)
        sims[label] = sim
    out = dict.fromkeys(sims, 0.0)
    for _ in range(repeats + 1):
        for label, sim in sims.items():
            out[label] = max(out[label], _time(sim, steps, 1)[0])
    out["ratio"] = out["bare"] / out["all effects compiled in"]
    return out


def interleaved(sims: dict, steps: int, repeats: int) -> dict:
    """Best polygon-steps/s and best per CPU-s of each of ``sims`` (label -> sim), timed in turn over ``repeats``
    + 1 rounds.
    """
    out = {label: [0.0, 0.0] for label in sims}
    for _ in range(repeats + 1):
        for label, sim in sims.items():
            rate, rate_cpu = _time(sim, steps, 1)
            out[label] = [max(out[label][0], rate), max(out[label][1], rate_cpu)]
    return out


def narrow_phase(n: int, warm: int, steps: int, repeats: int, threads: int) -> dict:
    """Whole-polygon clipping (``trim=False``) vs the facing-chain narrow phase (``trim=True``, the default) on
    the same pile, interleaved rounds, best of each; both per wall and per CPU second. Also what was checked:
    the largest position difference between the two runs (round-off of a chaotic system: grows with steps).
    """
    numba.set_num_threads(threads)
    sims = {}
    for label, trim in (("whole-polygon clipping", False), ("facing chain", True)):
        sim = Simulation(pile(n, 0.1, "swap"), seed=1)
        sim._stepper = K.make_stepper(*sim.effects.values(), trim=trim)
        sim.advance(warm)
        sims[label] = sim
    out = interleaved(sims, steps, repeats)
    a, b = sims.values()
    out["max_position_difference_m"] = float(np.abs(a.G[0, : a.n_mob, :2] - b.G[0, : b.n_mob, :2]).max())
    out["steps"] = a.step
    out["threads"] = threads
    return out


#: default Verlet skin before issue 15's speed work, in units of the smallest circumradius (now 0.6)
PREVIOUS_SKIN = 0.3


def previous_kernel(
    make_previous_stepper,
    n: int,
    spread: float,
    warm: int,
    steps: int,
    repeats: int,
    threads: int,
    skin: float = PREVIOUS_SKIN,
) -> dict:
    """An earlier kernel (``make_previous_stepper``, its factory) with the Verlet skin ``skin`` (units of the
    smallest circumradius; by default the one before issue 15's speed work) vs the current ones on the same pile
    (sweep), interleaved rounds, best of each per wall and per CPU second; both runs must end bit-identical.
    """
    numba.set_num_threads(threads)
    sims = {}
    for label in ("previous", "current"):
        sim = Simulation(pile(n, spread, "sweep"), seed=1)
        if label == "previous":
            sim._stepper = make_previous_stepper(*sim.effects.values())
            sim.skin = skin * float(sim.r_circ.min())
            sim.rebuild()
        sim.advance(warm)
        sims[label] = sim
    out = interleaved(sims, steps, repeats)
    a, b = sims.values()
    ca, cb = a.contacts(), b.contacts()  # live contacts, ordered by (i, j): the lists differ by their skins
    if not (
        np.array_equal(a.G, b.G) and ca.keys() == cb.keys() and all(np.array_equal(ca[k], cb[k]) for k in ca)
    ):
        raise SystemExit(
            "granular benchmark: the current kernel's trajectory differs from the previous kernel's bits"
        )
    out["threads"] = threads
    out["spread"] = spread
    out["steps"] = a.step
    out["skin"] = skin
    return out


def _narrow_phase_loop(overlap_geometry):
    """A jitted loop calling ``overlap_geometry`` (a ``_contact._overlap_geometry``) on pairs (pi, pj) ``reps``
    times with the per-pair hints, the last round's 11 outputs per pair in ``out``.
    """

    @njit
    def run(W, nc, G, pi, pj, hints, reps, out):
        rows = 2 * W.shape[1] + 4
        buf_a, buf_b = np.empty((rows, 2)), np.empty((rows, 2))
        tag_a, tag_b = np.empty(rows, np.int64), np.empty(rows, np.int64)
        side, geo = np.empty(rows), np.empty(11)
        for _ in range(reps):
            for q in range(pi.shape[0]):
                i, j = pi[q], pj[q]
                xi, yi, xj, yj = G[0, i, 0], G[0, i, 1], G[0, j, 0], G[0, j, 1]
                overlap_geometry(
                    W,
                    i,
                    nc[i],
                    j,
                    nc[j],
                    xi,
                    yi,
                    xj,
                    yj,
                    buf_a,
                    tag_a,
                    buf_b,
                    tag_b,
                    side,
                    geo,
                    True,
                    hints,
                    q,
                )
                out[q] = geo

    return run


def contact_kernels(previous_contact, n: int, warm: int, repeats: int, reps: int = 20) -> dict:
    """The narrow phase alone: ``previous_contact`` (an earlier ``_contact`` module) and the current one on every
    candidate pair with overlapping boxes of the settled pile (I = 0.1, 1 thread), interleaved rounds, best CPU
    ns per pair of each; and the largest output difference between them (0: bit-identical).
    """
    numba.set_num_threads(1)
    sim = Simulation(pile(n, 0.1, "swap"), seed=1)
    sim.advance(warm)
    pi = np.repeat(np.arange(sim.n_mob), np.diff(sim.nb_start))
    pj, box = sim.nb_j, sim.aabb
    meet = (box[pi, 1] >= box[pj, 0]) & (box[pj, 1] >= box[pi, 0])
    meet &= (box[pi, 3] >= box[pj, 2]) & (box[pj, 3] >= box[pi, 2])
    pi, pj = pi[meet], pj[meet]
    loops = {"previous": _narrow_phase_loop(previous_contact._overlap_geometry)}
    loops["current"] = _narrow_phase_loop(C._overlap_geometry)
    best = dict.fromkeys(loops, math.inf)
    outs = {}
    for _ in range(repeats + 1):
        for label, run in loops.items():
            hints, out = np.zeros((len(pi), 2), np.int64), np.empty((len(pi), 11))
            run(sim.wv, sim.nc, sim.G, pi, pj, hints, 1, out)  # compiles, warms the hints
            c0 = time.process_time()
            run(sim.wv, sim.nc, sim.G, pi, pj, hints, reps, out)
            best[label] = min(best[label], (time.process_time() - c0) / (reps * len(pi)) * 1e9)
            outs[label] = out
    a, b = outs["previous"], outs["current"]
    same_line = np.minimum(  # the crossings c1, c2 as an unordered pair
        np.abs(a[:, 1:5] - b[:, 1:5]).max(axis=1), np.abs(a[:, 1:5] - b[:, [3, 4, 1, 2]]).max(axis=1)
    )
    return {
        "pairs": len(pi),
        "ns_per_pair": best,
        "bit_identical": bool(np.array_equal(a, b)),
        "max_area_difference_rel": float(np.abs(a[:, 0] - b[:, 0]).max() / np.abs(a[:, 0]).max()),
        "max_point_difference_m": float(max(np.abs(a[:, 5:9] - b[:, 5:9]).max(), same_line.max())),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="300 particles, a few steps, 1 thread")
    add_out_argument(ap)
    ap.add_argument("--n", type=int, default=None, help="particles (default 10 000, smoke 300)")
    ap.add_argument("--methods", default="sweep,swap,cells", help="broad phases to time (comma-separated)")
    ap.add_argument("--max-threads", type=int, default=2, help="time 1 .. this many threads")
    ap.add_argument(
        "--reference",
        default=None,
        help="an earlier src/porepipe/granular/_kernels.py (git show REV:...) to time beside the current kernel",
    )
    ap.add_argument(
        "--reference-skin",
        type=float,
        default=PREVIOUS_SKIN,
        help=f"Verlet skin of the --reference run in units of R_min (default {PREVIOUS_SKIN}, the skin before issue "
        "15's speed work; 0.6, today's default, times the kernels alone)",
    )
    ap.add_argument(
        "--contact-reference",
        default=None,
        help="an earlier src/porepipe/granular/_contact.py to time the narrow phase alone beside the current one",
    )
    args = ap.parse_args()
    # as `porepipe granular` does: spin briefly at barriers only where each thread has an idle core
    openmp_wait = openmp_wait_for_idle_cores(1 if args.smoke else args.max_threads)
    methods = tuple(args.methods.split(","))
    n, warm, steps, repeats = (300, 10, 10, 1) if args.smoke else (10_000, 300, 200, 3)
    n = args.n or n
    builds = {}
    for spread in (0.1, 0.5):
        for method in methods:
            builds[(spread, method)] = list_build_cost(n, spread, method, 20, 1 if args.smoke else 3)
            print(f"N={n} I={spread:.1f} {method:6s}: {1e3 * builds[(spread, method)]:.3g} ms per list build")
    rows = []
    for spread in (0.1,) if args.smoke else (0.1, 0.5):
        for method in methods:
            for threads in (1,) if args.smoke else range(1, args.max_threads + 1):
                if threads > numba.config.NUMBA_NUM_THREADS:
                    continue
                r = measure(n, spread, method, threads, warm, steps, repeats)
                rows.append(r)
                print(
                    f"N={r['n']:6d} I={spread:.1f} {method:6s} threads={threads}: {r['rate']:.3g} polygon-steps/s, "
                    f"{r['rate_per_cpu_s']:.3g} per CPU-s "
                    f"(coordination {r['coordination']:.2f}, {r['rebuilds']} list builds)",
                    flush=True,
                )
    narrow = [narrow_phase(n, warm, steps, repeats, t) for t in ((1,) if args.smoke else (1, 2))]
    for r in narrow:
        ref, new = r["whole-polygon clipping"], r["facing chain"]
        print(
            f"narrow phase, {r['threads']} thr: whole-polygon clipping {ref[0]:.3g} polygon-steps/s ({ref[1]:.3g} per "
            f"CPU-s), facing chain (default) {new[0]:.3g} ({new[1]:.3g} per CPU-s): {new[1] / ref[1]:.2f}x per CPU-s; "
            f"positions agree to {r['max_position_difference_m']:.1e} m after {r['steps']} steps",
            flush=True,
        )
    previous = []
    if args.reference:
        make_previous = load_module(args.reference).make_stepper
        previous = [
            previous_kernel(make_previous, n, spread, warm, steps, repeats, t, args.reference_skin)
            for spread in ((0.1,) if args.smoke else (0.1, 0.5))
            for t in ((1,) if args.smoke else (1, 2))
        ]
    for r in previous:
        old, new = r["previous"], r["current"]
        print(
            f"I={r['spread']:.1f} {r['threads']} thr: --reference kernel, skin {r['skin']} R_min "
            f"{old[0]:.3g} polygon-steps/s ({old[1]:.3g} per CPU-s), "
            f"current {new[0]:.3g} ({new[1]:.3g} per CPU-s): {new[0] / old[0]:.2f}x wall, {new[1] / old[1]:.2f}x per "
            f"CPU-s; trajectories bit-identical after {r['steps']} steps",
            flush=True,
        )
    contact = None
    if args.contact_reference:
        contact = contact_kernels(load_module(args.contact_reference), n, warm, repeats)
        old, new = contact["ns_per_pair"]["previous"], contact["ns_per_pair"]["current"]
        print(
            f"narrow phase alone, {contact['pairs']} pairs, 1 thr: --contact-reference {old:.1f} ns per pair (CPU), "
            f"current {new:.1f}: {old / new:.3f}x; bit-identical {contact['bit_identical']} (largest differences: "
            f"area {contact['max_area_difference_rel']:.1e} of the largest, points {contact['max_point_difference_m']:.1e} "
            f"m; load {os.getloadavg()[0]:.1f})",
            flush=True,
        )
    cost = effect_cost(n, warm, steps, repeats)
    print(
        f"effects: bare {cost['bare']:.3g}, all compiled in {cost['all effects compiled in']:.3g} "
        f"polygon-steps/s -> compile-time switches save {cost['ratio']:.3f}x"
    )
    best = max(r["rate"] for r in rows)
    print("\n| case | polygon-steps/s | per CPU-s |\n|---|---|---|")
    for r in rows:
        print(
            f"| N={r['n']} I={r['spread']} {r['method']} {r['threads']} thr | {r['rate']:.3g} | "
            f"{r['rate_per_cpu_s']:.3g} |"
        )
    for name, rate in PEERS.items():
        print(f"| {name} (published) | {rate:.3g} | |")
    per_core = max(r["rate_per_cpu_s"] for r in rows)
    print(
        f"| target (2 cores) | {TARGET:.3g} | |\nbest here: {best:.3g} ({best / TARGET:.0%} of the target); "
        f"{per_core:.3g} per CPU-s, i.e. {2 * per_core:.3g} on 2 idle cores at perfect scaling "
        f"(load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; OpenMP barrier waiting: {openmp_wait})"
    )
    builds_out = [{"spread": k[0], "method": k[1], "seconds": v} for k, v in builds.items()]
    write_record(
        args.out,
        "granular_smoke.json" if args.smoke else "granular.json",
        {
            "rows": rows,
            "builds": builds_out,
            "effects": cost,
            "narrow_phase": narrow,
            "previous_kernel": previous,
            "contact_kernels": contact,
            "peers": PEERS,
            "target": TARGET,
            "openmp_wait": openmp_wait,
        },
    )


if __name__ == "__main__":
    main()
