"""Knudsen diffusion in the voxel pore space: exact flights, wall laws, transmission, D_eff (Mahler 2001, ch. 2-3);
the event-driven hard-sphere gas and wall reactions (ch. 3-4).
"""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "Adsorbate": "_surface",
    "Axis": "_settings",
    "CapillaryGeometry": "_capillary",
    "CapillaryKind": "_capillary",
    "DiffusionResult": "_api",
    "GasSettings": "_settings",
    "Geometry": "_api",
    "InletLaw": "_settings",
    "Mechanism": "_surface",
    "PoreVolume": "_geometry",
    "ReactionSettings": "_settings",
    "SPECIES": "_species",
    "Settings": "_settings",
    "Setup": "_settings",
    "SideReaction": "_surface",
    "SpeedDist": "_settings",
    "WallLaw": "_settings",
    "WallSpeed": "_settings",
    "accessible_pore": "_geometry",
    "build_capillary": "_capillary",
    "check_capillary_resolutions": "_capillary",
    "closed_box": "_geometry",
    "constricted_capillary": "_geometry",
    "cylinder": "_geometry",
    "equilibrium": "_api",
    "fit_length_series": "_length_series",
    "eta_of_phi": "_reactions",
    "make_gas": "_edmd",
    "mean_speed": "_species",
    "phi_of_eta": "_reactions",
    "pocketed_capillary": "_geometry",
    "prepare": "_api",
    "reactive_pore": "_edmd",
    "rough_capillary": "_geometry",
    "slit": "_geometry",
    "square_capillary": "_geometry",
    "surface_run": "_surface",
    "transport": "_api",
    "length_series": "_length_series",
    "wall_area": "_geometry",
    "write_capillary": "_capillary",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
