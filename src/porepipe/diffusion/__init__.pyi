"""Type stub of porepipe.diffusion: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.diffusion._api import DiffusionResult as DiffusionResult
from porepipe.diffusion._api import Geometry as Geometry
from porepipe.diffusion._api import equilibrium as equilibrium
from porepipe.diffusion._api import prepare as prepare
from porepipe.diffusion._api import transport as transport
from porepipe.diffusion._capillary import CapillaryGeometry as CapillaryGeometry
from porepipe.diffusion._capillary import CapillaryKind as CapillaryKind
from porepipe.diffusion._capillary import build_capillary as build_capillary
from porepipe.diffusion._capillary import check_capillary_resolutions as check_capillary_resolutions
from porepipe.diffusion._capillary import write_capillary as write_capillary
from porepipe.diffusion._edmd import make_gas as make_gas
from porepipe.diffusion._edmd import reactive_pore as reactive_pore
from porepipe.diffusion._geometry import PoreVolume as PoreVolume
from porepipe.diffusion._geometry import accessible_pore as accessible_pore
from porepipe.diffusion._geometry import closed_box as closed_box
from porepipe.diffusion._geometry import constricted_capillary as constricted_capillary
from porepipe.diffusion._geometry import cylinder as cylinder
from porepipe.diffusion._geometry import pocketed_capillary as pocketed_capillary
from porepipe.diffusion._geometry import rough_capillary as rough_capillary
from porepipe.diffusion._geometry import slit as slit
from porepipe.diffusion._geometry import square_capillary as square_capillary
from porepipe.diffusion._geometry import wall_area as wall_area
from porepipe.diffusion._length_series import fit_length_series as fit_length_series
from porepipe.diffusion._length_series import length_series as length_series
from porepipe.diffusion._reactions import eta_of_phi as eta_of_phi
from porepipe.diffusion._reactions import phi_of_eta as phi_of_eta
from porepipe.diffusion._settings import Axis as Axis
from porepipe.diffusion._settings import GasSettings as GasSettings
from porepipe.diffusion._settings import InletLaw as InletLaw
from porepipe.diffusion._settings import ReactionSettings as ReactionSettings
from porepipe.diffusion._settings import Settings as Settings
from porepipe.diffusion._settings import Setup as Setup
from porepipe.diffusion._settings import SpeedDist as SpeedDist
from porepipe.diffusion._settings import WallLaw as WallLaw
from porepipe.diffusion._settings import WallSpeed as WallSpeed
from porepipe.diffusion._species import SPECIES as SPECIES
from porepipe.diffusion._species import mean_speed as mean_speed
from porepipe.diffusion._surface import Adsorbate as Adsorbate
from porepipe.diffusion._surface import Mechanism as Mechanism
from porepipe.diffusion._surface import SideReaction as SideReaction
from porepipe.diffusion._surface import surface_run as surface_run

__all__ = [
    "SPECIES",
    "Adsorbate",
    "Axis",
    "CapillaryGeometry",
    "CapillaryKind",
    "DiffusionResult",
    "GasSettings",
    "Geometry",
    "InletLaw",
    "Mechanism",
    "PoreVolume",
    "ReactionSettings",
    "Settings",
    "Setup",
    "SideReaction",
    "SpeedDist",
    "WallLaw",
    "WallSpeed",
    "accessible_pore",
    "build_capillary",
    "check_capillary_resolutions",
    "closed_box",
    "constricted_capillary",
    "cylinder",
    "equilibrium",
    "eta_of_phi",
    "fit_length_series",
    "length_series",
    "make_gas",
    "mean_speed",
    "phi_of_eta",
    "pocketed_capillary",
    "prepare",
    "reactive_pore",
    "rough_capillary",
    "slit",
    "square_capillary",
    "surface_run",
    "transport",
    "wall_area",
    "write_capillary",
]
