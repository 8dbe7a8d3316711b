"""A sphere packing larger than the memory budget through voxelize -> segment -> minkowski, with time and peak memory.

The spheres are a Boolean model (uniform random centres, one radius, overlaps allowed) at the given porosity, in a
periodic box of ``n`` µm at a voxel size of 1 µm, so the volume has n³ voxels. Each stage runs as its own
``porepipe`` process with the scene's ``resources.memory_budget_mb``; the peak resident memory of each process
(``wait4`` rusage) and its wall time are printed next to the volume's size. With the default budget of 4000 MB a
2048³ volume (8.6 GB) cannot be held: minkowski then goes box by box with Dask, voxelize and segment slab by slab.

    python benchmarks/chunked_volume.py                 # 512³ with a 64 MB budget (about 1-2 min on 2 cores)
    python benchmarks/chunked_volume.py --full          # 2048³ with a 4000 MB budget (needs ~10 GB of disk)
    python benchmarks/chunked_volume.py --n 1024 --budget-mb 500
    python benchmarks/chunked_volume.py --full --tiled 128   # 2048³ grey tiled from one voxelized 128³ cell
    python benchmarks/chunked_volume.py --smoke         # 64³ with a 1 MB budget (CI smoke; no figures to quote)

``--tiled C`` voxelizes one periodic cell of C voxels and writes the n³ grey volume as (n/C)³ copies of it (the
voxelize stage takes ~1 h for 2048³ on 2 loaded cores); segment and minkowski then run as above, and their result
is checked against the cell: a periodic tiling has the cell's φ, S_V, K_V, T_V exactly and (n/C)³ times its χ.

Writes ``chunked_volume.json`` into ``--out`` (default ``results/benchmarks/``); the volumes go to a work folder
there that is deleted at the end unless ``--keep``.
"""

from __future__ import annotations

import argparse
import math
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import add_out_argument, write_record

STAGES = ("voxelize", "segment", "minkowski")


def boolean_spheres(n: int, radius: float, porosity: float, seed: int = 0) -> np.ndarray:
    """Rows x y z r (µm) of a Boolean model with expected porosity ``porosity`` in the box [0, n)³."""
    count = int(round(-math.log(porosity) * n**3 / (4.0 / 3.0 * math.pi * radius**3)))
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.random((count, 3)) * n, np.full(count, float(radius))])


def write_scene(work: Path, n: int, spheres: np.ndarray, budget_mb: int) -> Path:
    np.savetxt(work / "spheres.xyzr", spheres, fmt="%.6f")
    scene = work / "scene.yaml"
    scene.write_text(
        f"name: chunked\ndomain: {{size_um: [{n}, {n}, {n}], periodic: true}}\n"
        "spheres: {xyzr: spheres.xyzr}\nresolutions_um: [1.0]\nanalyses: [minkowski]\n"
        f"resources: {{memory_budget_mb: {budget_mb}}}\n"
    )
    return scene


def _hwm_mb(pid: int) -> float:
    """VmHWM (peak resident set since the process's exec) of ``pid`` in MB; 0 once it is gone."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


def run_stage(argv: list[str], threads: int) -> dict:
    """Run one porepipe command; its wall time (s) and peak resident memory (MB).

    The peak is the child's VmHWM, read every 0.2 s while it runs: rusage's ru_maxrss would also count the memory of
    this process at the fork (it survives exec), which the tiled run makes large.
    """
    cmd = [sys.executable, "-m", "porepipe.cli", *argv]
    if argv[0] != "segment":  # segment is numpy only, no numba threads
        cmd += ["--threads", str(threads)]
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, text=True)
        peak = 0.0
        while proc.poll() is None:
            peak = max(peak, _hwm_mb(proc.pid))
            time.sleep(0.2)
        seconds = time.perf_counter() - t0
        log.seek(0)
        out = log.read()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv[:1])} failed:\n{out}")
    return {"seconds": seconds, "peak_mb": peak, "output": out.strip().splitlines()[-1:]}


def baseline_mb() -> float:
    """Peak RSS of a process that only imports the three stages and Dask (interpreter, numba, xarray, h5py)."""
    imports = "import porepipe.cli, porepipe.voxelize._run, porepipe.segment._run, porepipe.minkowski._run, dask, time"
    proc = subprocess.Popen([sys.executable, "-c", f"{imports}; time.sleep(1.0)"])
    time.sleep(0.5)
    peak = 0.0
    while proc.poll() is None:
        peak = max(peak, _hwm_mb(proc.pid))
        time.sleep(0.1)
    return peak


def commands(work: Path, scene: Path, budget_mb: int) -> dict[str, list[str]]:
    grey, binary, mink = work / "grey.h5", work / "binary.h5", work / "minkowski.h5"
    return {
        "voxelize": ["voxelize", str(scene), "--a", "1.0", "-o", str(grey)],
        "segment": ["segment", str(grey), "-o", str(binary), "--memory-budget-mb", str(budget_mb)],
        "minkowski": ["minkowski", str(binary), "--scene", str(scene), "-o", str(mink)],
    }


def write_tiled_grey(work: Path, n: int, cell: int, radius: float, porosity: float) -> dict:
    """grey.h5 of n³ voxels tiled from one voxelized periodic cell; returns the time and the cell's pore volume."""
    from porepipe._shared.grey import write_grey_volume
    from porepipe._shared.store import ResultWriter
    from porepipe.segment._api import choose_threshold, segment
    from porepipe.segment._settings import SegmentationMethod
    from porepipe.voxelize import grey_histogram, voxelize

    if n % cell:
        raise SystemExit(f"--tiled {cell} must divide --n {n}")
    spheres = boolean_spheres(cell, radius, porosity)
    grey = voxelize(spheres[:, :3], spheres[:, 3], (cell,) * 3, 1.0, periodic=True)
    reps = n // cell
    t0 = time.perf_counter()
    slabs = ((i0, np.tile(grey, (1, reps, reps))) for i0 in range(0, n, cell))
    with ResultWriter(work / "grey.h5", stage="voxelize", scene="chunked") as w:
        write_grey_volume(w, slabs, (n, n, n), 1.0, True, {"tiled_from": cell})
    threshold = choose_threshold(grey_histogram(grey), SegmentationMethod.otsu).value
    return {"seconds": time.perf_counter() - t0, "cell_pore": segment(grey, threshold), "reps": reps}


def check_tiled(work: Path, cell_pore: np.ndarray, reps: int) -> str:
    """Compare minkowski.h5 of the tiling with the functionals of its cell (densities equal, χ times reps³)."""
    from porepipe._shared.store import read_table
    from porepipe.minkowski import minkowski_functionals

    got = read_table(work / "minkowski.h5").sel(phase="pore")
    ref = minkowski_functionals(cell_pore, 1.0, periodic=True).sel(phase="pore")
    for key in ("phi", "S_V", "K_V", "T_V"):
        np.testing.assert_allclose(float(got[key]), float(ref[key]), rtol=1e-12, err_msg=key)
    if round(float(got["chi"])) != round(float(ref["chi"])) * reps**3:
        raise SystemExit(f"chi {float(got['chi'])} != {reps**3} x {float(ref['chi'])}")
    return f"equals the cell's functionals (densities to 1e-12, chi = {reps}^3 x {float(ref['chi']):g})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=512, help="voxels per edge (default 512)")
    parser.add_argument("--budget-mb", type=int, default=64, help="resources.memory_budget_mb (default 64)")
    parser.add_argument("--full", action="store_true", help="2048³ with a 4000 MB budget (the issue's case)")
    parser.add_argument("--smoke", action="store_true", help="64³ with a 1 MB budget (CI smoke)")
    parser.add_argument("--radius", type=float, default=32.0, help="sphere radius in µm (= voxels)")
    parser.add_argument("--porosity", type=float, default=0.35)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--keep", action="store_true", help="keep the work folder with the volumes")
    parser.add_argument("--tiled", type=int, help="tile the grey volume from one voxelized cell of this edge")
    add_out_argument(parser)
    args = parser.parse_args()
    if args.full:
        args.n, args.budget_mb = 2048, 4000
    if args.smoke:
        args.n, args.budget_mb, args.radius = 64, 1, 8.0
    work = Path(args.out) / f"chunked_volume_work_{args.n}"
    work.mkdir(parents=True, exist_ok=True)
    spheres = boolean_spheres(args.n, args.radius, args.porosity)
    scene = write_scene(work, args.n, spheres, args.budget_mb)
    rows, base, check = [], baseline_mb(), ""
    print(f"baseline (imports only): {base:.0f} MB", flush=True)
    stages = commands(work, scene, args.budget_mb)
    try:
        if args.tiled:
            tiled = write_tiled_grey(work, args.n, args.tiled, args.radius, args.porosity)
            stages.pop("voxelize")
            rows.append({"stage": f"tile grey from a {args.tiled}³ cell", "seconds": tiled["seconds"]})
            rows[-1].update(peak_mb=float("nan"), file_gb=(work / "grey.h5").stat().st_size / 1e9)
            print(f"tiled grey written: {tiled['seconds']:.1f} s", flush=True)
        for stage, argv in stages.items():
            row = {"stage": stage, **run_stage(argv, args.threads)}
            row["file_gb"] = (work / Path(argv[argv.index("-o") + 1]).name).stat().st_size / 1e9
            rows.append(row)
            print(
                f"{stage}: {row['seconds']:.1f} s, peak {row['peak_mb']:.0f} MB; {row['output']}", flush=True
            )
        if args.tiled:
            check = check_tiled(work, tiled["cell_pore"], tiled["reps"])
            print(f"check: {check}")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    volume_gb = args.n**3 / 1e9
    source = f"{len(spheres)} spheres of r = {args.radius:g}"
    if args.tiled:
        source = f"tiled from a {args.tiled}³ periodic cell of {len(boolean_spheres(args.tiled, args.radius, args.porosity))} spheres of r = {args.radius:g}"
    print(
        f"\n# {args.n}³ voxels ({volume_gb:.2f} GB as uint8), {source}, "
        f"budget {args.budget_mb} MB, {args.threads} threads (shared machine)\n"
    )
    print(f"baseline: a process that only imports the stages holds {base:.0f} MB (not volume data)\n")
    print("| stage | wall [s] | peak RSS [MB] | peak - baseline [MB] | file [GB] |\n|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['stage']} | {r['seconds']:.1f} | {r['peak_mb']:.0f} | {r['peak_mb'] - base:.0f} | "
            f"{r['file_gb']:.2f} |"
        )
    record = {
        "n": args.n,
        "budget_mb": args.budget_mb,
        "spheres": len(spheres),
        "radius_um": args.radius,
        "threads": args.threads,
        "volume_gb": volume_gb,
        "rows": rows,
        "baseline_mb": base,
        "tiled_from": args.tiled,
        "check": check,
        "peak_within_budget": all(r["peak_mb"] <= args.budget_mb for r in rows),
        "peak_above_baseline_within_budget": all(r["peak_mb"] - base <= args.budget_mb for r in rows),
    }
    write_record(args.out, f"chunked_volume_{args.n}.json", record)


if __name__ == "__main__":
    main()
