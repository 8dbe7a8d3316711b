"""Galton board of thesis §2.5.4 with many balls in one board: bin counts against the binomial law (Eq. 2.58).

One board, balls fed through a funnel (drop source above a V hopper). Defaults (GaltonBoard): round pins with gaps
of 1.05 ball diameters, gamma 0.225, one ball every 0.5 s; p = 2/3 (--two-thirds, GaltonBoard.two_thirds()) by moving
each row of pins 0.312 mm to the left of the row above, at gamma 0.235 (where its decisions are uncorrelated).
Printed: P(right) and the lag-1 correlation r1 of successive
decisions with their standard errors, the bins against the binomial and chi². The thesis-like board (hexagonal
nails, gamma 1, 50 balls/s): --thesis (p = 2/3 by --tip-shift).
Each ball's bin is recorded when it passes half a row pitch below the last row, and the ball then leaves the run.

    python benchmarks/granular_galton.py --balls 400 --p 0.5
    python benchmarks/granular_galton.py --balls 2300 --seed 35               # p = 1/2, ~7 CPU-min
    python benchmarks/granular_galton.py --balls 2300 --two-thirds --seed 34  # p = 2/3, ~7 CPU-min
    python benchmarks/granular_galton.py --thesis --balls 2300 --max-stuck 5     # the thesis-like board
    python benchmarks/granular_galton.py --smoke        # 30 balls, for CI (no figures to quote)
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
from _common import add_out_argument, write_record
from scipy import stats

from porepipe.granular import GaltonBoard, chi2_binomial, decision_stats, galton_paths


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--balls", type=int, default=400)
    ap.add_argument("--p", type=float, default=0.5, help="the binomial p compared with")
    ap.add_argument(
        "--thesis", action="store_true", help="GaltonBoard.thesis_like(): hexagons, gamma 1, 50 balls/s"
    )
    ap.add_argument(
        "--two-thirds", action="store_true", help="GaltonBoard.two_thirds(), compared with p = 2/3"
    )
    ap.add_argument("--nail-corners", type=int, help="16 round pins (default), 6 hexagons")
    ap.add_argument("--tip-shift", type=float, help="hexagon tips moved left by this, m")
    ap.add_argument("--row-shift", type=float, help="each row moved left by this against the row above, m")
    ap.add_argument("--damping", type=float)
    ap.add_argument("--friction", type=float)
    ap.add_argument("--every", type=float, help="seconds between drops")
    ap.add_argument("--spacing", type=float, help="nail spacing D, m")
    ap.add_argument("--nail", type=float, help="nail circumradius, m")
    ap.add_argument("--max-stuck", type=int, default=0, help="balls that may stay in the board (arches)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--smoke", action="store_true", help="30 balls (CI smoke; no figures to quote)")
    add_out_argument(ap)
    args = ap.parse_args()
    if args.smoke:
        args.balls = 30
    fields = {
        "spacing_m": args.spacing,
        "nail_r_m": args.nail,
        "nail_corners": args.nail_corners,
        "tip_shift_m": None if args.tip_shift is None else -args.tip_shift,
        "row_shift_m": None if args.row_shift is None else -args.row_shift,
        "damping": args.damping,
        "friction": args.friction,
        "every_s": args.every,
    }
    changes = {k: v for k, v in fields.items() if v is not None}  # options given replace the board's defaults
    if args.two_thirds:
        args.p = 2 / 3
    make = (
        GaltonBoard.thesis_like if args.thesis else GaltonBoard.two_thirds if args.two_thirds else GaltonBoard
    )
    board = make(**changes)
    sim = board.simulation(args.balls, args.seed)
    t0, c0 = time.perf_counter(), time.process_time()
    dec, bins = galton_paths(sim, board, progress=True, max_stuck=args.max_stuck)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    counts = np.bincount(np.clip(bins, 0, 10), minlength=11)  # outer bins take any beyond
    exp = len(bins) * stats.binom.pmf(np.arange(11), 10, args.p)
    chi2, dof, pval = chi2_binomial(bins, args.p)
    print("P(right) per row", np.round(dec.mean(axis=0), 3).tolist())
    r = [np.corrcoef(dec[:, k], dec[:, k + 1])[0, 1] for k in range(dec.shape[1] - 1)]
    print("corr(successive decisions)", np.round(r, 3).tolist())
    st = decision_stats(dec)
    print(
        f"P(right) {st['p']:.4f} +- {st['se_p']:.4f} (p = {args.p:.4f}), pooled lag-1 correlation "
        f"{st['r1']:+.4f} +- {st['se_r1']:.4f}; {round(st['skipped'] * dec.size)} skipped nails"
    )
    print(f"{len(bins)} balls, {wall:.0f} s wall, {cpu:.0f} s CPU, {sim.step} steps, t = {sim.time_s:.2f} s")
    print("counts  ", counts.tolist(), f"({int(np.sum((bins < 0) | (bins > 10)))} beyond 0..10)")
    print("binomial", np.round(exp, 1).tolist())
    print(
        f"mean {bins.mean():.3f} (binomial {10 * args.p:.3f}), variance {bins.var(ddof=1):.3f} "
        f"(binomial {10 * args.p * (1 - args.p):.3f}); chi2 {chi2:.1f} on {dof} dof, p = {pval:.3g}"
    )
    write_record(
        args.out,
        f"granular_galton_p{args.p:.3f}_n{board.nail_corners}_g{board.damping}_mu{board.friction}"
        f"_d{board.spacing_m}_s{args.seed}.json",
        {
            "args": vars(args) | {"out": str(args.out)},
            "board": dataclasses.asdict(board),
            "counts": counts.tolist(),
            "chi2": chi2,
            "decisions": st,
            "cpu_s": cpu,
            "variance": float(bins.var(ddof=1)),
            "pvalue": pval,
        },
    )


if __name__ == "__main__":
    main()
