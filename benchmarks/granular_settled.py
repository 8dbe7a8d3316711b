"""Polygon-steps per second in a settled pile, beside the released lattice of ``benchmarks/granular.py``.

``granular.py`` times a lattice laid out with slight overlaps in its first few ms after release (coordination
4.6): left alone it expands, so it is not the settled pile issue 15 names. Here the same N grains (same shapes and
box) start from a loose lattice at circumradius spacing, where no two overlap, and settle under gravity with velocity
Verlet at Δt = 20 µs (0.45 Δt_rule; a pile at rest stays at rest under Verlet up to 2 Δt_rule) until their
kinetic energy is below 2·10⁻⁵ J/m per grain (~7 mm/s) after at least 0.3 s. The settled positions are cached
under the output folder (a file per N, size spread and seed, with the settling parameters in its name and checked
on loading), so only the first run settles (N = 10⁴: 1.16 s simulated, 2 min on 2 cores;
coordination 3.59, as the thesis's heaps' 3.6; progress on the console). The pile is then restarted at rest at the
benchmark's Δt = 2 µs and timed (warm-up, then best of 3) beside the lattice, for 1 and 2 threads, with the
coordination of each.

    python benchmarks/granular_settled.py            # N = 10 000 (the first run settles, ~2 min; then ~25 s)
    python benchmarks/granular_settled.py --smoke    # N = 300, 1 thread
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numba
import numpy as np
from _common import add_out_argument, write_record
from granular import TARGET, measure, pile_settings, pile_shapes, pile_width

from porepipe._shared.numba_config import openmp_wait_for_idle_cores
from porepipe.granular import Simulation, polygon_properties
from porepipe.granular._settings import Integrator

#: settling step (s) and integrator: velocity Verlet at 0.45 Δt_rule for these grains (a settled pile restarted at rest
#: stays at rest under Verlet up to 2 Δt_rule, tests/unit/granular/test_pile_at_rest.py)
SETTLE_DT, SETTLE_INTEGRATOR = 2e-5, Integrator.verlet
#: settled when the kinetic energy per grain is below this (J/m) after at least SETTLE_MIN_S
SETTLED_EKIN = 2e-5
SETTLE_MIN_S, SETTLE_MAX_S, SETTLE_CHUNK_S = 0.3, 2.0, 0.02


def loose_lattice(n: int, spread: float, method: str, seed: int = 1, dt_s: float = SETTLE_DT):
    """The benchmark's grains in rows at circumradius spacing (no two overlap), in the benchmark's box."""
    outlines, phis = pile_shapes(n, spread, seed)
    rc = [
        float(np.max(np.linalg.norm(np.asarray(v) - polygon_properties(v)["centroid_m"], axis=1)))
        for v in outlines
    ]
    width = pile_width(n)
    parts, row, prev = [], [], 0.0
    x, y = 0.0, max(rc)
    for v, phi, ri in zip(outlines, phis, rc, strict=True):
        x += prev + ri if row else ri
        if x + ri > width:  # next row, two of the row's largest circumradii higher
            y += 2.0 * max(row)
            x, row = ri, []
        parts.append({"vertices_m": v.tolist(), "position_m": (x, y), "angle_rad": float(phi)})
        row.append(ri)
        prev = ri
    return pile_settings(parts, width, y, method, dt_s).model_copy(update={"integrator": SETTLE_INTEGRATOR})


def coordination(sim: Simulation) -> float:
    """Mean number of grain-grain contacts per grain."""
    return float(2.0 * np.sum(sim.contacts()["j"] < sim.n_mob) / sim.n_mob)


def settle(n: int, spread: float, seed: int) -> tuple[np.ndarray, dict]:
    """Settle the loose lattice; returns the (N, 3) positions (x, y, angle) and what the settling reached."""
    sim = Simulation(loose_lattice(n, spread, "cells", seed), seed=seed)
    chunk = int(round(SETTLE_CHUNK_S / sim.dt))
    t0 = time.perf_counter()
    while True:
        sim.advance(chunk)
        ekin = sim.kinetic_energy() / sim.n_mob
        print(
            f"settling {n} grains: {1e3 * sim.time_s:.0f} ms simulated, kinetic energy {ekin:.1e} J/m per grain, "
            f"coordination {coordination(sim):.2f} ({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )
        if (sim.time_s >= SETTLE_MIN_S and ekin < SETTLED_EKIN) or sim.time_s >= SETTLE_MAX_S:
            break
    reached = {"settle_s": sim.time_s, "ekin_J_m_per_grain": ekin, "coordination": coordination(sim)}
    return sim.position, reached


def cache_path(out: Path, n: int, spread: float, seed: int) -> Path:
    """The settled positions' file: every settling parameter is in its name."""
    return out / (
        f"granular_settled_n{n}_I{spread:g}_seed{seed}_{SETTLE_INTEGRATOR.value}_dt{SETTLE_DT:g}_ekin{SETTLED_EKIN:g}_min{SETTLE_MIN_S:g}.npz"
    )


def settled_positions(out: Path, n: int, spread: float, seed: int) -> tuple[np.ndarray, dict]:
    """Cached settled positions, or settle now and cache them (written whole, then renamed)."""
    path = cache_path(out, n, spread, seed)
    if path.exists():
        with np.load(path) as f:
            pos = f["positions"]
            if pos.shape == (n, 3):
                print(f"settled pile from {path}")
                return pos, {k: float(f[k]) for k in ("settle_s", "ekin_J_m_per_grain", "coordination")}
        print(f"{path}: {pos.shape} positions, not ({n}, 3): settling again")
    pos, reached = settle(n, spread, seed)
    out.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, positions=pos, **reached)
    os.replace(tmp, path)
    return pos, reached


def settled_pile(positions: np.ndarray, n: int, spread: float, method: str, seed: int = 1):
    """The settled grains at rest, at the benchmark's Δt."""
    outlines, _ = pile_shapes(n, spread, seed)
    parts = [
        {"vertices_m": v.tolist(), "position_m": (float(x), float(y)), "angle_rad": float(phi)}
        for v, (x, y, phi) in zip(outlines, positions, strict=True)
    ]
    return pile_settings(parts, pile_width(n), float(positions[:, 1].max()), method)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="N = 300, 1 thread")
    ap.add_argument("--method", default="cells", help="neighbour search (default cells)")
    add_out_argument(ap)
    args = ap.parse_args()
    n, warm, steps, repeats = (300, 10, 10, 1) if args.smoke else (10_000, 300, 200, 3)
    threads = (1,) if args.smoke else (1, 2)
    openmp_wait = openmp_wait_for_idle_cores(max(threads))
    spread, seed = 0.1, 1
    numba.set_num_threads(min(max(threads), numba.config.NUMBA_NUM_THREADS))
    positions, reached = settled_positions(Path(args.out), n, spread, seed)
    rows = []
    for t in threads:
        lattice = measure(n, spread, args.method, t, warm, steps, repeats)
        settled = measure(
            n, spread, args.method, t, warm, steps, repeats, settled_pile(positions, n, spread, args.method)
        )
        for name, r in (("lattice just after release", lattice), ("settled pile", settled)):
            rows.append(r | {"case": name})
            print(
                f"N={n} {name:26s} {t} thr: {r['rate']:.3g} polygon-steps/s, {r['rate_per_cpu_s']:.3g} per CPU-s "
                f"(coordination {r['coordination']:.2f}, {r['rebuilds']} list builds; load {os.getloadavg()[0]:.1f})",
                flush=True,
            )
    best = max(r["rate"] for r in rows if r["case"] == "settled pile")
    print(
        f"settled pile (coordination {reached['coordination']:.2f} when settled, {1e3 * reached['settle_s']:.0f} ms "
        f"of settling): best {best:.3g} polygon-steps/s, {100 * best / TARGET:.0f} % of the target {TARGET:.0e} on 2 "
        f"cores (OpenMP barrier waiting: {openmp_wait})"
    )
    write_record(args.out, "granular_settled.json", {"rows": rows, "settled": reached, "target": TARGET})


if __name__ == "__main__":
    main()
