"""Boolean model of balls: Miles' formulae and their exact lattice versions for the 2x2x2 estimators.

Miles' formulae (continuous reference)
--------------------------------------
For a Boolean model of balls of radius r with intensity λ (v = 4πr³/3, s = 4πr², m = ∫H dS = 4πr with
H = (k1 + k2)/2, q = exp(-λv)):

``V_V = 1 - q``, ``S_V = q λ s``, ``M_V = q (λ m - (π²/32) (λ s)²)``,
``χ_V = q (λ - λ² m s / (4π) + (π/384) (λ s)³)``

(Miles 1976; Schneider & Weil 2008, Thm. 9.1.4 with V1 = m/π, V2 = s/2: V̄1 = q(γV1 - (π/8)(γV2)²),
V̄0 = q(γ - γ²V1V2/2 + (π/48)(γV2)³); Ohser & Mücklich 2000, §5.2). The M_V coefficient also follows from the
planar sections: they are a 2-D Boolean model of discs with N_A = 2rλ, L_A = (π/4) S_V, and
χ_A = q (N_A - L_A²/(4π)), M_V = 2π χ_A.

Lattice versions (what the digitised model really has)
------------------------------------------------------
The voxel-centre digitisation of the Boolean model on the lattice aℤ³ has a stationary 2x2x2 configuration
distribution that is known exactly: a set F of cell vertices is uncovered with probability
``Q(F) = exp(-λ |∪_{p∈F} B(p, r)|)`` (capacity functional of the Boolean model), and by inclusion-exclusion the
code with covered vertex set C and uncovered set U has probability ``P(c) = Σ_{G⊆C} (-1)^|G| Q(U ∪ G)``
(Ohser, Nagel & Schladitz 2009, Image Anal. Stereol. 28:77-92). As every estimator of this package is a linear
function of the configuration histogram, its expectation over the Boolean model is ``Σ_c w(c) P(c)``: an exact
reference for the measured means, free of sampling error. The volumes of the unions of up to 8 balls are
computed by slicing along z and the exact arc integral of the union of discs in each slice (adaptive quadrature,
absolute error ~1e-12 r³).

What the lattice versions show (η = λv = 0.4, r/a = 4 ... 256; pore = balls): V_V is exact and S_V → Miles
like a/r (-1.35 % at r/a = 16, -0.16 % at 128). M_V and χ_V do not converge to Miles' values. Along every
intersection circle of two balls the background forms a wedge; thin wedges (balls nearly touching) digitise into
isolated background pixels in the planar sections and into perforated sheets in 3-D, and the number of these
fragments per unit length of intersection circle does not decrease with a. The bias of M_V at r/a = 256 is
-4.5 % for 6-adjacent balls (pore6_matrix26) and -13.6 % for 26-adjacent balls; χ_V of 26-adjacent balls tends
to a wrong constant (-0.033 r⁻³ instead of -0.0033 r⁻³ at η = 0.4), that of 6-adjacent balls diverges like 1/a
(table in tests/validation/test_minkowski_boolean.py).
"""

from __future__ import annotations

import functools
import itertools

import numpy as np
from scipy.integrate import quad

from porepipe._shared.errors import PorepipeError
from porepipe.minkowski import _weights
from porepipe.minkowski._api import _adjacency, voxel3
from porepipe.minkowski._settings import Adjacency

QUANTITIES = ("phi", "S_V", "K_V", "chi_V")


def _check_positive(**values: float) -> None:
    for name, value in values.items():
        if not np.isfinite(value) or value <= 0:
            raise PorepipeError(f"{name} must be a positive finite number, got {value!r}")


def miles_densities(intensity_um3: float, radius_um: float) -> dict[str, float]:
    """Miles' densities V_V, S_V, M_V (= K_V, ∫H per volume) and χ_V of a Boolean model of balls.

    Parameters
    ----------
    intensity_um3 : float
        Intensity λ of the Poisson process of centres (µm⁻³).
    radius_um : float
        Ball radius r (µm).

    Returns
    -------
    dict
        ``phi`` (V_V, 1), ``S_V`` (µm⁻¹), ``K_V`` (M_V, µm⁻²), ``chi_V`` (µm⁻³) of the union of the balls.
    """
    _check_positive(intensity_um3=intensity_um3, radius_um=radius_um)
    lam, r = intensity_um3, radius_um
    v, s, m = 4.0 / 3.0 * np.pi * r**3, 4.0 * np.pi * r * r, 4.0 * np.pi * r
    q = np.exp(-lam * v)
    return {
        "phi": 1.0 - q,
        "S_V": q * lam * s,
        "K_V": q * (lam * m - np.pi**2 / 32.0 * (lam * s) ** 2),
        "chi_V": q * (lam - lam * lam * m * s / (4.0 * np.pi) + np.pi / 384.0 * (lam * s) ** 3),
    }


# -- union of balls --------------------------------------------------------------------------------------------------
def _exposed_arcs(covered: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Complement in [0, 2π) of a union of angular intervals (start, start + length)."""
    pieces = []
    for start, stop in covered:
        start, length = start % (2 * np.pi), stop - start
        if start + length > 2 * np.pi:
            pieces += [(start, 2 * np.pi), (0.0, start + length - 2 * np.pi)]
        else:
            pieces.append((start, start + length))
    exposed, pos = [], 0.0
    for start, stop in sorted(pieces):
        if start > pos:
            exposed.append((pos, start))
        pos = max(pos, stop)
    if pos < 2 * np.pi:
        exposed.append((pos, 2 * np.pi))
    return exposed


def union_of_discs_area(cx: np.ndarray, cy: np.ndarray, radius: np.ndarray) -> float:
    """Exact area of a union of discs: Green's formula ½∮(x dy - y dx) over the exposed boundary arcs.

    Discs of radius <= 0 are ignored; of identical discs only the last counts.
    """
    area = 0.0
    n = len(radius)
    for i in range(n):
        ri = radius[i]
        if ri <= 0:
            continue
        covered, hidden = [], False
        for j in range(n):
            if j == i or radius[j] <= 0:
                continue
            dx, dy = cx[j] - cx[i], cy[j] - cy[i]
            d = np.hypot(dx, dy)
            if d == 0.0 and radius[j] == ri:
                hidden = j > i
            elif d + ri <= radius[j]:
                hidden = True
            elif d < ri + radius[j] and d + radius[j] > ri:
                half = np.arccos(np.clip((d * d + ri * ri - radius[j] ** 2) / (2 * d * ri), -1.0, 1.0))
                centre = np.arctan2(dy, dx)
                covered.append((centre - half, centre + half))
            if hidden:
                break
        if hidden:
            continue
        for t1, t2 in _exposed_arcs(covered):
            area += 0.5 * (
                ri * ri * (t2 - t1)
                + ri * cx[i] * (np.sin(t2) - np.sin(t1))
                - ri * cy[i] * (np.cos(t2) - np.cos(t1))
            )
    return area


def union_of_balls_volume(centres_um: np.ndarray, radius_um: float) -> float:
    """Volume of the union of equal balls, by z-slices (exact disc-union area) and adaptive quadrature.

    Parameters
    ----------
    centres_um : (n, 3) ndarray
        Ball centres (µm); meant for a few balls (n <= ~10).
    radius_um : float
        Common radius (µm).

    Returns
    -------
    float
        Volume in µm³, absolute error ~1e-12 r³.
    """
    centres = np.asarray(centres_um, dtype=np.float64)
    if centres.ndim != 2 or centres.shape[1] != 3 or len(centres) == 0:
        raise PorepipeError(f"centres_um must be an (n, 3) array with n >= 1, got shape {centres.shape}")
    _check_positive(radius_um=radius_um)
    r, z = radius_um, centres[:, 2]
    lo, hi = z.min() - r, z.max() + r

    def area(t):
        return union_of_discs_area(
            centres[:, 0], centres[:, 1], np.sqrt(np.clip(r * r - (t - z) ** 2, 0.0, None))
        )

    breaks = sorted(set(np.concatenate([z - r, z, z + r]).tolist()) - {lo, hi})
    value, _ = quad(area, lo, hi, points=breaks or None, epsabs=1e-12 * r**3, epsrel=1e-13, limit=800)
    return value


def _cell_symmetries(voxel_um: tuple[float, float, float]) -> list[np.ndarray]:
    """Vertex permutations (as bit maps) of the cell's symmetries that keep the voxel edge lengths."""
    maps = []
    for perm in itertools.permutations(range(3)):
        if not np.allclose(np.asarray(voxel_um)[list(perm)], voxel_um):
            continue
        for flip in itertools.product((0, 1), repeat=3):
            maps.append((_weights.VERTICES[:, perm] ^ np.asarray(flip)) @ np.array([1, 2, 4]))
    return maps


@functools.lru_cache(maxsize=16)
def cell_union_volumes(radius_um: float, voxel_um: tuple[float, float, float]) -> np.ndarray:
    """(256,) volumes |∪_{p∈F} B(p, r)| (µm³) for every set F of cell vertices (bit mask; entry 0 is 0)."""
    _check_positive(radius_um=radius_um)
    maps = _cell_symmetries(voxel_um)
    volumes, known = np.zeros(_weights.N_CODES), {}
    for mask in range(1, _weights.N_CODES):
        bits = [b for b in range(8) if mask >> b & 1]
        key = min(int(sum(1 << int(m[b]) for b in bits)) for m in maps)
        if key not in known:
            members = [b for b in range(8) if key >> b & 1]
            known[key] = union_of_balls_volume(_weights.VERTICES[members] * np.asarray(voxel_um), radius_um)
        volumes[mask] = known[key]
    volumes.setflags(write=False)  # cached: callers must not change it
    return volumes


def lattice_code_probabilities(intensity_um3: float, radius_um: float, voxel_um) -> np.ndarray:
    """Exact 2x2x2 configuration probabilities of the digitised Boolean model of balls (foreground = covered).

    Parameters
    ----------
    intensity_um3, radius_um : float
        Intensity λ (µm⁻³) and ball radius (µm).
    voxel_um : float or (3,) floats
        Lattice spacings (µm); a voxel is foreground when its centre is covered by a ball.

    Returns
    -------
    (256,) float ndarray
        Probability of each cell code (bit dx + 2 dy + 4 dz); sums to 1.
    """
    _check_positive(intensity_um3=intensity_um3)
    uncovered = np.exp(-intensity_um3 * cell_union_volumes(float(radius_um), voxel3(voxel_um)))
    uncovered[0] = 1.0
    probabilities = np.zeros(_weights.N_CODES)
    for code in range(_weights.N_CODES):
        empty, sub = _weights.N_CODES - 1 - code, code
        while True:  # all subsets G of the covered set, (-1)^|G| Q(U ∪ G)
            probabilities[code] += (-1) ** sub.bit_count() * uncovered[empty | sub]
            if sub == 0:
                break
            sub = (sub - 1) & code
    return probabilities


def expected_densities(probabilities: np.ndarray, voxel_um, adjacency: int) -> dict[str, float]:
    """Expectation of the package's estimators of φ, S_V, K_V, χ_V under configuration probabilities.

    The same formulae as :func:`porepipe.minkowski.minkowski_from_histogram` with the histogram replaced by its
    expectation per cell (``probabilities`` sums to 1); ``adjacency`` (6 or 26) is that of the foreground.
    """
    p = np.asarray(probabilities, dtype=np.float64)
    geom = _weights.geometry(voxel3(voxel_um))
    transitions = _weights.transition_table() @ p
    sections = _weights.section_euler_table(adjacency) @ p
    return {
        "phi": float(p @ _weights.volume_table()) / _weights.VOLUME_DENOMINATOR,
        "S_V": 2.0
        * float(
            np.sum(geom.line_weight * transitions / (_weights.TRANSITION_DENOMINATOR * geom.line_length_um))
        ),
        "K_V": 2.0
        * np.pi
        * float(np.sum(geom.plane_weight * sections * geom.plane_spacing_um))
        / (_weights.SECTION_DENOMINATOR * geom.cell_volume_um3),
        "chi_V": float(p @ _weights.euler_table(adjacency))
        / (_weights.EULER_DENOMINATOR * geom.cell_volume_um3),
    }


def boolean_lattice_densities(
    intensity_um3: float, radius_um: float, voxel_um, adjacency: Adjacency | str = Adjacency.pore6_matrix26
) -> dict[str, float]:
    """Exact expectation of the measured φ, S_V, K_V, χ_V of a digitised Boolean model of balls (pore = balls).

    Parameters
    ----------
    intensity_um3, radius_um : float
        Intensity λ (µm⁻³) and ball radius (µm).
    voxel_um : float or (3,) floats
        Voxel edge lengths (µm).
    adjacency : Adjacency
        Adjacency pair; the balls are the pore phase (non-zero voxels).

    Returns
    -------
    dict
        ``phi``, ``S_V`` (µm⁻¹), ``K_V`` (µm⁻²), ``chi_V`` (µm⁻³) = T_V / 4π, the values that
        :func:`porepipe.minkowski.minkowski_functionals` returns on average for the pore phase of a periodic
        sample; compare with :func:`miles_densities` for the discretisation bias.
    """
    probabilities = lattice_code_probabilities(intensity_um3, radius_um, voxel_um)
    return expected_densities(probabilities, voxel_um, _adjacency(adjacency).of("pore"))
