"""Simple-cubic sphere arrays against the published drag (Zick & Homsy 1982): κ̂ against resolution, halfway and
interpolated (CLI, MR1) walls, TRT Λ = 3/16, flow along x.

Writes ``lbm_spheres.json`` into ``--out`` (default: results/benchmarks, where the report's permeability-cost
section reads it) and prints one row per run: solid fraction
c, voxels per diameter d, walls, K = L³/(6π a κ̂), its error against ZICK_HOMSY_SC, steps and CPU seconds.
The order of convergence between two resolutions is log(e₁/e₂)/log(d₂/d₁) of |error|.

Usage: python benchmarks/lbm_spheres.py [--full] [--fractions 0.125 0.343] [--diameters 8 12 16] [--shifts 5]
[--walls halfway cli mr1] [--smoke]

The default (d = 8, 12, 16) takes about a CPU-minute; ``--full`` adds d = 24 and 32, as the report's cost section
quotes them (over 10 CPU-minutes here: c = 0.125, d = 32 alone took 156 CPU-s with halfway walls).
"""

from __future__ import annotations

import argparse
import itertools
import time

from _common import add_out_argument, write_record

from porepipe.lbm import Settings, permeability
from porepipe.lbm import _calibration as cal

#: Sub-voxel shifts of the sphere for ``--shifts N`` (the first N).
SHIFTS = cal.SUBVOXEL_SHIFTS
#: voxels per sphere diameter of the default run, and of ``--full``
DIAMETERS = [8, 12, 16]
FULL_DIAMETERS = [8, 12, 16, 24, 32]


def run(
    c: float, diameter: float, walls: str, tau: float = 0.857, tolerance: float = 1e-6, shift=(0.0, 0.0, 0.0)
) -> dict:
    """One sphere array: K against Zick & Homsy, steps and cost."""
    cells = cal.cells_for_diameter(c, diameter)
    pore, geometry, a = cal.sphere_array(cells, c, shift)
    t_cpu, t_wall = time.process_time(), time.perf_counter()
    res = permeability(
        pore,
        "x",
        Settings(walls=walls, tau=tau, tolerance_kappa=tolerance),
        progress=False,
        geometry=geometry,
    )
    k = cal.drag_coefficient(res.kappa_lu, cells, a)
    ref = cal.ZICK_HOMSY_SC[c]
    return {
        "c": c,
        "cells": cells,
        "diameter": 2 * a,
        "shift": list(shift),
        "walls": res.walls,
        "tau": tau,
        "K": k,
        "K_ref": ref,
        "K_ref_rounding": cal.ZICK_HOMSY_SC_ROUNDING[c],
        "error": k / ref - 1,
        "steps": res.steps,
        "stopped_by": res.stopped_by,
        "kappa_error": res.kappa_error,
        "cpu_s": time.process_time() - t_cpu,
        "wall_s": time.perf_counter() - t_wall,
        "nodes": res.n_nodes,
        "links": res.n_links,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fractions", type=float, nargs="+", default=[0.125, 0.343])
    p.add_argument("--diameters", type=float, nargs="+", default=None, help=f"default {DIAMETERS}")
    p.add_argument("--full", action="store_true", help=f"diameters {FULL_DIAMETERS} (over 10 CPU-minutes)")
    p.add_argument("--walls", nargs="+", default=["halfway", "cli"])
    add_out_argument(p)  # the report reads lbm_spheres.json from results/benchmarks/
    p.add_argument(
        "--shifts",
        type=int,
        default=1,
        choices=range(1, len(SHIFTS) + 1),
        help="runs per case with the sphere moved by sub-voxel shifts (the error's lattice-position scatter)",
    )
    p.add_argument("--smoke", action="store_true", help="c = 0.125, d = 8 only")
    args = p.parse_args(argv)
    if args.diameters is None:
        args.diameters = FULL_DIAMETERS if args.full else DIAMETERS
    if args.smoke:
        args.fractions, args.diameters = [0.125], [8]
    rows = []
    for c in args.fractions:
        if c not in cal.ZICK_HOMSY_SC:
            p.error(f"no published drag for c = {c}; choose from {sorted(cal.ZICK_HOMSY_SC)}")
        for d in args.diameters:
            for walls, shift in itertools.product(args.walls, SHIFTS[: args.shifts]):
                row = run(c, d, walls, shift=shift)
                rows.append(row)
                print(
                    f"c={c:<6} d={row['diameter']:6.2f} L={row['cells']:3d} shift={shift} {row['walls']:8s} "
                    f"K={row['K']:.5f} "
                    f"(ZH {row['K_ref']}) err={100 * row['error']:+.3f} % steps={row['steps']} "
                    f"cpu={row['cpu_s']:.1f} s",
                    flush=True,
                )
    write_record(args.out, "lbm_spheres.json", rows)
    if not (args.full or args.smoke) and max(args.diameters) < max(FULL_DIAMETERS):
        print(f"Finer spheres (d up to {max(FULL_DIAMETERS)}): python benchmarks/lbm_spheres.py --full")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
