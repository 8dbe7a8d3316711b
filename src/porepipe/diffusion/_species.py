"""Gas species (thesis Table 3.1 van der Waals radii; molar masses) and the voxel/jiffie <-> SI conversion.

Inside the engine lengths are in units of the smallest voxel edge ("voxels") and times in jiffies, the time the
lightest species needs to fly one voxel at its mean thermal speed (thesis §3.2.3: its v̄ = 1 voxel/jiffie).
"""

from __future__ import annotations

import math

from porepipe._shared.errors import PorepipeError, positive_number

#: gas constant (thesis value, J K^-1 mol^-1)
R_GAS = 8.31441

#: name -> (van der Waals radius nm (Table 3.1), molar mass g/mol); "butene" is the thesis's fictitious test gas
#: of §4.2.3 (58 g/mol, r = 0.26 nm).
SPECIES: dict[str, tuple[float, float]] = {
    "Ar": (0.1771, 39.948),
    "C(CH3)4": (0.3232, 72.151),
    "C2H6": (0.2222, 30.069),
    "C2H4": (0.2082, 28.053),
    "He": (0.1278, 4.0026),
    "CO2": (0.1971, 44.009),
    "CO": (0.1845, 28.010),
    "C3H8": (0.2559, 44.096),
    "C3H6": (0.2339, 42.080),
    "O2": (0.1734, 31.998),
    "N2": (0.1899, 28.013),
    "H2": (0.1414, 2.0159),
    "butene": (0.26, 58.0),
}


def mean_speed(species: str, temperature_K: float) -> float:
    """Mean thermal speed v̄ = sqrt(8RT / (pi M)) in m/s (thesis 3.1)."""
    if species not in SPECIES:
        raise PorepipeError(f"unknown species {species!r}; allowed: {', '.join(SPECIES)}")
    positive_number("temperature_K", temperature_K)
    molar_kg = SPECIES[species][1] * 1e-3
    # sqrt(T) apart: 8·R·T overflowed to inf (v̄ = inf m/s, D in m²/s inf) above T ~ 1e307 K, a finite setting
    return math.sqrt(8.0 * R_GAS / (math.pi * molar_kg)) * math.sqrt(temperature_K)


def jiffie_s(voxel_m: float, lightest_mean_speed: float) -> float:
    """Duration of one jiffie in seconds: one voxel edge at the lightest species' mean speed."""
    return voxel_m / lightest_mean_speed
