"""Result files describe themselves: named dimensions, coordinates in µm, units pint reads, one open_result."""

import numpy as np
import pint
import pytest
import xarray as xr

from porepipe import open_result
from porepipe._shared.store import ResultWriter, label_dims, read_binary_volume, read_volume
from porepipe._shared.units import ALIASES, SUFFIXES, annotate, canonical

UREG = pint.UnitRegistry()


def test_every_spelling_porepipe_writes_is_one_pint_reads():
    for units in {*ALIASES.values(), *(u for _, u in SUFFIXES)}:
        UREG.Unit(units)
    # the pitfalls the module avoids: pint reads mD as millidebye and D as debye
    assert UREG.Quantity(1, canonical("mD")[0]).to("m^2").magnitude == pytest.approx(9.869233e-16, rel=1e-6)
    assert UREG.Quantity(1, canonical("1/um")[0]).to("1/m").magnitude == pytest.approx(1e6, rel=1e-12)


def test_annotate_respells_and_fills_units_but_invents_none():
    ds = xr.Dataset(
        {
            "S_V": ((), 0.1, {"units": "1/um"}),
            "kappa_mD": ((), 500.0),
            "kappa_lu": ((), 0.3, {"units": "voxel^2"}),
            "count": ((), np.int64(3)),
            "mystery": ((), 1.5),
        }
    )
    out = annotate(ds)
    assert out.S_V.attrs["units"] == "µm^-1" and out.kappa_mD.attrs["units"] == "millidarcy"
    assert out.kappa_lu.attrs == {"units": "1", "lattice_units": "voxel^2"}
    assert out["count"].attrs["units"] == "1" and "units" not in out.mystery.attrs
    assert ds.S_V.attrs["units"] == "1/um"  # the caller's Dataset is left as it was


def test_volume_opens_with_coordinates_of_the_voxel_centres(tmp_path):
    path = tmp_path / "binary_a2.h5"
    pore = (np.arange(3 * 4 * 5).reshape(3, 4, 5) % 2).astype(np.uint8)
    with ResultWriter(path, stage="segment") as w:
        w.write_volume("pore", pore, voxel_um=2.0, origin_um=(10.0, 0.0, -4.0), attrs={"threshold": 107})
        w.write_table(xr.Dataset({"porosity": ((), float(pore.mean()), {"units": "1"})}))
    ds = open_result(path)
    assert ds.pore.dims == ("x_um", "y_um", "z_um")
    # voxel i covers [origin + i a, origin + (i + 1) a): its centre is origin + (i + 1/2) a
    np.testing.assert_array_equal(ds.x_um.values, [11.0, 13.0, 15.0])
    np.testing.assert_array_equal(ds.z_um.values, [-3.0, -1.0, 1.0, 3.0, 5.0])
    assert all(ds[c].attrs["units"] == "µm" for c in ("x_um", "y_um", "z_um"))
    np.testing.assert_array_equal(ds.pore.values, pore)
    assert ds.attrs["stage"] == "segment" and ds.porosity.attrs["units"] == "1"
    # the readers of before see the same volume and attributes, without the dimension-scale bookkeeping
    data, attrs = read_volume(path, "pore")
    np.testing.assert_array_equal(data, pore)
    assert set(attrs) == {"voxel_um", "origin_um", "periodic", "threshold", "units"}
    assert read_binary_volume(path)[1].origin_um == (10.0, 0.0, -4.0)


def test_volumes_on_other_grids_get_their_own_coordinates(tmp_path):
    path = tmp_path / "two.h5"
    with ResultWriter(path, stage="x") as w:
        w.write_volume("a", np.zeros((2, 2, 2), np.uint8), voxel_um=1.0)
        w.write_volume("b", np.zeros((2, 2, 2), np.uint8), voxel_um=1.0)
        w.write_volume("c", np.zeros((4, 2, 2), np.uint8), voxel_um=0.5, origin_um=(0, 0.25, 0.25))
    ds = open_result(path)
    assert ds.a.dims == ds.b.dims == ("x_um", "y_um", "z_um")
    assert ds.c.dims == ("x_um_c", "y_um_c", "z_um_c")
    np.testing.assert_array_equal(ds.x_um_c.values, [0.25, 0.75, 1.25, 1.75])


def test_named_plain_datasets_open_as_a_dataset_over_sphere_and_xyz(tmp_path):
    path = tmp_path / "packing.h5"
    with ResultWriter(path, stage="pack") as w:
        w.h5.create_dataset("centres_um", data=np.arange(6.0).reshape(2, 3)).attrs["units"] = "µm"
        w.h5.create_dataset("radii_um", data=[1.0, 2.0]).attrs["units"] = "µm"
        label_dims(w.h5, {"centres_um": ("sphere", "xyz"), "radii_um": ("sphere",)}, {"xyz": ["x", "y", "z"]})
        w.write_array("sphere_radii_um", np.array([1.0, 2.0]), dims=("sphere",))
    ds = open_result(path)
    assert ds.centres_um.dims == ("sphere", "xyz") and list(ds.xyz.values) == ["x", "y", "z"]
    assert ds.radii_um.dims == ("sphere",) and ds.sphere_radii_um.attrs["units"] == "µm"
    np.testing.assert_array_equal(ds.centres_um.sel(xyz="y").values, [1.0, 4.0])
