"""κ-based stop against the thesis's density rule on porous volumes: steps, time and κ̂ of each.

Both rules watch the same trajectory (same lattice, operator and checks), so one run to the density rule (δρ < 1e-9,
δv < 1e-4 and δκ < 1e-5 over a 500-step window: the tight rule) also shows where ``stop: kappa`` (δκ and the
estimated remaining error below ``tolerance_kappa`` = 1e-5, the default) would have ended: the first check in its
history where both are below the tolerance. The κ stop's κ̂ is the history's κ̂ there, its time the run's time per
step times its steps. ``--separate`` (and ``--smoke``, always) also runs ``stop: kappa`` itself and checks that it
stops at that step with that κ̂, bit for bit.

Default volumes (the issue's porous samples; each made by the workflow if missing, ~2 min once): the mini scene at
4 µm (25³, CLI walls from its grey volume), the image-to-model scene's image (64³ at 2 µm, halfway walls: no model
geometry) and the decorated fontainebleau-like model at 8 µm (40³, CLI walls at the exact polyhedral grains). The
default run takes ~2–5 min on this shared 2-core machine (the decorated model's density run: 90 000 steps).

Usage: python benchmarks/lbm_kappa_stop.py [VOLUME[=GEOMETRY] ...] [--axis z] [--walls cli|mr1] [--separate]
       VOLUME = binary_a{a}.h5, GEOMETRY = grains.h5 (exact decorated grains), packing.h5 (exact spheres) or
       grey_a{a}.h5 (grey-value walls); without GEOMETRY halfway walls
       python benchmarks/lbm_kappa_stop.py --smoke   (a generated 24³ porous volume, halfway walls, ~10 s)
Writes lbm_kappa_stop.json into --out (default results/benchmarks).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from _common import add_out_argument, write_record

from porepipe._shared.store import read_binary_volume
from porepipe.lbm import Settings, permeability
from porepipe.lbm._walls import geometry_from_files

ROOT = Path(__file__).resolve().parents[1]
#: the issue's porous samples: (scene, binary volume, wall geometry or "")
DEFAULT = (
    ("mini", "results/mini/segment/binary_a4.h5", "results/mini/voxelize/grey_a4.h5"),
    ("image-to-model", "results/image-to-model/acquire_binary/binary_a2.h5", ""),
    (
        "fontainebleau-like",
        "results/fontainebleau-like/segment/binary_a8.h5",
        "results/fontainebleau-like/decorate/grains.h5",
    ),
)
#: the density rule's step limit (the decorated model needs ~90 000 steps)
MAX_STEPS = 400_000


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


def _default_specs() -> list[str]:
    """The default volumes as ``VOLUME[=GEOMETRY]``; runs the workflow for any that is missing."""
    specs = []
    for scene, binary, geometry in DEFAULT:
        missing = [f for f in (binary, geometry) if f and not (ROOT / f).is_file()]
        if missing:
            cmd = [sys.executable, "-m", "porepipe", "run", scene, "--", *missing]
            print(f"making {', '.join(missing)}: {' '.join(cmd[1:])}", flush=True)
            subprocess.run(cmd, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
        specs.append(str(ROOT / binary) + (f"={ROOT / geometry}" if geometry else ""))
    return specs


def _volume(spec: str):
    """(pore, voxel_um, geometry or None, label) of ``VOLUME[=GEOMETRY]``."""
    path, _, geometry_path = spec.partition("=")
    pore, meta = read_binary_volume(path)
    geometry = None
    if geometry_path:
        name = Path(geometry_path).name
        kind = "grains" if name.startswith("grains") else "packing" if name.startswith("packing") else "grey"
        geometry = geometry_from_files(
            pore.shape,
            meta.voxel_um,
            meta.origin_um,
            threshold=meta.attrs.get("threshold"),
            periodic=meta.periodic,
            **{kind: geometry_path},
        )
    label = str(Path(path).relative_to(ROOT)) if Path(path).is_relative_to(ROOT) else path
    return pore.astype(bool), meta.voxel_um, geometry, label


def kappa_stop_in(history: dict, tolerance: float) -> int | None:
    """Index of the first check at which ``stop: kappa`` declares convergence (δκ and the error estimate below
    ``tolerance``, the solver's rule), or None.
    """
    ok = (history["delta_kappa"] < tolerance) & (history["kappa_error"] < tolerance)
    hits = np.flatnonzero(ok)
    return int(hits[0]) if hits.size else None


def _run(pore, axis, settings, voxel_um, geometry):
    t0 = time.perf_counter()
    res = permeability(pore, axis, settings, voxel_um, progress=False, geometry=geometry)
    return res, time.perf_counter() - t0


def compare(pore, voxel_um, geometry, axis: str, label: str, walls: str, separate: bool) -> dict:
    """One run to the density rule; the κ stop read from its history (and run itself if ``separate``)."""
    walls = walls if geometry is not None else "halfway"
    base = Settings(walls=walls, max_steps=MAX_STEPS, accept_unconverged=True)
    dens, wall_s = _run(pore, axis, base.model_copy(update={"stop": "density"}), voxel_um, geometry)
    h = dens.history
    k = kappa_stop_in(h, base.tolerance_kappa)
    out = {
        "volume": label,
        "shape": list(pore.shape),
        "porosity": float(pore.mean()),
        "walls": dens.walls,
        "tolerance_kappa": base.tolerance_kappa,
        "density": {
            "steps": dens.steps,
            "wall_s": wall_s,
            "kappa_lu": dens.kappa_lu,
            "kappa_mD": dens.kappa_mD,
            "converged": dens.converged,
            "stopped_by": dens.stopped_by,
        },
    }
    if k is None:
        out["kappa"] = None
        return out
    steps = int(h["step"][k])
    out["kappa"] = {
        "steps": steps,
        "wall_s": wall_s * steps / dens.steps,  # the same steps cost the same
        "kappa_lu": float(h["kappa"][k]),
        "kappa_error": float(h["kappa_error"][k]),
    }
    out["kappa_difference"] = out["kappa"]["kappa_lu"] / dens.kappa_lu - 1
    out["step_ratio"] = steps / dens.steps
    if separate:
        real, real_s = _run(pore, axis, base, voxel_um, geometry)
        out["kappa"]["wall_s"] = real_s
        out["separate_run_agrees"] = bool(
            real.stopped_by == "kappa" and real.steps == steps and real.kappa_lu == out["kappa"]["kappa_lu"]
        )
    return out


def _line(row: dict) -> str:
    d, k = row["density"], row["kappa"]
    head = f"{row['volume']}: {row['shape']} phi={row['porosity']:.3f} walls={row['walls']}  "
    dens = f"density rule {d['steps']} steps {d['wall_s']:.1f} s" + (
        "" if d["converged"] else " (did NOT converge: step limit)"
    )
    if k is None:
        return head + dens + "; the kappa rule never fired"
    agree = {True: "; separate kappa run: same step and kappa", False: "; separate kappa run DIFFERS"}
    return (
        head
        + f"kappa rule {k['steps']} steps {k['wall_s']:.1f} s ({row['step_ratio']:.2f} of the steps), "
        + dens
        + f"; kappa differs by {100 * row['kappa_difference']:+.4f} % (estimate {k['kappa_error']:.1e})"
        + agree.get(row.get("separate_run_agrees"), "")
    )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("volumes", nargs="*", help="binary_a{a}.h5[=grains.h5|packing.h5|grey_a{a}.h5]")
    p.add_argument("--axis", default="z")
    p.add_argument("--walls", default="cli", choices=["cli", "mr1"], help="walls where a geometry is given")
    p.add_argument("--separate", action="store_true", help="also run the kappa stop itself and compare")
    add_out_argument(p)
    p.add_argument("--smoke", action="store_true", help="a generated 24³ porous volume only")
    args = p.parse_args(argv)
    if args.smoke:
        cases, args.separate = [(_generated(), 1.0, None, "generated 24^3")], True
    else:
        cases = [_volume(v) for v in (args.volumes or _default_specs())]
    slit = np.ones((6, 6, 6), dtype=bool)
    slit[:, :, 0] = False
    permeability(
        slit, "x", Settings(walls="halfway"), progress=False
    )  # compile first: the times are the runs'
    rows = []
    for pore, voxel_um, geometry, label in cases:
        rows.append(compare(pore, voxel_um, geometry, args.axis, label, args.walls, args.separate))
        print(_line(rows[-1]), flush=True)
    write_record(args.out, "lbm_kappa_stop.json", rows)
    bad = [r["volume"] for r in rows if r.get("separate_run_agrees") is False]
    if bad:
        raise SystemExit(f"the kappa run itself stopped elsewhere than the replayed rule on {', '.join(bad)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
