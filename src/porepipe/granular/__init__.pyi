"""Type stub of porepipe.granular: its lazy exports (``_EXPORTS`` in __init__.py) for IDEs and type checkers.

Kept equal to the export table by tests/unit/store/test_stubs.py.
"""

from porepipe.granular._api import Frame as Frame
from porepipe.granular._api import Simulation as Simulation
from porepipe.granular._api import polygon_overlap as polygon_overlap
from porepipe.granular._api import time_step_rule as time_step_rule
from porepipe.granular._elastic import elastic_constants as elastic_constants
from porepipe.granular._elastic import unloading_frames as unloading_frames
from porepipe.granular._galton import GaltonBoard as GaltonBoard
from porepipe.granular._galton import chi2_binomial as chi2_binomial
from porepipe.granular._galton import decision_stats as decision_stats
from porepipe.granular._galton import galton_paths as galton_paths
from porepipe.granular._heap import analyse_heap as analyse_heap
from porepipe.granular._heap import floor_dip_ensemble as floor_dip_ensemble
from porepipe.granular._heap import heap_ensemble as heap_ensemble
from porepipe.granular._heap import heap_stress_angles as heap_stress_angles
from porepipe.granular._heap import wittmer_angles as wittmer_angles
from porepipe.granular._measure import contact_persistence as contact_persistence
from porepipe.granular._measure import coordination as coordination
from porepipe.granular._measure import diagonal_strain as diagonal_strain
from porepipe.granular._measure import displacement_grid as displacement_grid
from porepipe.granular._measure import force_directions as force_directions
from porepipe.granular._measure import force_magnitudes as force_magnitudes
from porepipe.granular._measure import frame_contacts as frame_contacts
from porepipe.granular._measure import frame_particles as frame_particles
from porepipe.granular._measure import packing_fraction as packing_fraction
from porepipe.granular._measure import plane_strain_constants as plane_strain_constants
from porepipe.granular._measure import polygon_area as polygon_area
from porepipe.granular._measure import pressure_dip as pressure_dip
from porepipe.granular._measure import pressure_profile as pressure_profile
from porepipe.granular._measure import repose_angle_fit as repose_angle_fit
from porepipe.granular._measure import repose_angle_integral as repose_angle_integral
from porepipe.granular._measure import scaled_profile as scaled_profile
from porepipe.granular._measure import stress_tensor as stress_tensor
from porepipe.granular._measure import surface_profile as surface_profile
from porepipe.granular._measure import wall_contacts as wall_contacts
from porepipe.granular._run import read_granular as read_granular
from porepipe.granular._run import run as run
from porepipe.granular._settings import Settings as Settings
from porepipe.granular._shapes import AngleMode as AngleMode
from porepipe.granular._shapes import Dist as Dist
from porepipe.granular._shapes import check_convex as check_convex
from porepipe.granular._shapes import ellipse_polygon as ellipse_polygon
from porepipe.granular._shapes import polygon_properties as polygon_properties
from porepipe.granular._shapes import rectangle as rectangle
from porepipe.granular._shapes import regular_polygon as regular_polygon
from porepipe.granular._silo import THESIS_MIN_WIDTH_GRAINS as THESIS_MIN_WIDTH_GRAINS
from porepipe.granular._silo import THESIS_SHAPES as THESIS_SHAPES
from porepipe.granular._silo import THESIS_SILO as THESIS_SILO
from porepipe.granular._silo import analyse_silo as analyse_silo
from porepipe.granular._silo import inner_extent as inner_extent
from porepipe.granular._silo import resolve_wall_contacts as resolve_wall_contacts
from porepipe.granular._silo import wall_by_name as wall_by_name
from porepipe.granular._silo import wall_profiles as wall_profiles
from porepipe.granular._silo_shape import fit_shaped_mu_j as fit_shaped_mu_j
from porepipe.granular._silo_shape import shaped_sigma_zz as shaped_sigma_zz
from porepipe.granular._silo_shape import shifted_silo as shifted_silo
from porepipe.granular._silo_shape import silo_half_width as silo_half_width
from porepipe.granular._silo_shape import silo_wall_slabs as silo_wall_slabs
from porepipe.granular._theory import closure_ife as closure_ife
from porepipe.granular._theory import closure_linear as closure_linear
from porepipe.granular._theory import fit_janssen as fit_janssen
from porepipe.granular._theory import hopper_sigma_zz as hopper_sigma_zz
from porepipe.granular._theory import janssen as janssen
from porepipe.granular._theory import lateral_pressure_bounds as lateral_pressure_bounds
from porepipe.granular._theory import parabolic_r_p as parabolic_r_p
from porepipe.granular._theory import parabolic_sigma_zz as parabolic_sigma_zz
from porepipe.granular._theory import parabolic_xi as parabolic_xi
from porepipe.granular._theory import principal_angle as principal_angle
from porepipe.granular._theory import silo_sigma_zz as silo_sigma_zz
from porepipe.granular._theory import silo_xi as silo_xi
from porepipe.granular._theory import stepped_silo as stepped_silo
from porepipe.granular._theory import wedge_stress as wedge_stress

__all__ = [
    "THESIS_MIN_WIDTH_GRAINS",
    "THESIS_SHAPES",
    "THESIS_SILO",
    "AngleMode",
    "Dist",
    "Frame",
    "GaltonBoard",
    "Settings",
    "Simulation",
    "analyse_heap",
    "analyse_silo",
    "check_convex",
    "chi2_binomial",
    "closure_ife",
    "closure_linear",
    "contact_persistence",
    "coordination",
    "decision_stats",
    "diagonal_strain",
    "displacement_grid",
    "elastic_constants",
    "ellipse_polygon",
    "fit_janssen",
    "fit_shaped_mu_j",
    "floor_dip_ensemble",
    "force_directions",
    "force_magnitudes",
    "frame_contacts",
    "frame_particles",
    "galton_paths",
    "heap_ensemble",
    "heap_stress_angles",
    "hopper_sigma_zz",
    "inner_extent",
    "janssen",
    "lateral_pressure_bounds",
    "packing_fraction",
    "parabolic_r_p",
    "parabolic_sigma_zz",
    "parabolic_xi",
    "plane_strain_constants",
    "polygon_area",
    "polygon_overlap",
    "polygon_properties",
    "pressure_dip",
    "pressure_profile",
    "principal_angle",
    "read_granular",
    "rectangle",
    "regular_polygon",
    "repose_angle_fit",
    "repose_angle_integral",
    "resolve_wall_contacts",
    "run",
    "scaled_profile",
    "shaped_sigma_zz",
    "shifted_silo",
    "silo_half_width",
    "silo_sigma_zz",
    "silo_wall_slabs",
    "silo_xi",
    "stepped_silo",
    "stress_tensor",
    "surface_profile",
    "time_step_rule",
    "unloading_frames",
    "wall_by_name",
    "wall_contacts",
    "wall_profiles",
    "wedge_stress",
    "wittmer_angles",
]
