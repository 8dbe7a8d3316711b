"""What a longer time step buys and where it stops being stable: a settled pile restarted at rest, per integrator.

The benchmark's 8-10-gons (``granular.py``'s shapes, E = 10⁷ N/m, γ = 0.5) are settled once (``granular_settled.py``'s
cached positions, velocity Verlet), then restarted at rest at Δt = f·Δt_rule for Gear and velocity Verlet and several
tangential dampings γ_t. A pile at rest must stay at rest: the kinetic energy left from settling decays (~10⁻⁶ J/m
per grain after 20 ms); where it grows past 3·10⁻⁵ J/m per grain instead, the step is unstable. Printed per row: the
kinetic energy after 20 ms, the CPU seconds per simulated second (what the step costs), and the default step the
engine picks for the same scene (README, granular decisions: the normal and tangential damping bounds).

    python benchmarks/granular_time_step.py           # N = 600 (~2 min, the first run settles ~15 s more)
    python benchmarks/granular_time_step.py --smoke   # N = 150, two steps per case
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from _common import add_out_argument, write_record
from granular_settled import settled_pile, settled_positions

from porepipe.granular import Simulation

#: kinetic energy per grain (J/m) after the run above which the pile is called heating (stable: ~1e-6)
HEATING = 3e-5
RUN_S = 0.02


def restart(positions, n, integrator, tangential_damping, dt_s=None):
    """The settled pile at rest at step ``dt_s``, or the engine's default where it is None."""
    pile = settled_pile(positions, n, 0.1, "cells")
    d = pile.model_dump()
    d["integrator"] = integrator
    d["material"]["tangential_damping"] = tangential_damping
    d["dt_s"] = dt_s
    return Simulation(type(pile).model_validate(d), seed=1)


def scan_row(sim, n, integrator, tangential_damping):
    """Kinetic energy per grain after RUN_S and CPU seconds per simulated second of ``sim``, a pile at rest."""
    t0 = time.process_time()
    sim.advance(int(round(RUN_S / sim.dt)))
    cpu = time.process_time() - t0
    return {
        "integrator": integrator,
        "tangential_damping": tangential_damping,
        "dt_over_rule": sim.dt / sim.dt_rule,
        "ekin_J_m_per_grain": sim.kinetic_energy() / n,
        "cpu_s_per_simulated_s": cpu / sim.time_s,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="N = 150, two steps per case")
    add_out_argument(ap)
    args = ap.parse_args()
    n = 150 if args.smoke else 600
    fractions = (
        {"gear": (0.1, 0.3), "verlet": (0.5, 2.0)}
        if args.smoke
        else {
            "gear": (0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5),
            "verlet": (0.5, 1.0, 1.5, 2.0),
        }
    )
    dampings = (1.0,) if args.smoke else (0.5, 1.0, 2.0)
    positions, reached = settled_positions(Path(args.out), n, 0.1, 1)
    for integrator in fractions:  # load or compile the kernels outside the timed rows
        restart(positions, n, integrator, dampings[0]).advance(2)
    rows = []
    for integrator, steps in fractions.items():
        for td in dampings:
            default = restart(positions, n, integrator, td)
            print(
                f"{integrator}, tangential damping {td}: default step {default.dt / default.dt_rule:.3f} dt_rule"
            )
            for f in (*steps, None):
                sim = default if f is None else restart(positions, n, integrator, td, f * default.dt_rule)
                r = scan_row(sim, n, integrator, td)
                r["default"] = f is None
                r["heating"] = r["ekin_J_m_per_grain"] > HEATING
                rows.append(r)
                print(
                    f"  dt = {r['dt_over_rule']:.3f} dt_rule{' (default)' if f is None else ''}: kinetic energy "
                    f"{r['ekin_J_m_per_grain']:.1e} J/m per grain after {1e3 * RUN_S:.0f} ms "
                    f"({'HEATS' if r['heating'] else 'at rest'}), {r['cpu_s_per_simulated_s']:.2f} CPU-s per "
                    "simulated s",
                    flush=True,
                )
    bad = [r for r in rows if r["default"] and r["heating"]]
    print(f"default steps heating: {len(bad)} of {sum(r['default'] for r in rows)}")
    write_record(args.out, "granular_time_step.json", {"rows": rows, "settled": reached, "n": n})
    if bad:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
