"""Galton board of thesis §2.5.4 with many interacting balls: bin counts against the binomial law (Eq. 2.58).

One board, balls fed through a funnel (drop source above a V hopper), hexagonal nails with the tip up; p = 2/3
by shifting the tips sideways. Each ball's bin is recorded when it passes half a row pitch below the last row,
and the ball then leaves the run (the bins below would only hold it).

    python benchmarks/granular_galton.py --balls 2300 --p 0.5
    python benchmarks/granular_galton.py --smoke        # 100 balls, for CI (no figures to quote)
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import add_out_argument, write_record
from scipy import stats

from porepipe.granular import GaltonBoard, chi2_binomial, galton_paths


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--balls", type=int, default=2300)
    ap.add_argument("--p", type=float, default=0.5, help="the binomial p compared with")
    ap.add_argument("--tip-shift", type=float, default=0.0, help="nail tips moved left by this, m")
    ap.add_argument("--damping", type=float, default=1.0)
    ap.add_argument("--friction", type=float, default=0.3)
    ap.add_argument("--every", type=float, default=0.02, help="seconds between drops")
    ap.add_argument("--spacing", type=float, default=0.010, help="nail spacing D, m")
    ap.add_argument("--nail", type=float, default=0.002, help="nail (hexagon) circumradius, m")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--smoke", action="store_true", help="100 balls (CI smoke; no figures to quote)")
    add_out_argument(ap)
    args = ap.parse_args()
    if args.smoke:
        args.balls = 100
    board = GaltonBoard(args.spacing, args.nail, -args.tip_shift, args.damping, args.friction, args.every)
    sim = board.simulation(args.balls, args.seed)
    t0 = time.perf_counter()
    dec, bins = galton_paths(sim, board, progress=True)
    wall = time.perf_counter() - t0
    counts = np.bincount(np.clip(bins, 0, 10), minlength=11)  # outer bins take any beyond
    exp = len(bins) * stats.binom.pmf(np.arange(11), 10, args.p)
    chi2, dof, pval = chi2_binomial(bins, args.p)
    print("P(right) per row", np.round(dec.mean(axis=0), 3).tolist())
    r = [np.corrcoef(dec[:, k], dec[:, k + 1])[0, 1] for k in range(dec.shape[1] - 1)]
    print("corr(successive decisions)", np.round(r, 3).tolist())
    print(f"{len(bins)} balls, {wall:.0f} s wall, {sim.step} steps, t = {sim.time_s:.2f} s")
    print("counts  ", counts.tolist(), f"({int(np.sum((bins < 0) | (bins > 10)))} beyond 0..10)")
    print("binomial", np.round(exp, 1).tolist())
    print(
        f"mean {bins.mean():.3f} (binomial {10 * args.p:.3f}), variance {bins.var(ddof=1):.3f} "
        f"(binomial {10 * args.p * (1 - args.p):.3f}); chi2 {chi2:.1f} on {dof} dof, p = {pval:.3g}"
    )
    write_record(
        args.out,
        f"granular_galton_p{args.p:.3f}_g{args.damping}_mu{args.friction}_d{args.spacing}.json",
        {
            "args": vars(args) | {"out": str(args.out)},
            "counts": counts.tolist(),
            "chi2": chi2,
            "pvalue": pval,
        },
    )


if __name__ == "__main__":
    main()
