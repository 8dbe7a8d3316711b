"""Lattice-Boltzmann permeability (D3Q19; TRT, BGK, MRT; halfway or interpolated walls; sparse pore nodes), ch. 6."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "Axis": "_settings",
    "Collision": "_settings",
    "DARCY_M2": "_api",
    "Gradient": "_settings",
    "GrainWalls": "_walls",
    "GreyWalls": "_walls",
    "Lateral": "_settings",
    "PermeabilityResult": "_api",
    "Precision": "_settings",
    "Settings": "_settings",
    "Setup": "_settings",
    "SphereWalls": "_walls",
    "StabilityError": "_solver",
    "StopRule": "_settings",
    "Streaming": "_settings",
    "Velocity": "_settings",
    "Walls": "_settings",
    "kappa_units": "_api",
    "permeability": "_api",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
