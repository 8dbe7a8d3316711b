"""Galton board of thesis §2.5.4: one board, many interacting balls fed through a funnel, hexagonal nails.

Geometry (:class:`GaltonBoard`, lengths in m): nails are hexagons with a tip up on a triangular lattice of spacing D
(row pitch D sqrt(3)/2), ``ROWS`` rows filling the board between two side walls; row 0 has a nail at x = 0 right
under the funnel's outlet. Balls are 16-gons of radius ``BALL_R``, dropped into a V hopper above the board at one
every ``every_s`` seconds. p != 1/2 is made as in the thesis (Fig. 2.39): every nail's tip is
moved sideways by ``tip_shift_m`` (to the left for p > 1/2, so more balls pass on the right).

A ball's path is read off where its centre passes half a pitch below each row: the ten decisions (right = 1)
and its bin k = number of rights (= nearest integer to x/D + ROWS/2 below the last row). Once below the last
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

ROWS = 10
BALL_R, BALL_CORNERS = 0.002, 16
HOPPER_W, HOPPER_H = 0.06, 0.05  # hopper top width and height


@dataclasses.dataclass(frozen=True)
class GaltonBoard:
    """Geometry and material of the board (lengths in m)."""

    spacing_m: float = 0.010  # nail spacing D: gaps of 1.6 ball diameters (1.4 jams the stream)
    nail_r_m: float = 0.002  # hexagon circumradius
    tip_shift_m: float = 0.0  # tips moved by this (negative: to the left, p > 1/2)
    damping: float = 1.0
    friction: float = 0.3
    every_s: float = 0.02  # one ball dropped into the hopper every this many seconds
    outlet_m: float = 2.5 * 2 * BALL_R  # funnel outlet: wide enough not to clog, feeds the top nail only

    @property
    def pitch_m(self) -> float:
        return self.spacing_m * math.sqrt(3) / 2

    def nail(self) -> np.ndarray:
        """Hexagon with a tip up, its top corner moved sideways by ``tip_shift_m``."""
        ang = np.pi / 2 + np.pi / 3 * np.arange(6)
        v = self.nail_r_m * np.column_stack([np.cos(ang), np.sin(ang)])
        v[0, 0] += self.tip_shift_m
        return v

    def walls(self) -> list:
        """Nails, side walls (at +-7 D), the V hopper with its outlet above nail (0, 0) (board top at y = 0)."""
        d, pitch, half_w = self.spacing_m, self.pitch_m, 7 * self.spacing_m
        walls, hexagon = [], self.nail()
        for k in range(ROWS):
            for j in range(-8, 9):
                x = (j + 0.5 * (k % 2)) * d
                # no nail closer to a side wall than a ball diameter plus a radius: no pocket to stick in
                if half_w - abs(x) - self.nail_r_m > 3 * BALL_R:
                    corners = [tuple(p + (x, -k * pitch)) for p in hexagon]
                    walls.append({"name": f"nail{k}_{j}", "vertices_m": corners})
        y_out = self.nail_r_m + 3 * BALL_R  # funnel outlet height: a ball leaving it falls onto the top nail
        bottom, top = -(ROWS + 0.5) * pitch, y_out + HOPPER_H
        w = self.outlet_m  # each wall runs so that its outside is on its left
        walls.append(_slab("left", (-half_w, bottom), (-half_w, y_out)))
        walls.append(_slab("right", (half_w, y_out), (half_w, bottom)))
        walls.append(_slab("funnel_left", (-0.5 * w, y_out), (-0.5 * HOPPER_W, top)))
        walls.append(_slab("funnel_right", (0.5 * HOPPER_W, top), (0.5 * w, y_out)))
        return walls

    def simulation(self, n_balls: int, seed: int = 1) -> Simulation:
        """The board with ``n_balls`` balls to be dropped into the hopper (velocity Verlet)."""
        top = self.nail_r_m + 3 * BALL_R + HOPPER_H
        ball = {"size_m": (BALL_R, BALL_R), "corners": BALL_CORNERS, "orientation_dist": "EQUAL"}
        source = {
            "x_m": 0.0,
            "y_m": top + 2 * BALL_R,
            "width_m": HOPPER_W - 6 * BALL_R,
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
    sim: Simulation, board: GaltonBoard, t_max_s: float | None = None, chunk: int = 40, progress: bool = False
):
    """Run until every ball has left the board; return (decisions (N, ROWS) of 0/1, bins (N,)).

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

    Raises
    ------
    PorepipeError
        A ball is still in the board at ``t_max_s`` (default: last drop + 10 s), e.g. the outlet jammed.
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
            raise PorepipeError(
                f"galton: {int((~done).sum())} balls still in the board at t = {sim.time_s:.3g} s"
            )
        sim.advance(chunk)
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
    steps = np.diff(np.column_stack([np.zeros(n), xs]), axis=1)
    decisions = (steps > 0).astype(np.int64)
    bins = np.rint(xs[:, -1] / board.spacing_m + ROWS / 2).astype(np.int64)
    return decisions, bins


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
