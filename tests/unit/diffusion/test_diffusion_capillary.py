"""Scene key diffusion.geometry: the synthetic capillaries built from the scene (wiring of the tested generators).

Truth: the generator functions called directly with the sizes in voxels (their own geometry is checked in
test_diffusion_geometry.py and against Clausing's W in tests/validation); here the µm -> voxel conversion, the file
written for the workflow and the error lines are checked.
"""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import read_binary_volume
from porepipe.diffusion import (
    CapillaryGeometry,
    build_capillary,
    constricted_capillary,
    cylinder,
    pocketed_capillary,
    rough_capillary,
    slit,
    square_capillary,
    write_capillary,
)


@pytest.mark.parametrize(
    ("spec", "a_um", "direct"),
    [
        ({"kind": "square", "a": 6, "length": 20}, 1.0, lambda: square_capillary(6, 20)),
        ({"kind": "square", "a_um": 3, "length_um": 10}, 0.5, lambda: square_capillary(6, 20)),
        ({"kind": "cylinder", "radius_um": 4, "length_um": 8}, 0.5, lambda: cylinder(8, 16)),
        ({"kind": "cylinder", "radius": 2.5, "length": 7}, 2.0, lambda: cylinder(2.5, 7)),
        ({"kind": "slit", "width": 5, "length": 12}, 1.0, lambda: slit(5, 12, 4)),
        (
            {"kind": "constricted", "radius": 6, "length": 30, "throat_radius": 2, "throat_length": 3},
            1.0,
            lambda: constricted_capillary(6, 30, 2, 3),
        ),
        (
            {"kind": "pocketed", "a": 6, "length": 30, "pocket_depth": 4, "pocket_width": 2, "n_pockets": 4},
            1.0,
            lambda: pocketed_capillary(6, 30, 4, 2, 4),
        ),
        (
            {"kind": "rough", "a": 8, "length": 20, "roughness": 0.4},
            1.0,
            lambda: rough_capillary(8, 20, 0.4, seed=5),
        ),
    ],
)
def test_scene_geometry_builds_the_generator_volume(spec, a_um, direct):
    vol = build_capillary(CapillaryGeometry(**spec), a_um, seed=5)
    ref = direct()
    np.testing.assert_array_equal(vol.pore, ref.pore)
    np.testing.assert_array_equal(vol.periodic, ref.periodic)


def test_written_capillary_reads_as_a_binary_volume(tmp_path):
    out = write_capillary(CapillaryGeometry(kind="slit", width_um=2.0, length_um=6.0), 0.5, tmp_path / "b.h5")
    pore, meta = read_binary_volume(out, anisotropic=True)
    assert pore.shape == (4, 4, 12)
    assert meta.voxel_xyz_um == (0.5, 0.5, 0.5)
    assert tuple(bool(p) for p in meta.periodic) == (False, True, False)


@pytest.mark.parametrize(
    ("spec", "a_um", "message"),
    [
        ({"kind": "square", "a_um": 3, "length": 10}, 2.0, "diffusion.geometry.a_um = 3"),
        ({"kind": "cylinder", "radius": 2, "length_um": 0.2}, 1.0, "diffusion.geometry.length_um = 0.2"),
        (
            {"kind": "constricted", "radius": 3, "length": 9, "throat_radius": 3, "throat_length": 1},
            1.0,
            "diffusion.geometry.throat_radius",
        ),
    ],
)
def test_bad_sizes_name_the_key(spec, a_um, message):
    with pytest.raises(PorepipeError, match=message):
        build_capillary(CapillaryGeometry(**spec), a_um)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ({"kind": "cylinder", "radius": 2}, "kind cylinder needs length"),
        ({"kind": "square", "a": 2, "a_um": 2, "length": 3}, "give a .voxels. or a_um .µm., not both"),
        ({"kind": "square", "a": 2, "length": 3, "radius": 1}, "radius is not a size of kind square"),
    ],
)
def test_scene_key_errors_name_the_size(spec, message):
    with pytest.raises(ValueError, match=message):
        CapillaryGeometry(**spec)
