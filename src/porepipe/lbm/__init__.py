"""Lattice-Boltzmann permeability (D3Q19; BGK, TRT, MRT; sparse pore-node storage), thesis chapter 6."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "Axis": "_settings",
    "Collision": "_settings",
    "DARCY_M2": "_api",
    "Gradient": "_settings",
    "Lateral": "_settings",
    "PermeabilityResult": "_api",
    "Precision": "_settings",
    "Settings": "_settings",
    "Setup": "_settings",
    "StabilityError": "_solver",
    "Velocity": "_settings",
    "kappa_units": "_api",
    "permeability": "_api",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
