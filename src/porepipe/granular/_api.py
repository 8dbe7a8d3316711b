"""Frictional 2-D DEM of convex polygons (gc2d, Schinner 2001): public API.

Decisions the thesis leaves open or prints damaged (each is tested in tests/unit/granular):

- **Characteristic length l (Eq. 2.15)** uses the particles' *radii*, r = sqrt(area/pi) (the radius of the disk of
  equal area; for the thesis's N-gon disks this is the disk radius to O(1/N²)), with a wall as r = infinity, so
  l = r_i r_j/(r_i + r_j). The centroid-to-contact distances |r_i| would make the stiffness of a wall depend on
  where along it a grain touches, and would make l vary during a contact, which the damping law
  dh_eff/dt = (1/l) dA/dt (Eq. 2.21, printed "l dA/dt") assumes it does not.
- **Relative tangential velocity (Eq. 2.18, printed v1 + v2)**: v_t = ((v_i + w_i x r_i) - (v_j + w_j x r_j)) . t
  at the contact point s, r_k = s - x_k.
- **Tangential effective mass (Eq. 2.17)**: m_t = 1/(1/m_i + 1/m_j + (r_i.n)²/I_i + (r_j.n)²/I_j), the exact
  mass that a tangential impulse at s sees (lever arm r x t = r . n); the printed r_i² is its disk case.
- **Tangential force (Eq. 2.27)**: the spring xi += (2/7) E v_t dt is stored per contact; the force is
  F_t = xi + gamma_t sqrt(2/7 E m_t) v_t, capped at mu F_el (F_el = E A / l); when capped, xi is set to the cap.
  Storing the damping term in xi, as Eq. 2.27 reads literally, would integrate it into a second spring.
- **Normal damping (Eqs. 2.21-2.22)**: D = gamma sqrt(E m_n) (A - A_old)/(l dt) with A_old the overlap of the
  previous step (0 at first contact), clipped to D >= -F_el so the normal force never attracts. Cohesion
  k_coh L (L = contact-line length) is then subtracted and may attract (Eq. 2.28).
- **Normal direction**: perpendicular to c1c2 (Fig. 2.4), oriented from i towards j (towards s for a wall);
  when the boundaries do not cross twice (one polygon inside the other, coincident polygons) it falls back to the
  centroid direction (+y if the centroids coincide), s to the overlap centroid and L to the overlap's width.
- **Angles** are counter-clockwise (gc2d's are clockwise, Eq. 2.35).
- **Application point** (``material.application_point``): the midpoint of c1c2 (Fig. 2.4) gives a flat face
  lying on a flat surface no restoring torque until a corner lifts, so a block below the friction threshold rocks
  and creeps (~1e-4 m/s); the overlap centroid moves towards the deeper end and restores it (creep < 1e-9 m/s).
- **Damping time step**: the normal damping uses dA/dt as the backward difference of the predicted overlaps, and
  the linear stability of that scheme (tests/unit/granular/test_integrator.py) bounds the damping rate c of a
  contact, c = gamma sqrt(E/m_n) L/l for a line of length L: Gear with one correction is unstable beyond
  c dt = 0.24-0.35 (damping ratio 0.25-4) and rings (spectral radius -> 1) near it, velocity Verlet beyond
  c dt = 0.78-2. Flat faces of long grains (L > l) reach it at the rule's dt; the default dt keeps c dt <= 0.15
  (Gear) or 0.4 (Verlet) for the longest edge of any grain.
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from porepipe._shared.errors import PorepipeError, positive_number
from porepipe.granular import _kernels as K
from porepipe.granular._contact import _contact_frame, _overlap_geometry
from porepipe.granular._neighbours import SwapState, _carry_state, _transpose, candidate_pairs
from porepipe.granular._settings import (
    ApplicationPoint,
    DropMode,
    GravityKind,
    Integrator,
    Settings,
    Waveform,
)
from porepipe.granular._shapes import check_convex, inscribed_radius
from porepipe.granular._system import collect_bodies, particle_properties, wall_polygons

#: fewest particles per thread worth a parallel region
PARTICLES_PER_THREAD = 1000
#: largest damping rate x dt the default dt allows (Gear: unstable beyond 0.24-0.35; Verlet: beyond 0.78-2)
DAMPING_DT = {Integrator.gear: 0.15, Integrator.verlet: 0.4}
#: largest tangential damping rate x dt (one contact, :func:`tangential_damping_rate`) the default dt allows. Gear:
#: one contact is stable to 0.165, but a settled pile's grains add their contacts' damping: 600 8-10-gons restarted
#: at rest heat up from c_t dt = 0.074-0.09 (tangential_damping 0.5, 1, 2) and stay at rest at 0.07 and below.
#: Verlet: the same pile stays at rest up to c_t dt = 0.8-1.2 (benchmarks/granular_time_step.py;
#: tests/unit/granular/test_pile_at_rest.py)
TANGENTIAL_DT = {Integrator.gear: 0.06, Integrator.verlet: 0.4}
_WAVE = {Waveform.cosinus: 1, Waveform.sawtooth: 2, Waveform.tapping: 3, Waveform.triangle: 4}
_GKIND = {GravityKind.constant: 0, GravityKind.linear: 1, GravityKind.step: 2, GravityKind.smooth_step: 3}


def polygon_overlap(p, q, trim: bool = True):
    """Overlap of two convex polygons (world frame): area, contact line, application point and normal.

    Parameters
    ----------
    p, q : (N, 2) and (M, 2) array_like
        Corners in m (either orientation).
    trim : bool
        Cut p to its facing chain before clipping (the default, as the simulation); False clips all of p (the
        reference, ``make_stepper(trim=False)``). Both agree to round-off.

    Returns
    -------
    dict
        ``area_m2``; ``c1_m``, ``c2_m`` (the boundary crossings, NaN if there is no proper line);
        ``point_m`` (midpoint of c1c2, Fig. 2.4); ``normal`` (unit, from p's centroid side towards q);
        ``length_m`` (|c1c2|); ``centroid_m`` (of the overlap).
    """
    p = check_convex(p, "polygon p")
    q = check_convex(q, "polygon q")
    kmax = len(p) + len(q) + 4
    buf_a, buf_b = np.empty((kmax, 2)), np.empty((kmax, 2))
    tag_a, tag_b = np.empty(kmax, np.int64), np.empty(kmax, np.int64)
    geo = np.empty(11)
    cp, cq = p.mean(axis=0), q.mean(axis=0)
    both = np.zeros((2, max(len(p), len(q)), 2))
    both[0, : len(p)], both[1, : len(q)] = p, q
    bufs = (buf_a, tag_a, buf_b, tag_b, np.empty(kmax))
    hint = np.zeros((1, 2), np.int64)
    _overlap_geometry(both, 0, len(p), 1, len(q), *cp, *cq, *bufs, geo, trim, hint, 0)
    out = {"area_m2": float(geo[0]), "centroid_m": geo[7:9].copy(), "point_m": geo[5:7].copy()}
    if geo[0] <= 0:
        return out | {
            "c1_m": np.full(2, np.nan),
            "c2_m": np.full(2, np.nan),
            "normal": np.full(2, np.nan),
            "length_m": 0.0,
        }
    nx, ny, length = _contact_frame(geo, cp[0], cp[1], cq[0], cq[1], False, buf_a)
    line = geo[9] > 0
    return out | {
        "c1_m": geo[1:3].copy() if line else np.full(2, np.nan),
        "c2_m": geo[3:5].copy() if line else np.full(2, np.nan),
        "normal": np.array([nx, ny]),
        "length_m": float(length),
    }


def time_step_rule(min_mass_kg: float, young_N_m: float) -> float:
    """The upper bound dt = (pi/10) sqrt(m_min / E) of Eq. 2.9 (1/10 of the contact half-period), in s."""
    mass = positive_number("time_step_rule: min_mass_kg", min_mass_kg)
    return 0.1 * math.pi * math.sqrt(mass / positive_number("time_step_rule: young_N_m", young_N_m))


def damping_rate(mass, radius, longest_edge, young_N_m: float, damping: float, pairs: bool) -> float:
    """Largest normal damping rate c = F_damp / (m_n h') of any contact, in 1/s.

    A contact of line length L between i and j damps with gamma sqrt(E m_n) (1/l) dA/dt = gamma sqrt(E m_n) (L/l)
    h', i.e. c = gamma sqrt(E/m_n) L/l, with 1/m_n = 1/m_i + 1/m_j and 1/l = 1/r_i + 1/r_j. L is at most the
    longest edge of the smaller grain, so c <= gamma sqrt(2 E/m_k) 2 L_k/r_k over grains k (particle pairs) or
    gamma sqrt(E/m_k) L_k/r_k (a grain on a wall).
    """
    per = np.sqrt(young_N_m / np.asarray(mass)) * np.asarray(longest_edge) / np.asarray(radius)
    return float(damping * per.max() * (2.0 * math.sqrt(2.0) if pairs else 1.0))


def tangential_damping_rate(
    mass, inertia, r_circ, young_N_m: float, tangential_damping: float, pairs: bool
) -> float:
    """Largest tangential damping rate c_t = D_t / m_t of any contact, in 1/s.

    The Cundall-Strack damping D_t = gamma_t sqrt(k_t m_t) v_t (k_t = 2/7 E) acts on the relative tangential
    velocity, whose effective mass is 1/m_t = 1/m_i + 1/m_j + a_i²/I_i + a_j²/I_j with lever arms a <= the
    circumradius: c_t = gamma_t sqrt(k_t / m_t) <= gamma_t sqrt(2 k_t max_k (1/m_k + r_k²/I_k)) over grains k
    (particle pairs; a grain on a wall has the 2 dropped).
    """
    per = 1.0 / np.asarray(mass) + np.asarray(r_circ) ** 2 / np.asarray(inertia)
    return float(tangential_damping * math.sqrt(2.0 / 7.0 * young_N_m * per.max() * (2.0 if pairs else 1.0)))


def _step_count(steps) -> int:
    """``steps`` as an int if it is a whole number >= 0 (an int, a NumPy integer or an integral float such as 3.0)."""
    if isinstance(steps, bool | np.bool_):
        ok = False
    elif isinstance(steps, int | np.integer):
        ok = steps >= 0
    else:
        ok = (
            isinstance(steps, float | np.floating) and float(steps).is_integer() and steps >= 0
        )  # no NaN, inf
    if not ok:
        raise PorepipeError(f"Simulation.advance: steps must be a whole number >= 0, got {steps!r}")
    return int(steps)


@dataclasses.dataclass
class Frame:
    """Particle state and contacts at one time."""

    time_s: float
    position: np.ndarray  # (N, 3) x, y in m, phi in rad
    velocity: np.ndarray  # (N, 3) m/s, rad/s
    active: np.ndarray  # (N,) uint8
    contacts: dict  # i, j, fx_N, fy_N (on i), sx_m, sy_m, fn_N, ft_N, area_m2, length_m


class Simulation:
    """A granular DEM run: bodies, contact state, integrator; advance it with :meth:`advance`.

    Parameters
    ----------
    settings : Settings
        The ``granular:`` scene section.
    seed : int
        Scene seed (shapes, lattice jitter, drop positions).
    """

    def __init__(self, settings: Settings, seed: int = 0):
        self.settings = settings
        s = settings
        bodies = collect_bodies(s, seed)
        props = particle_properties(bodies.vertices, s.material.density_kg_m2)
        walls = wall_polygons(s)
        wall_props = [
            {
                "centroid_m": v.mean(axis=0),
                "vertices_m": check_convex(v, f"granular wall {name!r}") - v.mean(axis=0),
            }
            for name, v, _ in walls
        ]
        n, nw = len(props), len(walls)
        if n == 0:
            raise PorepipeError(
                "granular: the scene has no particles (give particles, blocks or drop_sources)"
            )
        self.n_mob, self.n_walls = n, nw
        kmax = max(len(p["vertices_m"]) for p in props + wall_props)
        b = n + nw
        self.body = np.zeros((b, kmax, 2))
        self.nc = np.zeros(b, np.int64)
        for k, p in enumerate(props + wall_props):
            self.nc[k] = len(p["vertices_m"])
            self.body[k, : self.nc[k]] = p["vertices_m"]
        self.mass = np.array([p["mass_kg"] for p in props])
        self.inertia = np.array([p["inertia_kg_m2"] for p in props])
        self.area = np.concatenate([[p["area_m2"] for p in props], np.full(nw, np.inf)])
        self.inv_m = np.concatenate([1.0 / self.mass, np.zeros(nw)])
        self.inv_I = np.concatenate([1.0 / self.inertia, np.zeros(nw)])
        self.inv_r = np.concatenate([np.sqrt(np.pi / self.area[:n]), np.zeros(nw)])
        self.r_circ = np.linalg.norm(self.body[:n], axis=2).max(axis=1)
        self.r_in = np.array([inscribed_radius(p["vertices_m"]) for p in props])
        rho, E = s.material.density_kg_m2, s.material.young_N_m
        # Eq. 2.9 with the lightest mass and, for elongated grains, m = pi r_min² rho (inscribed radius)
        self.dt_rule = time_step_rule(min(self.mass.min(), math.pi * self.r_in.min() ** 2 * rho), E)
        edge = [
            np.linalg.norm(np.roll(p["vertices_m"], -1, axis=0) - p["vertices_m"], axis=1).max()
            for p in props
        ]
        rate = damping_rate(self.mass, 1.0 / self.inv_r[:n], edge, E, s.material.damping, n > 1)
        rate_t = tangential_damping_rate(
            self.mass, self.inertia, self.r_circ, E, s.material.tangential_damping, n > 1
        )
        self.damping_rates = (rate, rate_t)
        self.dt_damping = min(
            DAMPING_DT[s.integrator] / rate if rate > 0 else math.inf,
            TANGENTIAL_DT[s.integrator] / rate_t if rate_t > 0 else math.inf,
        )
        self.dt = s.dt_s if s.dt_s is not None else min(0.5 * self.dt_rule, self.dt_damping)
        # 0.6 R_min: vs 0.3, half the list builds for ~1.1x the candidates; the run is the same to the bit (a
        # candidate that does not touch adds zero), 1.09x per CPU-s on benchmarks/granular.py's wide pile
        self.skin = s.skin_m if s.skin_m is not None else 0.6 * float(self.r_circ.min())
        self.insert_s = bodies.insert_s
        self.drop = bodies.drop
        self.drop_modes = [src.mode for src in s.drop_sources]
        self.drop_windows = [(src.x_m, src.width_m) for src in s.drop_sources]
        self.G = np.zeros((6, b, 3))
        self.G[0, :n] = bodies.position
        self.G[1, :n] = bodies.velocity * self.dt
        for k, p in enumerate(wall_props):
            self.G[0, n + k, :2] = p["centroid_m"]
        self.active = np.concatenate([(self.insert_s <= 0).astype(np.uint8), np.ones(nw, np.uint8)])
        self.wall_names = [name for name, _, _ in walls]
        self.heat = np.zeros(5)
        if s.size_change is not None:
            h = s.size_change
            if h.time_s[1] < h.time_s[0]:
                raise PorepipeError(f"granular.size_change.time_s {h.time_s}: t2 must not precede t1")
            self.heat[:] = (h.amplitude, h.frequency_hz, h.slope, h.time_s[0], h.time_s[1])
        # the broad phase pads the circumradius for the largest size s(t) reaches, max(1, 1 + a)
        self.size_max = max(1.0, 1.0 + self.heat[0])
        self._wall_setup(walls)
        self.mat = np.array(
            [
                E,
                s.material.damping,
                s.material.friction,
                s.material.tangential_damping,
                s.material.cohesion_N_m,
                s.material.weakening_v_min_m_s,
                s.guard.max_overlap,
                s.guard.max_move * float(self.r_in.min()),
                float(s.material.application_point is ApplicationPoint.centroid),
            ]
        )
        self.gvec = np.asarray(s.gravity_m_s2, dtype=np.float64)
        g = s.gravity
        gnorm = float(np.linalg.norm(self.gvec))
        if g is not None:
            if gnorm == 0:
                raise PorepipeError("granular.gravity needs a direction: gravity_m_s2 must not be (0, 0)")
            self.gvec = self.gvec / gnorm
            self.gpar = np.array(
                [_GKIND[g.kind], g.g1_m_s2, g.g2_m_s2, g.time_s[0], g.time_s[1], g.steps, g.ramp]
            )
        else:
            self.gpar = np.zeros(7)
        g0 = self.gvec * (K._gravity_scale(self.gpar, 0.0) if s.gravity is not None else 1.0)
        self.G[2, :n, :2] = 0.5 * self.dt**2 * g0  # r_2 = dt^2/2 q'' at t = 0 (no contact forces yet)
        self.drag_par = np.zeros((len(s.drag_springs), 10))
        for k, d in enumerate(s.drag_springs):
            if d.particle >= n:
                raise PorepipeError(f"granular.drag_springs[{k}].particle = {d.particle}: only {n} particles")
            c, sn = math.cos(bodies.position[d.particle, 2]), math.sin(bodies.position[d.particle, 2])
            fx, fy = d.fixing_point_m
            anchor = bodies.position[d.particle, :2] + [c * fx - sn * fy, sn * fx + c * fy]
            self.drag_par[k] = (
                d.particle,
                fx,
                fy,
                anchor[0],
                anchor[1],
                d.velocity_m_s[0],
                d.velocity_m_s[1],
                d.time_s[0],
                d.time_s[1],
                d.k_N_m,
            )
        self.effects = {
            "cohesion": s.material.cohesion_N_m > 0,
            "velocity_weakening": s.material.velocity_weakening,
            "vibration": bool((self.wall_vib[:, 0] > 0).any()),
            "variable_gravity": g is not None,
            "drag_springs": len(s.drag_springs) > 0,
            "surface_velocity": bool((self.surf != 0).any()),
            "piston": bool((self.piston[:, 0] != 0).any()),
            "size_change": s.size_change is not None,
        }
        self._stepper = K.make_stepper(*self.effects.values())
        self.gear = s.integrator is Integrator.gear
        self.method = s.neighbour_search.value
        self.order = np.arange(n, dtype=np.int64)
        self.swap = SwapState(n)
        self.time_s = 0.0
        self.step = 0
        self.rebuilds = 0
        self.max_overlap_seen = 0.0
        # the step of the last insertion and the particles it inserted (for the guard's message only)
        self.last_insert = (-1, np.zeros(0, np.int64))
        self.wv = np.zeros_like(self.body)
        self.aabb = np.zeros((b, 4))
        self._place_all()
        self.nb_start = np.zeros(n + 1, np.int64)
        self.nb_j = np.zeros(0, np.int64)
        self.ft = np.zeros(0)
        self.aold = np.zeros(0)
        self.pout = np.zeros((0, len(K.POUT)))
        self.rebuild()

    # -- set-up helpers ------------------------------------------------------------------------------------------
    def _wall_setup(self, walls):
        n, nw = self.n_mob, self.n_walls
        self.wall_base = np.zeros((n + nw, 2))
        self.wall_vib = np.zeros((n + nw, 7))
        self.piston = np.zeros((n + nw, K.PISTON_COLS))
        self.surf = np.zeros(n + nw)
        pad = np.zeros(n + nw)
        for k, (_, _, w) in enumerate(walls):
            self.wall_base[n + k] = self.G[0, n + k, :2]
            if w is None:
                continue
            self.surf[n + k] = w.surface_velocity_m_s
            if w.vibration is not None:
                v = w.vibration
                self.wall_vib[n + k] = (
                    _WAVE[v.waveform],
                    v.amplitude_m,
                    v.frequency_hz,
                    math.cos(v.angle_rad),
                    math.sin(v.angle_rad),
                    v.from_s,
                    v.to_s,
                )
                pad[n + k] = v.amplitude_m
            if w.piston is not None:
                pc = w.piston
                d = (math.cos(pc.angle_rad), math.sin(pc.angle_rad))
                self.piston[n + k, :6] = (1.0, d[0], d[1], pc.force_N, 1.0 / pc.mass_kg, pc.v_max_m_s)
                pad[n + k] = 0.5 * self.skin  # its travel between list builds (a build follows skin/2)
        self.wall_pad = pad

    def size_scale(self, t: float | None = None) -> float:
        """The particles' size factor s(t) (1 without ``size_change``) at t (default: now)."""
        if not self.effects["size_change"]:
            return 1.0
        return float(K._size_scale(self.heat, self.time_s if t is None else t))

    def gravity_now(self) -> float:
        """|g| at the present time (m/s²): the scene's g(t), or |gravity_m_s2| without ``granular.gravity``."""
        if self.settings.gravity is None:
            return float(np.linalg.norm(self.gvec))
        return float(K._gravity_scale(self.gpar, self.time_s))

    def ramp_gravity(self, g_to_m_s2: float, duration_s: float) -> None:
        """From now on ramp |g| linearly from its present value to ``g_to_m_s2`` over ``duration_s``, then hold it.

        Replaces the scene's g(t) for the rest of the run: a sequence of calls loads and unloads a packing in
        cycles (§4.3.3's adiabatic unloading and its reversal). Needs ``granular.gravity`` in the scene, which
        selects the kernel with a time-dependent g.
        """
        if self.settings.gravity is None:
            raise PorepipeError(
                "ramp_gravity: the scene needs granular.gravity (the time-dependent g kernel)"
            )
        if not (np.isfinite(g_to_m_s2) and g_to_m_s2 >= 0 and np.isfinite(duration_s) and duration_s > 0):
            raise PorepipeError(
                f"ramp_gravity: g_to_m_s2 must be >= 0 and duration_s > 0 (got {g_to_m_s2}, {duration_s})"
            )
        g_from = self.gravity_now()
        self.gpar[:] = (
            _GKIND[GravityKind.linear],
            g_from,
            g_to_m_s2,
            self.time_s,
            self.time_s + duration_s,
            1,
            0,
        )

    def _place_all(self):
        n = self.n_mob
        for w in range(n, self.nc.shape[0]):
            if self.piston[w, 0] != 0:
                self.G[0, w, :2] = self.wall_base[w] + self.piston[w, 6] * self.piston[w, 1:3]
        sc = self.size_scale()
        for i in range(self.nc.shape[0]):
            K._place(
                self.body,
                self.nc,
                self.G[0, i, 0],
                self.G[0, i, 1],
                self.G[0, i, 2],
                self.wv,
                self.aabb,
                i,
                sc if i < n else 1.0,
            )

    def wall_boxes(self) -> np.ndarray:
        """(W, 4) bounding boxes of the walls, padded by their vibration amplitude."""
        n = self.n_mob
        box = self.aabb[n:].copy()
        p = self.wall_pad[n:]
        return box + np.column_stack([-p, p, -p, p])

    # -- neighbour list ---------------------------------------------------------------------------------------------
    def rebuild(self) -> None:
        """Rebuild the candidate list at the current positions, carrying every contact's state over."""
        n = self.n_mob
        x = np.ascontiguousarray(self.G[0, :n, :2])
        rad = self.r_circ * self.size_max if self.size_max != 1.0 else self.r_circ
        start, nb_j = candidate_pairs(
            self.method, x, rad, self.active[:n], self.skin, self.wall_boxes(), n, self.order, self.swap
        )
        ft, aold, pout = np.zeros(len(nb_j)), np.zeros(len(nb_j)), np.zeros((len(nb_j), len(K.POUT)))
        _carry_state(self.nb_start, self.nb_j, self.ft, self.aold, self.pout, start, nb_j, ft, aold, pout)
        self.nb_start, self.nb_j, self.ft, self.aold, self.pout = start, nb_j, ft, aold, pout
        # each pair's facing corners of the last step, where the narrow phase starts its search (a hint only:
        # the contact does not depend on it, so it is neither carried over nor checkpointed)
        self.hint = np.zeros((len(nb_j), 2), np.int64)
        self.tr_start, self.tr_p = _transpose(n, start, nb_j)
        self.x_build = x.copy()
        self.scratch = np.zeros((n, 6))
        self.piston[:, 8] = self.piston[:, 6]
        self.rebuilds += 1

    # -- time stepping ---------------------------------------------------------------------------------------------
    def _insert_due(self) -> bool:
        """Activate particles whose insertion time has come (REL sources measure their window's top first)."""
        due = np.nonzero((self.active[: self.n_mob] == 0) & (self.insert_s <= self.time_s + 0.5 * self.dt))[0]
        for i in due:
            src = self.drop[i]
            if src >= 0 and self.drop_modes[src] is DropMode.rel:
                x0, w = self.drop_windows[src]
                live = self.active[: self.n_mob] == 1
                xs = self.G[0, : self.n_mob, 0]
                inside = live & (np.abs(xs - x0) <= 0.5 * w + self.r_circ.max())
                top = float(self.G[0, : self.n_mob, 1][inside].max()) if inside.any() else 0.0
                self.G[0, i, 1] += top
            self.active[i] = 1
        if len(due):
            self.last_insert = (self.step, due)
        return len(due) > 0

    def remove(self, which) -> None:
        """Take particles out of the run for good (a sink: balls that reached the bins, grains that left a silo).

        ``which`` is a boolean mask or index array over the mobile particles; their contacts end at the next step.
        """
        idx = np.arange(self.n_mob)[which]
        self.active[idx] = 0
        self.insert_s[idx] = np.inf  # never (re)inserted

    def _next_insert_step(self) -> int:
        pending = self.insert_s[(self.active[: self.n_mob] == 0) & np.isfinite(self.insert_s)]
        if pending.size == 0:
            return 1 << 62
        return max(math.ceil(pending.min() / self.dt - 0.5), self.step + 1)

    def advance(self, steps: int) -> None:
        """Advance by ``steps`` time steps (inserting particles and rebuilding the list as needed).

        Raises
        ------
        PorepipeError
            ``steps`` is not a whole number >= 0 (2.7, -5, NaN, a string or a bool), or the stability guard fired
            (overlap explosion, runaway speed, NaN); the message gives the dt to try.
        """
        end = self.step + _step_count(steps)
        # a parallel region costs ~10 us (much more on a loaded machine): small systems run on one thread (the
        # result does not depend on the thread count)
        threads = numba.get_num_threads()
        numba.set_num_threads(max(1, min(threads, self.n_mob // PARTICLES_PER_THREAD)))
        try:
            self._advance(end)
        finally:
            numba.set_num_threads(threads)

    def _advance(self, end: int) -> None:
        while self.step < end:
            if self._insert_due():
                self._place_all()
                self.rebuild()
            stop = min(end, self._next_insert_step())
            diag = np.zeros(4)
            done, code = self._stepper(
                self.G,
                self.body,
                self.nc,
                self.wv,
                self.aabb,
                self.inv_m,
                self.inv_I,
                self.inv_r,
                self.area,
                self.active,
                self.n_mob,
                self.wall_base,
                self.wall_vib,
                self.surf,
                self.nb_start,
                self.nb_j,
                self.tr_start,
                self.tr_p,
                self.ft,
                self.aold,
                self.hint,
                self.pout,
                self.x_build,
                self.scratch,
                self.mat,
                self.gvec,
                self.gpar,
                self.drag_par,
                self.time_s,
                self.dt,
                stop - self.step,
                0.5 * self.skin,
                self.gear,
                diag,
                self.piston,
                self.heat,
            )
            self.step += int(done)
            self.time_s = self.step * self.dt
            self.max_overlap_seen = max(self.max_overlap_seen, diag[3])
            if code == K.REBUILD:
                self.rebuild()
            elif code != K.DONE:
                self._guard_error(code, diag)

    def damping_bound_notice(self) -> str | None:
        """A line saying that ``granular.dt_s`` is past the default's damping bound, or None where it is not.

        Past the bound the run is accepted (a lone contact stays stable up to c dt = 0.24-0.35 under Gear and
        0.78-2 under Verlet, c_t dt = 0.165 under Gear), but a dense pile may gain energy with no overlap large
        enough for the guard: under Gear a settled pile heats from c_t dt = 0.074-0.09 (``TANGENTIAL_DT``).
        """
        if self.settings.dt_s is None or self.dt <= self.dt_damping * (1.0 + 1e-9):
            return None
        integrator = self.settings.integrator
        rate, rate_t = self.damping_rates
        advice = "; integrator: verlet takes larger steps" if integrator == Integrator.gear else ""
        return (
            f"granular.dt_s = {self.dt:.3g} s is past the default's damping bound {self.dt_damping:.3g} s under "
            f"{integrator.value} (normal c dt = {rate * self.dt:.2f}, bound {DAMPING_DT[integrator]}; tangential "
            f"c_t dt = {rate_t * self.dt:.3f}, bound {TANGENTIAL_DT[integrator]}): a dense pile may gain energy "
            f"without tripping the overlap guard; leave dt_s unset for the default{advice}"
        )

    def _guard_error(self, code, diag):
        try_dt = min(0.5 * self.dt, 0.5 * self.dt_rule, self.dt_damping)
        damped = (
            f" and the damping bound {self.dt_damping:.3g} s (material.damping, tangential_damping)"
            if self.dt > self.dt_damping * (1.0 + 1e-9)
            else ""
        )
        what = {
            K.GUARD_OVERLAP: f"overlap area {diag[2]:.3g} r_eq² (limit {self.mat[6]:g})",
            K.GUARD_NAN: "a non-finite position or velocity",
            K.GUARD_MOVE: f"a displacement of {diag[2]:.3g} m in one step (limit {self.mat[7]:.3g} m)",
        }[code]
        if self.step <= 1 and code == K.GUARD_OVERLAP:
            raise PorepipeError(
                f"granular: particle {int(diag[1])} starts with {what}: the initial placement "
                "overlaps (widen the block's grid_m or move the particle)"
            )
        at, new = self.last_insert
        if code == K.GUARD_OVERLAP and self.step == at + 1:
            sources = sorted({int(self.drop[i]) for i in new if self.drop[i] >= 0})
            names = ", ".join(f"granular.drop_sources[{k}]" for k in sources) or "the scene"
            raise PorepipeError(
                f"granular: particle {int(diag[1])} shows {what} one step after {names} inserted particle(s) "
                f"{new[:5].tolist()} at t = {self.insert_s[new].min():.6g} s: they went in on top of grains that "
                "had not moved away (not an unstable dt); insert less often (every_s), over a wider width_m, "
                "higher, or with a downward velocity_m_s"
            )
        if code == K.GUARD_MOVE and not self._touches(int(diag[1])):
            raise PorepipeError(self._free_flight(int(diag[1]), diag[2]))
        raise PorepipeError(
            f"granular: unstable at step {self.step} (t = {self.time_s:.6g} s): particle {int(diag[1])} shows "
            f"{what}; dt = {self.dt:.3g} s vs the rule (pi/10) sqrt(m_min/E) = {self.dt_rule:.3g} s "
            f"(Eq. 2.9){damped}: rerun with granular.dt_s <= {try_dt:.3g}"
        )

    def _touches(self, k: int) -> bool:
        """Whether particle ``k`` had a contact (a grain or a wall) in the last step."""
        c = self.contacts()
        return bool(np.any(c["i"] == k) or np.any(c["j"] == k))

    def _free_flight(self, k: int, moved: float) -> str:
        """The guard's message for particle ``k`` that moved ``moved`` m in one step without a contact: a grain
        that flew fast (a long fall, a launch), not an unstable time step.
        """
        n = self.n_mob
        vx, vy, w = self.G[1, k] / self.dt
        x, y = self.G[0, k, :2]
        box = self.aabb[n:]
        if not len(box):
            where = " in a scene without walls"
        elif x < box[:, 0].min() or x > box[:, 1].max() or y < box[:, 2].min() or y > box[:, 3].max():
            where = ", outside every wall's reach"
        else:
            where = ""
        limit = self.mat[7]
        return (
            f"granular: particle {k} moved {moved:.3g} m in one step without a contact at step {self.step} "
            f"(t = {self.time_s:.6g} s): it flies at {math.hypot(vx, vy):.3g} m/s and {abs(w):.3g} rad/s at "
            f"({x:.3g}, {y:.3g}) m{where}, and granular.guard.max_move = {self.settings.guard.max_move:g} inscribed "
            f"radii allows {limit:.3g} m per step (a faster grain may pass through a wall or grain unseen); not an "
            "unstable dt (a smaller dt_s only delays the stop for a falling grain): give it walls to land on or "
            "shorten granular.duration_s, or, if the flight is meant, raise granular.guard.max_move"
        )

    def start_overlaps(self) -> dict:
        """Pairs whose outlines overlap as placed (before the first step), and the largest overlap.

        A jittered or dense block can place grains into each other; below ``guard.max_overlap`` the run accepts
        them, and they push apart in the first steps, which adds kinetic energy (granular-box with g = 0: 5 pairs,
        the largest 0.0044 r_eq², from rest to 0.011 J/m).

        Returns
        -------
        dict
            ``grains`` and ``walls`` (number of overlapping grain-grain and grain-wall pairs), ``largest`` (the
            largest overlap area / r_eq² of the smaller partner, as the guard measures it) and ``pair`` (its
            indices i, j; j >= n_particles is wall j - n_particles).
        """
        n = self.n_mob
        kmax = 2 * self.body.shape[1] + 4
        buf_a, buf_b = np.empty((kmax, 2)), np.empty((kmax, 2))
        tag_a, tag_b = np.empty(kmax, np.int64), np.empty(kmax, np.int64)
        side, geo = np.empty(kmax), np.empty(11)
        hint = self.hint.copy()
        box, x = self.aabb, self.G[0]
        out = {"grains": 0, "walls": 0, "largest": 0.0, "pair": (-1, -1)}
        for i in np.nonzero(self.active[:n])[0]:
            for p in range(self.nb_start[i], self.nb_start[i + 1]):
                j = self.nb_j[p]
                if (
                    not self.active[j]
                    or (box[i, 1] < box[j, 0] or box[j, 1] < box[i, 0])
                    or (box[i, 3] < box[j, 2] or box[j, 3] < box[i, 2])
                ):
                    continue
                _overlap_geometry(
                    self.wv, i, self.nc[i], j, self.nc[j], x[i, 0], x[i, 1], x[j, 0], x[j, 1],
                    buf_a, tag_a, buf_b, tag_b, side, geo, True, hint, p,
                )  # fmt: skip
                if geo[0] <= 0.0:
                    continue
                out["walls" if j >= n else "grains"] += 1
                rel = geo[0] * math.pi / min(self.area[i], self.area[j])
                if rel > out["largest"]:
                    out["largest"], out["pair"] = float(rel), (int(i), int(j))
        return out

    # -- observables -------------------------------------------------------------------------------------------------
    @property
    def position(self) -> np.ndarray:
        """(N, 3) centroid x, y (m) and angle (rad) of the mobile particles."""
        return self.G[0, : self.n_mob].copy()

    @property
    def velocity(self) -> np.ndarray:
        """(N, 3) velocities (m/s, rad/s) at the current step."""
        return self.G[1, : self.n_mob] / self.dt

    def contacts(self) -> dict:
        """Current contacts (overlap > 0) with the forces of the last step; forces act on i, -F on j."""
        live = self.pout[:, 8] > 0
        owner = np.repeat(np.arange(self.n_mob), np.diff(self.nb_start))
        out = {"i": owner[live], "j": self.nb_j[live]}
        for c, name in enumerate(K.POUT):
            if name.startswith("torque"):
                continue
            out[name] = self.pout[live, c].copy()
        return out

    def frame(self) -> Frame:
        return Frame(
            self.time_s, self.position, self.velocity, self.active[: self.n_mob].copy(), self.contacts()
        )

    def kinetic_energy(self) -> float:
        """Translational + rotational kinetic energy of the active particles, J/m (2-D: per unit depth is J)."""
        v = self.velocity
        a = self.active[: self.n_mob] == 1
        return float(
            0.5 * np.sum((self.mass * (v[:, 0] ** 2 + v[:, 1] ** 2) + self.inertia * v[:, 2] ** 2)[a])
        )

    def momentum(self) -> tuple[np.ndarray, float]:
        """Total linear momentum (2,) and angular momentum about the origin of the active particles."""
        v = self.velocity
        x = self.G[0, : self.n_mob]
        a = self.active[: self.n_mob] == 1
        p = (self.mass[a, None] * v[a, :2]).sum(axis=0)
        lz = np.sum(self.mass[a] * (x[a, 0] * v[a, 1] - x[a, 1] * v[a, 0]) + self.inertia[a] * v[a, 2])
        return p, float(lz)

    # -- checkpoint --------------------------------------------------------------------------------------------------
    STATE = (
        "G",
        "active",
        "insert_s",
        "nb_start",
        "nb_j",
        "ft",
        "aold",
        "x_build",
        "order",
        "tr_start",
        "tr_p",
        "pout",
        "piston",
    )

    def state(self) -> dict:
        """Everything that determines the continuation (arrays copied), for checkpoints."""
        out = {k: getattr(self, k).copy() for k in self.STATE}
        out["scalars"] = np.array([self.step, self.rebuilds], dtype=np.int64)
        out["max_overlap_seen"] = np.array([self.max_overlap_seen])
        return out

    def restore(self, state: dict) -> None:
        """Continue from :meth:`state` output (bit-identical to an uninterrupted run)."""
        for k in self.STATE:
            setattr(self, k, np.array(state[k]))
        self.step, self.rebuilds = (int(v) for v in state["scalars"])
        self.max_overlap_seen = float(state["max_overlap_seen"][0])
        self.time_s = self.step * self.dt
        self.scratch = np.zeros((self.n_mob, 6))
        self.swap = SwapState(self.n_mob)  # rebuilt from scratch at the next list build: the same pairs
        self.hint = np.zeros((len(self.nb_j), 2), np.int64)  # search hints, one per pair of the restored list
        self._place_all()
