"""κ-based stop against the thesis's density rule on porous volumes: steps, time and κ̂ of each.

For every binary volume (``binary_a{a}.h5``; optionally ``VOLUME=grains.h5`` or ``VOLUME=grey_a{a}.h5`` for CLI walls
with exact decorated grains / grey-value walls, else halfway walls) two runs along the axis: ``stop: kappa``
(tolerance_kappa 1e-5, the default) and ``stop: density`` (δρ < 1e-9, δv < 1e-4: the thesis's tight rule). Prints and
writes (``--out``/lbm_kappa_stop.json, default results/benchmarks) the steps, wall time and the relative difference of
κ̂ between the two. The issue's target: the κ stop in well under the density rule's steps, κ̂ within 0.1 %.

Usage: python benchmarks/lbm_kappa_stop.py results/mini/segment/binary_a4.h5 \
           results/fontainebleau-like/segment/binary_a4.h5=results/fontainebleau-like/decorate/grains.h5 [--axis z]
       python benchmarks/lbm_kappa_stop.py --smoke   (a generated 24³ porous volume, halfway walls)
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _common import add_out_argument, write_record

from porepipe._shared.store import read_binary_volume
from porepipe.lbm import Settings, permeability
from porepipe.lbm._walls import geometry_from_files


def _generated(n: int = 24, seed: int = 5) -> np.ndarray:
    """Overlapping spheres (radius 3–5 voxels, periodic) at porosity ≈ 0.35."""
    rng = np.random.default_rng(seed)
    x = np.arange(n) + 0.5
    grid = np.stack(np.meshgrid(x, x, x, indexing="ij"), -1)
    solid = np.zeros((n,) * 3, dtype=bool)
    for c, r in zip(rng.uniform(0, n, (40, 3)), rng.uniform(3.0, 5.0, 40)):
        d = np.abs(grid - c)
        d = np.minimum(d, n - d)
        solid |= (d**2).sum(-1) < r * r
    return ~solid


def _volume(spec: str):
    """(pore, voxel_um, geometry or None, label) of ``VOLUME[=GEOMETRY]``."""
    path, _, geometry_path = spec.partition("=")
    pore, meta = read_binary_volume(path)
    geometry = None
    if geometry_path:
        kind = "grains" if Path(geometry_path).name.startswith("grains") else "grey"
        geometry = geometry_from_files(
            pore.shape,
            meta.voxel_um,
            meta.origin_um,
            threshold=meta.attrs.get("threshold"),
            periodic=meta.periodic,
            **{kind: geometry_path},
        )
    return pore.astype(bool), meta.voxel_um, geometry, spec


def compare(pore, voxel_um, geometry, axis: str, label: str) -> dict:
    """Run both stop rules on one volume."""
    walls = "cli" if geometry is not None else "halfway"
    out = {"volume": label, "shape": list(pore.shape), "porosity": float(pore.mean()), "walls": walls}
    for rule in ("kappa", "density"):
        t0 = time.perf_counter()
        res = permeability(
            pore,
            axis,
            Settings(walls=walls, stop=rule, max_steps=400_000, accept_unconverged=True),
            voxel_um,
            progress=False,
            geometry=geometry,
        )
        out[rule] = {
            "steps": res.steps,
            "wall_s": time.perf_counter() - t0,
            "kappa_lu": res.kappa_lu,
            "kappa_mD": res.kappa_mD,
            "stopped_by": res.stopped_by,
            "converged": res.converged,
            "kappa_error": res.kappa_error,
        }
    out["kappa_difference"] = out["kappa"]["kappa_lu"] / out["density"]["kappa_lu"] - 1
    out["step_ratio"] = out["kappa"]["steps"] / out["density"]["steps"]
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("volumes", nargs="*", help="binary_a{a}.h5[=grains.h5|grey_a{a}.h5]")
    p.add_argument("--axis", default="z")
    add_out_argument(p)
    p.add_argument("--smoke", action="store_true", help="a generated 24³ porous volume only")
    args = p.parse_args(argv)
    cases = [(_generated(), 1.0, None, "generated 24^3")] if args.smoke or not args.volumes else []
    cases += [_volume(v) for v in args.volumes]
    slit = np.ones((6, 6, 6), dtype=bool)
    slit[:, :, 0] = False
    permeability(
        slit, "x", Settings(walls="halfway"), progress=False
    )  # compile first: the times are the runs'
    rows = []
    for pore, voxel_um, geometry, label in cases:
        row = compare(pore, voxel_um, geometry, args.axis, label)
        rows.append(row)
        k, d = row["kappa"], row["density"]
        print(
            f"{label}: {row['shape']} phi={row['porosity']:.3f} walls={row['walls']}  kappa stop {k['steps']} steps "
            f"{k['wall_s']:.1f} s, density stop {d['steps']} steps {d['wall_s']:.1f} s; "
            f"kappa differs by {100 * row['kappa_difference']:+.4f} % (estimate {k['kappa_error']:.1e})"
            + ("" if d["converged"] else " -- the density run did NOT converge (step limit)"),
            flush=True,
        )
    write_record(args.out, "lbm_kappa_stop.json", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
