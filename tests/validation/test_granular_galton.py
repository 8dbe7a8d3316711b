"""Thesis §2.5.4 Galton board (10 rows of nails): bins against the binomial law (Eq. 2.58).

What the thesis did: ~2300 balls dropped into ONE board of hexagonal nails (tips up; p = 2/3 by shifting the
tips), the balls counted in each shaft and plotted next to N b_{10,p}(k); "the values agree well", judged by eye
(Figs. 2.40-2.41: no statistic, no nail spacing, damping or friction given).

Part 1, the thesis's set-up (GaltonBoard.thesis_like(): one board, balls dropped into a V hopper at 50/s, funnel outlet 2.5
ball diameters above the top nail, hexagonal nails of circumradius 2 mm, balls 16-gons of radius 2 mm, mu = 0.3).
Measured 2026-12-02 (benchmarks/granular_galton.py; variance of the bin, Binomial(10, 1/2): 2.5):

    D = 12 mm, 2300 balls, gamma 0.5: variance 9.29, chi² 6536 on 8 dof (p = 0), decisions' lag-1 correlation
                                     0.24-0.43; 181 balls beyond bins 0..10 (they hop over nails)
    D = 12 mm, 300 balls, gamma 0.5 / 1.5 / 3: variance 10.9 / 9.6 / 19.6, correlation 0.3-0.5 / 0.4-0.8 / 0.7-0.9
    D = 14 mm, 300 balls, gamma 0.3 / 1.0: variance 10.6 / 9.4
    D = 10 mm, 300 balls, gamma 0.5 / 1.0: variance 6.76 / 5.71, correlation 0.01-0.24 / 0.15-0.28 (closest)
    D = 10 mm, 2300 balls, gamma 1.0: bins [57 137 200 270 328 334 350 260 182 111 71] (binomial x 2300:
                                     [2 22 101 270 472 566 472 270 101 22 2]), mean 4.97, variance 6.11,
                                     chi² 2494 on 8 dof (p = 0), correlation 0.23-0.29, 41 balls beyond 0..10
    D =  9 mm (gaps 1.4 ball diameters): the stream jams.

So the many-ball board is not binomial either: a ball carries its sideways momentum from row to row
(successive decisions positively correlated: a persistent walk), the wider the gaps the more; interactions in a
stream of 50 balls/s do not reset it, and a board tight enough to channel the balls jams. A two-state Markov walk
with lag-1 correlation 0.26 has variance 2.5 x 1.61 = 4.0; the rest of the 6.1 is hops over a nail and longer
memory. The tips shifted by
1 mm to the left move the distribution to the right (D = 12 mm, gamma 0.5: P(right) 0.54-0.62 per row, mean bin
6.02 at 300 balls; 6.26 at 2300, variance 9.9, chi² against Binomial(10, 2/3) 12791, p = 0), the asymmetry the
thesis shows. The tests pin this on GaltonBoard.thesis_like(); chi² rejects it.

Part 2, independent balls (one ball per board, the chi² test's premise).
Set-up: each ball falls through a board of its own (boards side by side, 14 nail spacings apart, so balls never
meet and every ball is an independent trial, which the chi² test needs). Nails are round (16-gon walls, radius 1.5 mm) on a triangular lattice (spacing d = 8 mm,
row pitch d sqrt(3)/2), so no ball can rest on a tip; balls are 16-gons of radius 2 mm released at rest above the
top nail with a uniform +-0.2 mm horizontal jitter and a random orientation. A ball's bin is the nearest
integer to (x - x0)/d + 5 when its centre passes half a row pitch below the last row (10 decisions of +-d/2).

Finding (measured 2026-12-02 on a loaded 2-core machine, mu = 0.3, 200 balls per gamma): the bin distribution is
NOT binomial, and its width is set by the normal damping gamma, i.e. by how much horizontal momentum a ball
carries from one nail to the next, not by chance:

    gamma  0.5: variance 14.6 (balls hop over nails; 22 and 21 balls in the outer bins 0 and 10)
    gamma  1.0: variance  4.44
    gamma 1.25: variance  2.40, yet bins [0 2 16 15 51 37 57 15 5 2 0] (chi² ~ 25 on 8 dof, p ~ 0.002:
                even bins 4 and 6 over-full, bin 5 short)
    gamma  1.5: variance  1.29
    gamma  3.0: every ball follows the same deterministic zig-zag after its first decision (L R R L L R R L ...)

Not a resolution artefact (150 balls, gamma = 1, mu = 0.3; sample-variance SE ~ 0.5): variance 4.59 at the
default dt, 4.02 at dt/2, 4.88 with 32-gon balls, 4.64 at E = 1e7 N/m. Friction matters as much as gamma
(gamma = 1.25, 150 balls): mu = 0 gives variance 12.6 (balls slide off keeping their momentum), mu = 0.8 gives 2.14.

Binomial(10, 1/2): variance 2.5. A single dissipative ball forgets its one random number (the release jitter)
instead of amplifying it into 10 independent decisions: with strong damping the nail-to-nail map contracts onto a
periodic orbit, with weak damping the ball keeps its momentum (persistent walk). Tuning gamma until the variance
matches would not make the decisions independent (gamma 1.25 matches the variance and still fails chi²), so the
issue's check "bin counts pass a chi² test against the binomial" is not met by either set-up; the tests below pin
the measured behaviour and the power of the chi² test that the binomial check uses.

Part 3, a board with independent decisions (GaltonBoard, at the former default gamma = 0.15), measured 2026-12-03 on the loaded 2-core
machine. What Parts 1-2 lack: a ball must not carry its sideways momentum from one row to the next, and the state it
arrives with at a nail must be spread by chaos, not contracted by damping. Both hold when the gaps are barely wider
than a ball and the balls are fairly elastic: a ball rattles between the two pins of a gap (each bounce on a convex
pin spreads its state, as in a dispersing billiard), the pins turn its sideways velocity around, and it leaves the
gap near its centre -- right above the next pin's apex -- with a fresh random offset. Board: round pins (16-gons,
r = 1.9 mm) at D = 8 mm, gaps 1.05 ball diameters; gamma = 0.15 (restitution of a disk on a plane 0.83-0.87 at
0.1-0.6 m/s, like glass or steel balls), mu = 0.3; an entry row of pins under the funnel (without it the first
bounce, off the top pin, flew over the top row's nails: 3 of 40 balls skipped one); one ball per 0.5 s (up to about five
in the board at a time: a ball takes up to ~2.5 s through it).

One ball per board (Part 2's set-up, released at rest on the top pin), variance against 2.5, lag-1 correlation r1
of successive decisions, chi² p against Binomial(10, 1/2) (decision = change of the nearest lattice bin):

    pins     gap/d  gamma  mu   balls  variance  r1      chi² p
    round    1.05   0.10   0.3  200    2.47      +0.015  0.79
    round    1.05   0.15   0.3  200    2.38      -0.038  0.80
    round    1.075  0.15   0.3  200    2.67      +0.028  0.80
    round    1.075  0.25   0.3  200    2.88      +0.081  0.30
    round    1.05   0.15   0.1  200    2.70      -0.003  0.21
    round    1.05   0.15   0.0  200    2.35      -0.023  0.71   (37 skipped nails: balls slide over)
    round    1.25   0.15   0.3  200    3.64      +0.114  0.012  (47 skipped nails: wide gaps keep momentum)
    round    1.05   1.0    0.3  200    0.25      -0.889  0      (deterministic zig-zag: damping contracts)
    hexagon  1.05   0.15   0.3  200    2.66      +0.024  0.25   (the thesis's nail shape works as well, but
                                                                 its many-ball board clogged the funnel at ball
                                                                 123 of 300: round pins are the default)
Many-ball board (GaltonBoard(), balls through the funnel), p = 1/2:

    balls  s per ball  seed  variance  r1      P(right)  chi² p
    300    0.5         1     2.36      -0.013  0.498     0.46
    300    0.5         2     2.38      -0.049  0.500     0.58
    300    0.5         3     2.16      -0.044  0.496     0.37
    600    0.5         4     2.82      -0.041  0.509     0.69
    300    0.25        1     2.41      -0.050  0.506     0.15
    2300   0.5         11    2.32      -0.040  0.4995    0.36   (the thesis's count; bins [1 17 86 269 490 596
                                                                 468 263 86 21 3], binomial [2 22 101 270 472 566
                                                                 472 270 101 22 2]; 29 min wall)
So chi² passes for every seed and ball count (2300 balls included); the decisions are independent but for a weak
anti-persistence, r1 = -0.040 +- 0.005 pooled over the 4100 balls (8 SE from 0): a two-state chain with that r1
has variance 2.5 x 0.92 = 2.31, as measured at 2300 balls, which chi² does not detect there (a variance test would:
2.4 SE). At 0.1 s per ball the funnel clogs: two balls arch across the entry gap, the
queue reaches the release point by t = 2.3 s and the run stops at the overlap guard).

p = 2/3 by moving each row 0.32 mm to the left against the row above (row_shift_m = -0.00032, calibrated: 0.30 mm
gave P(right) 0.646); Binomial(10, 2/3) has variance 2.22:

    balls  seed  row shift  variance  r1      P(right)  chi² p (against 2/3)
    300    1     0.30 mm    2.02      -0.099  0.646     0.044
    300    5     0.32 mm    1.77      -0.082  0.667     0.20
    300    6     0.32 mm    2.22      -0.044  0.663     0.94
    2300   12    0.32 mm    1.93      -0.074  0.6645    0.0002  (bins [0 0 2 25 120 316 560 668 410 164 35],
                                                                 binomial [0 1 7 37 131 314 523 598 449 199 40])

gamma = 0.2 (tried 2026-12-03: issue 15's notes gave r1 = +0.048 at gamma = 0.25, so r1 might cross 0
near 0.2; same shift, benchmarks/granular_galton.py --damping 0.2):

    balls  seed  row shift  variance  r1      P(right)  chi² p (against 2/3)
    2300   12    0.32 mm    2.08      -0.059  0.6475    3e-8    (bins [0 2 7 43 159 347 566 595 426 143 12];
                                                                 39 min wall on the loaded machine)
    1000   13    0.32 mm    2.03      -0.073  0.654     0.04

r1 does not cross 0 at gamma = 0.2 (SE 0.007 at 2300 balls; the per-row values are all negative, -0.02 to -0.16),
and the shift calibrated at gamma = 0.15 now gives P(right) 0.648-0.654, so chi² rejects on the mean as well.

So p = 2/3 was NOT met at the thesis's 2300 balls at gamma 0.15-0.2: a biased board is more anti-persistent (r1
-0.04 to -0.10, variance 0.8-0.9 of binomial; one ball per board gives the same: r1 -0.12 at a 0.3 mm shift, and a
tilted board, P(right) 0.64, r1 -0.06, variance 0.76 of binomial). The lag-1 correlation alone accounts for the
variance deficit: a stationary two-state chain of 10 steps with P(right) p and lag-k correlation r1^k has variance
10 p q (1 + 2 sum_k (1 - k/10) r1^k) = 1.95 (gamma 0.15, measured 1.93), 2.05 (gamma 0.2, seed 12: 2.08) and 1.98
(seed 13: 2.03), each within 0.5 SE of the sample variance; nothing else (hops over nails, longer memory) is needed.

Part 3b, the damping where successive decisions are uncorrelated (session 8, 2026-12-03, the current kernel, loaded
2-core machine, scratch scan of the same board recording each ball's decisions; SE of P(right) sqrt(pq/10n), of r1
1/sqrt(9 n); CPU s per run on one thread). r1 moves with gamma at ~3 per unit gamma near 0.23 and crosses 0 at both
p; the shift moves P(right) by ~1.5 per mm:

    gamma  shift mm  balls  seed  P(right)         r1               variance  chi² p (against p)  CPU s
    0.15   0.32      2300   12    0.6677 +- .0031  -0.062 +- 0.007  2.04      0.15                400
    0.15   0.32(gap 1.075) 1000 21 0.700 +- .0046  -0.059 +- 0.011  1.93      1e-10               117
    0.225  0.32      1000   22    0.674 +- .0047   -0.011 +- 0.011  2.25      0.65                116
    0.225  0.31      1000   23    0.658 +- .0047   -0.032 +- 0.011  2.15      0.035               119
    0.225  0         1000   24    0.504 +- .0050   -0.008 +- 0.011  2.42      0.98 (p = 1/2)      118
    0.23   0.315     1000   27    0.675 +- .0047   -0.021 +- 0.011  2.20      0.48                114
    0.24   0.32      1000   25    0.681 +- .0047   +0.024 +- 0.011  2.36      0.022               130
    0.24   0         1000   26    0.496 +- .0050   +0.020 +- 0.011  2.61      0.056 (p = 1/2)     129
    (a gamma 0.23, p = 1/2, 2300-ball run was stopped unfinished when 0.235 was chosen)

The gamma 0.15 seed-12 run differs from the earlier one with the same seed (the kernel changed since; chaotic
paths): its r1 is as negative, yet chi² passes there -- chi² at 2300 balls is a weak test of r1 = -0.06, so the
checks below test r1 against its SE directly. Chosen for p = 2/3: gamma = 0.235 and a 0.312 mm
shift (GaltonBoard.two_thirds()), then run once at 2300 balls per p (p = 1/2 at the same gamma fails; gamma 0.225
for p = 1/2, the default, see the last row):

    gamma  shift mm  balls  seed  P(right)          r1               variance  chi² p (against p)  CPU s
    0.235  0.0       2300   33    0.5002 +- 0.0033  +0.020 +- 0.007  2.772     0.00371             419  (p = 1/2)
    0.235  0.312     2300   34    0.6660 +- 0.0031  -0.016 +- 0.007  2.2       0.716               419  (p = 2/3)
    0.225  0         2300   35    0.5036 +- 0.0033  -0.018 +- 0.007  2.463     0.226               415  (p = 1/2)
    bins, p = 1/2, gamma 0.235: [1 40 108 279 448 533 461 291 102 33 4]
          p = 1/2, gamma 0.225: [1 13 97 277 450 600 462 261 108 28 3]
          (binomial x 2300:     [2 22 101 270 472 566 472 270 101 22 2])
          p = 2/3, gamma 0.235: [0 1 4 44 118 333 512 612 440 197 39]
          (binomial x 2300:     [0 1 7 37 131 314 523 598 449 199 40])

(`python benchmarks/granular_galton.py --balls 2300 --two-thirds --seed 34` reproduces the p = 2/3 row bin for bin:
414 s CPU, 417 s wall, idle-ish machine.) Both boards pass chi² at 2300 balls (p = 0.23 and 0.72); what is left is a residual anti-persistence r1 -0.016 to
-0.018, 2.3-2.6 SE from 0 (r1 moves by 0.03 for 0.01 in gamma, so this is the resolution of the gamma choice with
these runs), which a two-state chain turns into 3-4 % less variance (2.46 vs 2.5, 2.20 vs 2.22 measured: within 1 SE).

What carries the memory was looked for in each ball's state where its centre passes between a row's pins (offset
from the next pin's apex, sideways velocity, spin): on average the rebound off the gap's far pin reverses the
sideways velocity (after a right decision -0.008 to -0.014 m/s, after a left +0.006 to +0.025 m/s, spread 0.08-0.10
m/s), but a linear model of the next decision on that state explains 2-3 % of its variance and not the sign of r1
(at gamma 0.24 the reversal is still there while r1 > 0): the carrier is a nonlinear function of the rattle, not
found; damping is the knob that sets it.

Part 4, why a many-ball board jams (the thesis-like board stopped with 2 of 40 balls stuck, at rest): not a ball
held on a nail's apex but two balls side by side across a gap, each on a nail's upper side corner, pushing each
other sideways -- a two-particle arch, as in a clogged hopper. Friction holds it (mu >= 0.05 measured), without
friction it tips over (test_two_ball_arch_across_a_gap_is_held_by_friction). Any gap under two ball diameters can
hold one, so the default board feeds balls slowly enough that two seldom meet in a gap.
"""

import math

import numpy as np
import pytest
from scipy import stats

from porepipe._shared.errors import PorepipeError
from porepipe.granular import (
    GaltonBoard,
    Settings,
    Simulation,
    chi2_binomial,
    decision_stats,
    galton_paths,
    regular_polygon,
)

ROWS = 10
D = 0.008  # nail spacing, m
PITCH = D * math.sqrt(3) / 2  # row pitch (triangular lattice), m
LANE = 14 * D  # boards side by side: a ball's reach is +-(ROWS/2 + 1) d, so lanes 14 d apart never meet
R_BALL, R_NAIL, CORNERS = 0.002, 0.0015, 16


def _boards(n_balls, gamma, mu, seed):
    """n_balls independent Galton boards side by side, one ball above each top nail."""
    rng = np.random.default_rng(seed)
    ball = [tuple(p) for p in regular_polygon(CORNERS, R_BALL)]
    nail = regular_polygon(CORNERS, R_NAIL)
    particles, walls = [], []
    for b in range(n_balls):
        x0 = b * LANE
        particles.append(
            {
                "vertices_m": ball,
                "position_m": (x0 + rng.uniform(-2e-4, 2e-4), R_BALL + R_NAIL + 0.5 * PITCH),
                "angle_rad": float(rng.uniform(0, 2 * math.pi)),
            }
        )
        for k in range(ROWS):  # row k: the k + 1 reachable nails and one more on either side
            for j in range(-1, k + 2):
                centre = (x0 + (j - k / 2) * D, -k * PITCH)
                walls.append({"name": f"n{b}_{k}_{j}", "vertices_m": [tuple(p + centre) for p in nail]})
    floor_y, right = -(ROWS + 1.5) * PITCH, n_balls * LANE
    walls.append(
        {
            "name": "floor",
            "vertices_m": [
                (-LANE, floor_y - 0.01),
                (right, floor_y - 0.01),
                (right, floor_y),
                (-LANE, floor_y),
            ],
        }
    )
    settings = Settings.model_validate(
        {
            "particles": particles,
            "walls": walls,
            "gravity_m_s2": (0.0, -9.81),
            "integrator": "verlet",
            "material": {"young_N_m": 1e6, "density_kg_m2": 5000.0, "damping": gamma, "friction": mu},
        }
    )
    return Simulation(settings, seed=0), np.arange(n_balls) * LANE


def galton_bins(n_balls, gamma, mu=0.3, seed=1, t_max_s=2.0):
    """Bin index (0..10) of each ball: nearest integer to (x - x0)/d + 5 half a pitch below the last row."""
    sim, x0 = _boards(n_balls, gamma, mu, seed)
    x_out = np.full(n_balls, np.nan)
    while np.isnan(x_out).any():
        assert sim.time_s < t_max_s, "a ball did not leave the board"
        sim.advance(40)
        p = sim.position
        new = np.isnan(x_out) & (p[:, 1] < -(ROWS - 0.5) * PITCH)
        x_out[new] = p[new, 0]
    return np.rint((x_out - x0) / D + ROWS / 2).astype(int)


def chi2_binomial_pvalue(bins, p, n=ROWS):
    """Pearson chi² p-value of bin counts against Binomial(n, p), tails pooled until each expects >= 5 balls."""
    return chi2_binomial(bins, p, n)[2]


def test_chi2_bin_test_has_power_at_400_balls():
    # The sizing of the binomial check: with 400 independent balls the chi² test at alpha = 0.05 rejects
    # Binomial(10, 0.55) against p = 1/2 and a same-mean beta-binomial with 30 % more variance (rho = 0.3/9) with
    # >= 80 % power (measured by 400 synthetic boards each: ~1.0 and ~0.85; binomial SE of a power estimate at
    # 0.85 is 0.018, so the bound 0.78 is 4 SE below). Its size under the null is alpha (0.05 +- 0.035, 3.2 SE).
    rng = np.random.default_rng(7)
    reps, n = 400, 400
    a = 0.5 * (9 / 0.3 - 1)  # beta-binomial a = b with intra-class correlation rho = 1/(2a + 1) = 0.3/9

    def rejected(draw, p0):
        return np.mean([chi2_binomial_pvalue(draw(), p0) < 0.05 for _ in range(reps)])

    assert rejected(lambda: rng.binomial(10, 0.55, n), 0.5) >= 0.8
    assert rejected(lambda: stats.betabinom.rvs(10, a, a, size=n, random_state=rng), 0.5) >= 0.78
    assert abs(rejected(lambda: rng.binomial(10, 2 / 3, n), 2 / 3) - 0.05) < 0.035


@pytest.mark.slow
def test_single_ball_galton_board_width_is_set_by_damping_not_binomial():
    # 80 independent balls per gamma (mu = 0.3). Binomial(10, 1/2) has variance 2.5; the sample variance of 80
    # binomial draws has SE 2.5 sqrt(2/79) = 0.40. Measured (200 balls): 4.44 at gamma = 1 and 1.29 at
    # gamma = 1.5. Asserted: gamma = 1 exceeds 2.5 + 2.5 SE and gamma = 1.5 falls below 2.5 - 2.5 SE -- the
    # independent-ball board is not a Bernoulli process (module docstring). (chi² at 80 balls lacks the power to
    # be asserted: it gave p = 0.14 at gamma = 1 with variance above the bound.)
    # Symmetry still holds: the mean bin is 5 within 3 SE (SE = sqrt(var/80)).
    for gamma, wide in ((1.0, True), (1.5, False)):
        bins = galton_bins(80, gamma)
        var = bins.var(ddof=1)
        assert (var > 2.5 + 2.5 * 0.40) if wide else (var < 2.5 - 2.5 * 0.40), (gamma, var)
        assert abs(bins.mean() - 5) < 3 * math.sqrt(var / 80), (gamma, bins.mean())


# -- many interacting balls in one board, as the thesis did ------------------------------------------------------
TWO_THIRDS_BALLS = 150  # balls of the CI run of the p = 2/3 board
MANY = 200  # balls per CI board (the 2300-ball board of the thesis: benchmarks/granular_galton.py, report)


STUCK = (
    5  # the thesis-like board may jam: up to this many balls held in two-ball arches (Part 4) are left out
)


@pytest.fixture(scope="module")
def fair_board():
    board = GaltonBoard.thesis_like()
    return galton_paths(board.simulation(MANY), board, max_stuck=STUCK)


@pytest.mark.slow
def test_many_ball_board_is_symmetric_but_a_walk_with_memory(fair_board):
    # The thesis-like board (D = 10 mm, gamma = 1, mu = 0.3), the closest to binomial of the hexagon boards measured
    # (module docstring: variance 5.71, lag-1 correlation 0.15-0.28 per row at 300 balls). Asserted at 200 balls:
    # the mean bin is 5 within 3 SE (the board is symmetric); the variance exceeds 1.5 x 2.5 (the sampling SE of a
    # variance ~6 at 200 balls is ~0.5, so 3.75 is 4 SE below the measured value); the pooled lag-1 correlation of
    # successive decisions exceeds 0.1 (its SE for independent decisions is 1/sqrt(9 x 200) = 0.024): the
    # decisions are not independent Bernoulli trials, so the bins cannot be binomial.
    decisions, bins = fair_board
    var = bins.var(ddof=1)
    assert abs(bins.mean() - 5) < 3 * math.sqrt(var / len(bins)), bins.mean()
    assert var > 1.5 * 2.5, var
    prev, nxt = decisions[:, :-1].ravel(), decisions[:, 1:].ravel()
    assert np.corrcoef(prev, nxt)[0, 1] > 0.1


@pytest.mark.slow
def test_shifted_nail_tips_make_the_board_asymmetric():
    # Thesis Fig. 2.39: moving the tips sideways gives p != 1/2 ("the asymmetry is present"). Tips moved 1 mm to
    # the left (0.58 of the hexagon's half-width) on the wider board (D = 12 mm, gamma = 0.5; at D = 10 mm the
    # shallow right-hand faces hold balls and the stream jams): measured at 300 balls P(right) 0.54-0.62 per row
    # and mean bin 6.02 (SE 0.18). Asserted: mean bin > 5 + 3 SE.
    board = GaltonBoard.thesis_like(spacing_m=0.012, damping=0.5, tip_shift_m=-0.001)
    _, bins = galton_paths(board.simulation(MANY), board, max_stuck=STUCK)
    assert bins.mean() > 5 + 3 * math.sqrt(bins.var(ddof=1) / len(bins)), bins.mean()


@pytest.mark.slow
def test_thesis_board_is_not_binomial(fair_board):
    # The check on the thesis-like set-up fails, and is asserted to fail: chi² of its bins against
    # Binomial(10, 1/2) gives p = 1e-25 (D = 10 mm) to 1e-100 (D = 12 mm) at 300 balls, 0 at 2300.
    assert chi2_binomial_pvalue(fair_board[1], 0.5) < 1e-6


# -- the board with independent decisions (GaltonBoard defaults) --------------------------------------------------
def _assert_binomial(decisions, bins, p, r_bound):
    # chi² at size 1 %; |lag-1 correlation| < r_bound; P(right) within 3 SE of p (SE = sqrt(p (1 - p) / (10 n))),
    # no more than 1 % skipped nails
    st = decision_stats(decisions)
    assert chi2_binomial_pvalue(bins, p) > 0.01, np.bincount(np.clip(bins, 0, 10), minlength=11)
    assert abs(st["r1"]) < r_bound, st
    assert abs(st["p"] - p) < 3 * math.sqrt(p * (1 - p) / decisions.size), st
    assert st["skipped"] < 0.01, st


def test_galton_board_small_run_has_independent_decisions():
    # 60 balls (default suite, ~20 s). Power of this check (synthetic boards, 400 each): chi² at alpha = 0.05
    # rejects a same-mean beta-binomial of variance 6 (the thesis-like board's) with 0.90, of variance 4 with 0.41;
    # the lag-1 bound 0.13 is 3 SE (1/sqrt(540)) from 0 and 2-3 SE below the thesis-like board's 0.23-0.29.
    board = GaltonBoard()
    decisions, bins = galton_paths(board.simulation(60, seed=3), board)
    _assert_binomial(decisions, bins, 0.5, r_bound=0.13)


@pytest.mark.slow
def test_galton_board_bins_pass_chi2_against_binomial():
    # The check, p = 1/2: 300 balls (chi² power >= 0.8 against 30 % excess variance at 400 balls, see the
    # power test above). Measured (module docstring, Parts 3 and 3b): at gamma 0.225 r1 = -0.008 +- 0.011 (1000
    # balls, chi² p 0.98); at the former 0.15, chi² p = 0.15-0.69 over seeds and ball counts with r1 -0.040 +-
    # 0.005. Asserted: |r1| < 3 SE (SE 1/sqrt(9 x 300) = 0.019), variance within 3 SE of 2.5.
    board = GaltonBoard()
    decisions, bins = galton_paths(board.simulation(300, seed=2), board)
    _assert_binomial(decisions, bins, 0.5, r_bound=3 / math.sqrt(9 * 300))
    assert abs(bins.var(ddof=1) - 2.5) < 3 * 2.5 * math.sqrt(2 / 299)


def test_two_thirds_board_has_p_two_thirds_and_uncorrelated_decisions():
    # GaltonBoard.two_thirds() (rows shifted 0.312 mm, gamma 0.235), TWO_THIRDS_BALLS balls (~10 s CPU; 19 s wall
    # on the loaded machine). Asserted, each against its standard error (decision_stats): P(right) within 3 SE of 2/3
    # (SE 0.012 at 150 balls), the pooled lag-1 correlation r1 within 3 SE of 0 (SE 1/sqrt(9 n) = 0.027), under 1 %
    # skipped nails, and chi² against Binomial(10, 2/3) at size 1 %. Measured for this seed: P(right) 0.654, r1
    # -0.038, chi² p 0.47. Power: a shift off by 0.025 mm (P(right) off by ~0.037) fails the p check; the former
    # board (gamma 0.15, r1 -0.062 +- 0.007 at 2300 balls) fails the r1 check with ~25 % probability only -- the
    # 2300-ball confirmation (chi² p 0.72, r1 -0.016 +- 0.007) is benchmarks/granular_galton.py --two-thirds.
    board = GaltonBoard.two_thirds()
    decisions, bins = galton_paths(board.simulation(TWO_THIRDS_BALLS, seed=7), board)
    _assert_binomial(decisions, bins, 2 / 3, r_bound=3 * decision_stats(decisions)["se_r1"])


def test_two_ball_arch_across_a_gap_is_held_by_friction():
    # Why a many-ball board jams (the thesis-like board stopped with 2 of 40 balls stuck): two balls side by side
    # across a gap narrower than two diameters (hexagons 10 mm apart, side corners 6.54 mm = 1.63 ball diameters
    # apart), each resting on a nail's upper side corner (contact normal 51 deg above horizontal) and pushing the
    # other sideways: a two-particle arch, as in a clogged hopper. Without friction this symmetric equilibrium is
    # unstable (round-off tips it over; the balls fall through within 0.3 s); mu = 0.05 already holds it (measured:
    # at rest, |v| < 1e-7 m/s, sunk 0.13 mm under load). Asserted: mu = 0 falls more than a nail spacing, mu = 0.05
    # and 0.3 end at rest (|v| < 1e-5 m/s) within 0.5 mm of where they were put.
    d, rn, rb = 0.010, 0.002, 0.002
    hexagon = regular_polygon(6, rn, phase_rad=math.pi / 2)
    walls = [{"name": f"nail{i}", "vertices_m": [tuple(p + (i * d, 0.0)) for p in hexagon]} for i in (0, 1)]
    cx, cy = rn * math.cos(math.pi / 6), rn * math.sin(math.pi / 6)  # upper-right corner of the left nail
    dx = d / 2 - rb - cx
    yc = cy + math.sqrt(rb * rb - dx * dx)  # ball centres touching that corner and each other
    ball = [tuple(p) for p in regular_polygon(CORNERS, rb)]
    for mu, held in ((0.0, False), (0.05, True), (0.3, True)):
        parts = [{"vertices_m": ball, "position_m": (d / 2 + s * rb, yc + 1e-5)} for s in (-1, 1)]
        material = {"young_N_m": 1e6, "density_kg_m2": 5000.0, "damping": 1.0, "friction": mu}
        sim = Simulation(
            Settings.model_validate(
                {
                    "particles": parts,
                    "walls": walls,
                    "gravity_m_s2": (0, -9.81),
                    "integrator": "verlet",
                    "material": material,
                }
            )
        )
        start = sim.position[:, :2].copy()
        while sim.time_s < 0.3:
            sim.advance(500)
        moved = np.abs(sim.position[:, :2] - start).max()
        if held:
            assert moved < 5e-4 and np.abs(sim.velocity[:, :2]).max() < 1e-5, (mu, moved)
        else:
            assert moved > d, (mu, moved)


def test_clogged_funnel_is_one_clear_error():
    # 10 balls/s is too fast for the board at gamma = 0.15 (at the default 0.225 these 60 balls happen to pass):
    # two balls arch across the entry gap, the queue reaches the release point (measured: by t = 2.3 s) and the
    # next ball is released onto it -- an error naming the clog and the feed, not the overlap guard's advice to
    # shrink dt.
    board = GaltonBoard(every_s=0.1, damping=0.15)
    with pytest.raises(PorepipeError, match="funnel clogged .* every_s = 0.1 s"):
        galton_paths(board.simulation(60), board)


def test_board_refuses_what_it_cannot_build():
    """One kind of error for every check of the board (PorepipeError, one line): its first two raised ValueError."""
    with pytest.raises(PorepipeError, match="tip_shift_m needs hexagonal nails"):
        GaltonBoard(tip_shift_m=-0.001)
    with pytest.raises(PorepipeError, match="no gap wider than a ball"):
        GaltonBoard(spacing_m=0.0075)


def test_chi2_of_too_few_balls_is_a_clear_error():
    """Twelve balls cannot fill bins expecting five each: one line naming the count, not scipy's sum mismatch."""
    with pytest.raises(ValueError, match="12 balls are too few"):
        chi2_binomial(np.full(12, 5), 0.5)
