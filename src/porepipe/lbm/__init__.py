"""Lattice-Boltzmann permeability (D3Q19; BGK, TRT, MRT; sparse pore-node storage), thesis chapter 6."""

from porepipe.lbm._api import DARCY_M2, PermeabilityResult, kappa_units, permeability
from porepipe.lbm._settings import Axis, Collision, Gradient, Lateral, Precision, Settings, Setup, Velocity
from porepipe.lbm._solver import StabilityError

__all__ = [
    "DARCY_M2",
    "Axis",
    "Collision",
    "Gradient",
    "Lateral",
    "PermeabilityResult",
    "Precision",
    "Settings",
    "Setup",
    "StabilityError",
    "Velocity",
    "kappa_units",
    "permeability",
]
