"""Galton board of thesis §2.5.4: one board, many balls fed through a funnel, 10 rows of nails.

Geometry (:class:`GaltonBoard`, lengths in m): nails on a triangular lattice of spacing D (row pitch D sqrt(3)/2),
``ROWS`` rows filling the board between two side walls; row 0 has a nail at x = 0 right under the funnel's outlet.
Balls are 16-gons of radius ``BALL_R``, dropped into a V hopper above the board at one every ``every_s`` seconds.

The default board (p = 1/2): round pins (16-gons) with gaps of 1.05 ball diameters, fairly elastic balls (gamma =
0.225; gamma 0.15 gave restitution 0.83-0.87) and a feed slow enough that balls seldom meet (a gap under two ball diameters can hold a
two-ball arch). A ball rattles between the two pins of a gap, so it cannot carry its sideways momentum past the next
pin, and each bounce on a convex pin spreads its state (chaotic scattering), so it arrives at the next pin's apex
with a fresh random offset. What is left of a ball's memory is set by the damping: the lag-1 correlation r1 of
successive decisions grows with gamma, about 3 per unit gamma near 0.23 (anti-persistent below, persistent above),
and crosses 0 near gamma = 0.23 at p = 1/2 but near 0.24 at p = 2/3 (at the same gamma r1 is 0.02-0.04 lower on the
biased board), so the p = 2/3 board (:meth:`GaltonBoard.two_thirds`) has its own damping, 0.235. The thesis-like
board (:meth:`GaltonBoard.thesis_like`: hexagons with a tip up, wider gaps, gamma = 1) is a persistent walk instead
(successive decisions correlated 0.2-0.4).

p != 1/2: for round pins every row is moved sideways by ``row_shift_m`` against the row above (the thesis's "a nail
not under the middle of two nails but offset"), for hexagons the tip is moved by ``tip_shift_m`` (its Fig. 2.39);
negative: to the left, so more balls pass on the right (p > 1/2). p = 2/3: a 0.312 mm shift (P(right) rises ~1.5 per
mm of shift).

Measured at 2300 balls (the thesis's count; benchmarks/granular_galton.py; SEs: P(right) sqrt(pq/23000), r1
1/sqrt(9 x 2300) = 0.007; every run made is listed in tests/validation/test_granular_galton.py, Parts 3 and 3b):
p = 2/3 board (gamma 0.235, 0.312 mm): P(right) 0.6660 +- 0.0031, r1 -0.016 +- 0.007, variance 2.20 (binomial
2.22), chi² p = 0.72. p = 1/2 at gamma 0.235: r1 +0.020 +- 0.007, variance 2.77 (2.5), chi² p = 0.004 (fails, hence
gamma 0.225 for p = 1/2): the default board P(right) 0.5036 +- 0.0033, r1 -0.018 +- 0.007, variance 2.46 (2.5), chi²
p = 0.23. At the former default gamma 0.15: p = 1/2 chi² p = 0.36 (r1 -0.040 +- 0.005),
p = 2/3 (0.32 mm) r1 -0.062 to -0.074 and chi² p = 0.0002 and 0.15 in two runs.

A ball's path is read off where its centre passes half a pitch below each row: its bin there is the number of
rights so far (nearest lattice position), a decision is the change of that bin (right = 1). Once below the last
row it leaves the run (deactivated): the bins underneath would only hold it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import stats

from porepipe._shared.errors import PorepipeError
from porepipe.granular._api import Simulation
from porepipe.granular._settings import Settings
from porepipe.granular._shapes import regular_polygon

ROWS = 10
BALL_R, BALL_CORNERS = 0.002, 16
HOPPER_W, HOPPER_H = 0.06, 0.05  # hopper top width and height
#: row shift (m) and damping of the p = 2/3 board (GaltonBoard.two_thirds): r1 crosses 0 at a higher damping than
#: at p = 1/2 (module docstring)
TWO_THIRDS_SHIFT_M, TWO_THIRDS_DAMPING = 0.000312, 0.235


@dataclasses.dataclass(frozen=True)
class GaltonBoard:
    """Geometry and material of the board (lengths in m); defaults: the board with independent decisions."""

    spacing_m: float = 0.008  # nail spacing D: gaps of 1.05 ball diameters between round pins
    nail_r_m: float = 0.0019  # pin (circum)radius
    nail_corners: int = 16  # 16: round pins; 6: the thesis's hexagons with a tip up
    tip_shift_m: float = 0.0  # hexagons only: tips moved by this (negative: to the left, p > 1/2)
    row_shift_m: float = 0.0  # each row moved by this against the row above (negative: to the left, p > 1/2)
    damping: float = 0.225  # where successive decisions are uncorrelated at p = 1/2 (module docstring)
    friction: float = 0.3
    every_s: float = 0.5  # one ball dropped into the hopper every this many seconds
    # balls are released this high above the funnel outlet (the hopper's top: HOPPER_H + 2 BALL_R)
    drop_m: float = 4 * BALL_R
    # an entry row of nails one pitch above the top row, whose central gap the funnel feeds: a ball enters the
    # board as it leaves any gap, and the first bounce cannot fly over the top row's nails
    entry_row: bool = True
    # funnel outlet width and height above the top row's centres; None: on the centres of the entry row's two
    # central nails (without an entry row, 2.5 ball diameters at nail_r_m + 3 BALL_R: the thesis-like feed of
    # 50 balls/s does not clog it)
    outlet_m: float | None = None
    outlet_y_m: float | None = None

    def __post_init__(self):
        if self.tip_shift_m and self.nail_corners != 6:
            raise PorepipeError(
                f"GaltonBoard: tip_shift_m needs hexagonal nails (nail_corners=6), got {self.nail_corners}"
            )
        if self.spacing_m - np.ptp(self.nail()[:, 0]) <= 2 * BALL_R:
            raise PorepipeError(
                f"GaltonBoard: spacing_m {self.spacing_m:g} leaves no gap wider than a ball ({2 * BALL_R:g} m) "
                f"between nails of radius {self.nail_r_m:g}"
            )
        if self.outlet_m is not None and not 2 * BALL_R < self.outlet_m <= HOPPER_W:
            raise PorepipeError(
                f"GaltonBoard: outlet_m must be wider than a ball ({2 * BALL_R:g} m) and at most the hopper's top "
                f"({HOPPER_W:g} m), got {self.outlet_m!r}"
            )

    @classmethod
    def two_thirds(cls, **changes) -> GaltonBoard:
        """The board with P(right) = 2/3: each row moved ``TWO_THIRDS_SHIFT_M`` to the left of the row above, and
        damping ``TWO_THIRDS_DAMPING`` (where its successive decisions are uncorrelated).

        ``changes`` replace fields.
        """
        return cls(**({"row_shift_m": -TWO_THIRDS_SHIFT_M, "damping": TWO_THIRDS_DAMPING} | changes))

    @classmethod
    def thesis_like(cls, **changes) -> GaltonBoard:
        """The board as the thesis describes it: hexagons tip up (D = 10 mm), gamma = 1, 50 balls/s into the hopper.

        Not binomial (successive decisions correlated 0.2-0.4, tests/validation/test_granular_galton.py);
        ``changes`` replace fields.
        """
        base = {
            "spacing_m": 0.010,
            "nail_r_m": 0.002,
            "nail_corners": 6,
            "damping": 1.0,
            "every_s": 0.02,
            "entry_row": False,
            "drop_m": HOPPER_H + 2 * BALL_R,
        }
        return cls(**(base | changes))

    @property
    def pitch_m(self) -> float:
        return self.spacing_m * math.sqrt(3) / 2

    @property
    def outlet(self) -> tuple[float, float, float]:
        """Funnel outlet (width, height above the top row's centres, centre x), m; centred over nail (0, 0)."""
        if self.entry_row:
            w, h = self.spacing_m, self.pitch_m + self.nail_r_m
        else:
            w, h = 2.5 * 2 * BALL_R, self.nail_r_m + 3 * BALL_R
        w = w if self.outlet_m is None else self.outlet_m
        h = h if self.outlet_y_m is None else self.outlet_y_m
        return float(w), float(h), float(self.nail_x(-1, -0.5))

    def nail(self) -> np.ndarray:
        """A pin (regular polygon, a corner up), for hexagons with its top corner moved by ``tip_shift_m``."""
        v = regular_polygon(self.nail_corners, self.nail_r_m, phase_rad=np.pi / 2)
        v[0, 0] += self.tip_shift_m
        return v

    def nail_x(self, row: int, j) -> np.ndarray:
        """Centre x of nail(s) j in a row (row 0: nail 0 at x = 0)."""
        return (np.asarray(j) + 0.5 * (row % 2)) * self.spacing_m + row * self.row_shift_m

    def bin_of(self, x, rows_passed: int) -> np.ndarray:
        """Number of rights after ``rows_passed`` rows of a ball at x (nearest position over the next row's nails)."""
        return np.rint((np.asarray(x) - rows_passed * self.row_shift_m) / self.spacing_m + rows_passed / 2)

    def walls(self) -> list:
        """Nails, side walls (at +-7 D), the V hopper with its outlet above nail (0, 0) (board top at y = 0)."""
        pitch, half_w = self.pitch_m, 7 * self.spacing_m
        walls, pin = [], self.nail()
        for k in range(-1 if self.entry_row else 0, ROWS):
            for j in range(-8, 9):
                x = float(self.nail_x(k, j))
                # no nail closer to a side wall than a ball diameter plus a radius: no pocket to stick in
                if half_w - abs(x) - self.nail_r_m > 3 * BALL_R:
                    corners = [tuple(p + (x, -k * pitch)) for p in pin]
                    walls.append({"name": f"nail{k}_{j}", "vertices_m": corners})
        w, y_out, xc = self.outlet  # a ball leaving the outlet falls onto the top nail
        bottom, top = -(ROWS + 0.5) * pitch, y_out + HOPPER_H
        # each wall runs so that its outside is on its left
        walls.append(_slab("left", (-half_w, bottom), (-half_w, y_out)))
        walls.append(_slab("right", (half_w, y_out), (half_w, bottom)))
        walls.append(_slab("funnel_left", (xc - 0.5 * w, y_out), (xc - 0.5 * HOPPER_W, top)))
        walls.append(_slab("funnel_right", (xc + 0.5 * HOPPER_W, top), (xc + 0.5 * w, y_out)))
        return walls

    def simulation(self, n_balls: int, seed: int = 1) -> Simulation:
        """The board with ``n_balls`` balls dropped into the funnel, ``drop_m`` above its outlet (velocity Verlet).

        A ball starts at rest (but for a downward ``3 BALL_R / every_s``) at a uniform random x across the funnel.
        """
        w, y_out, xc = self.outlet
        funnel_w = min(HOPPER_W, w + (HOPPER_W - w) * self.drop_m / HOPPER_H)
        ball = {"size_m": (BALL_R, BALL_R), "corners": BALL_CORNERS, "orientation_dist": "EQUAL"}
        source = {
            "x_m": xc,
            "y_m": y_out + self.drop_m,
            "width_m": funnel_w - 6 * BALL_R,  # clear of the funnel's walls
            "every_s": self.every_s,
            "to_s": (n_balls - 0.5) * self.every_s,
            # a ball has moved on by more than its diameter when the next one is dropped
            "velocity_m_s": (0.0, -3 * BALL_R / self.every_s),
            "shape": ball,
        }
        material = {
            "young_N_m": 1e6,
            "density_kg_m2": 5000.0,
            "damping": self.damping,
            "friction": self.friction,
        }
        settings = Settings.model_validate(
            {
                "walls": self.walls(),
                "drop_sources": [source],
                "gravity_m_s2": (0.0, -9.81),
                "integrator": "verlet",
                "skin_m": BALL_R,  # fast, sparse balls: a wide skin keeps list rebuilds rare
                "material": material,
            }
        )
        return Simulation(settings, seed=seed)


def _slab(name, a, b, thick=0.002):
    """Wall: the segment a-b thickened by ``thick`` to its left-hand side (convex quadrilateral)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    t = (b - a) / np.linalg.norm(b - a)
    n = np.array([-t[1], t[0]]) * thick
    return {"name": name, "vertices_m": [tuple(a), tuple(b), tuple(b + n), tuple(a + n)]}


def galton_paths(
    sim: Simulation,
    board: GaltonBoard,
    t_max_s: float | None = None,
    chunk: int = 40,
    progress: bool = False,
    max_stuck: int = 0,
):
    """Run until every ball has left the board; return (decisions (N, ROWS): 1 right, 0 left, other values
    a ball that skipped a nail; bins (N,)) of the N balls through.

    Parameters
    ----------
    sim : Simulation
        From :meth:`GaltonBoard.simulation`.
    board : GaltonBoard
        Its geometry (row levels, nail spacing).
    t_max_s : float, optional
        Give up at this simulated time (default: last drop + 10 s).
    chunk : int
        Steps between readings of the positions (a ball falls well under a row pitch in ``chunk`` steps).
    progress : bool
        Print the count of balls through once per simulated second.
    max_stuck : int
        Balls that may still be in the board at ``t_max_s`` (e.g. two held in an arch across a gap); they are
        left out of the result.

    Raises
    ------
    PorepipeError
        More than ``max_stuck`` balls are still in the board at ``t_max_s`` (default: last drop + 10 s), e.g. two
        held in an arch; or the funnel clogged (balls queued up to where the next one is released).
    """
    n = sim.n_mob
    t_max = (sim.insert_s.max() + 10.0) if t_max_s is None else t_max_s
    levels = -(np.arange(ROWS) + 0.5) * board.pitch_m  # half a pitch below each row
    xs = np.full((n, ROWS), np.nan)
    nxt = np.zeros(n, np.int64)  # next level each ball has to cross
    done = np.zeros(n, bool)
    last = 0.0
    while not done.all():
        if sim.time_s > t_max:
            if (~done).sum() <= max_stuck:
                break
            raise PorepipeError(
                f"galton: {int((~done).sum())} balls still in the board at t = {sim.time_s:.3g} s "
                f"(max_stuck = {max_stuck})"
            )
        _advance(sim, board, chunk)
        p = sim.position
        live = (sim.active[:n] == 1) & ~done
        for _ in range(ROWS):  # a fast ball may cross more than one level per chunk (rare): loop until none
            cross = live & (nxt < ROWS)
            cross[cross] = p[cross, 1] < levels[nxt[cross]]
            if not cross.any():
                break
            idx = np.nonzero(cross)[0]
            xs[idx, nxt[idx]] = p[idx, 0]
            nxt[idx] += 1
        out = live & (nxt == ROWS)
        if out.any():
            done |= out
            sim.remove(out)
        if progress and sim.time_s - last > 1.0:
            last = sim.time_s
            print(f"t = {sim.time_s:.1f} s: {int(done.sum())}/{n} balls through", flush=True)
    passed = np.arange(1, ROWS + 1)
    xs, n = xs[done], int(done.sum())
    lattice = board.bin_of(xs, passed).astype(np.int64)  # bin after each row
    # 1 right, 0 left (else a skipped nail)
    decisions = np.diff(np.column_stack([np.zeros(n, np.int64), lattice]), axis=1)
    bins = lattice[:, -1]
    return decisions, bins


def _advance(sim: Simulation, board: GaltonBoard, steps: int) -> None:
    """``sim.advance``; a ball released onto balls queued in the funnel (overlap guard) is a clogged funnel."""
    try:
        sim.advance(steps)
    except PorepipeError as err:
        queued = int(((sim.active[: sim.n_mob] == 1) & (sim.position[:, 1] > board.outlet[1])).sum())
        if queued < 3:
            raise
        raise PorepipeError(
            f"galton: the funnel clogged at t = {sim.time_s:.3g} s ({queued} balls queued above its outlet, the "
            f"next one released onto them); feed slower than every_s = {board.every_s:g} s"
        ) from err


def decision_stats(decisions) -> dict:
    """P(right) and the pooled lag-1 correlation of successive decisions, each with its standard error.

    Parameters
    ----------
    decisions : (N, ROWS) int array
        From :func:`galton_paths` (a skipped nail counts by its sign: 1 if > 0, else 0).

    Returns
    -------
    dict
        ``p``, ``se_p`` (sqrt(p q / (N ROWS))), ``r1``, ``se_r1`` (1/sqrt(N (ROWS - 1)): the SE of a correlation of
        independent decisions) and ``skipped`` (the fraction of decisions that skipped a nail).
    """
    d = np.clip(decisions, 0, 1)
    n, rows = d.shape
    p = float(d.mean())
    return {
        "p": p,
        "se_p": math.sqrt(p * (1 - p) / d.size),
        "r1": float(np.corrcoef(d[:, :-1].ravel(), d[:, 1:].ravel())[0, 1]),
        "se_r1": 1 / math.sqrt(n * (rows - 1)),
        "skipped": float(np.mean((decisions != 0) & (decisions != 1))),
    }


def chi2_binomial(bins, p: float, n: int = ROWS, min_expected: float = 5.0):
    """Pearson chi² of bin counts against n_balls Binomial(n, p), tails pooled until each expects >= 5 balls.

    Parameters
    ----------
    bins : (N,) int array
        Bin of each ball (values beyond 0..n count in the outer bins).
    p : float
        Probability of a step to the right.
    n : int
        Rows (decisions per ball).
    min_expected : float
        Pooling threshold of the tails.

    Returns
    -------
    tuple
        (chi², degrees of freedom, p-value).
    """
    counts = np.bincount(np.clip(bins, 0, n), minlength=n + 1).astype(float)
    expected = len(bins) * stats.binom.pmf(np.arange(n + 1), n, p)
    lo, hi = 0, n
    while expected[: lo + 1].sum() < min_expected:
        lo += 1
    while expected[hi:].sum() < min_expected:
        hi -= 1
    if lo >= hi:
        raise ValueError(
            f"chi2_binomial: {len(bins)} balls are too few for bins expecting >= {min_expected:g} balls each "
            f"(Binomial({n}, {p:g}))"
        )
    obs = np.r_[counts[: lo + 1].sum(), counts[lo + 1 : hi], counts[hi:].sum()]
    exp = np.r_[expected[: lo + 1].sum(), expected[lo + 1 : hi], expected[hi:].sum()]
    res = stats.chisquare(obs, exp)
    return float(res.statistic), len(obs) - 1, float(res.pvalue)
