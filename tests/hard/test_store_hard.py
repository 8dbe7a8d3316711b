"""Result-file readers (porepipe._shared.store) on files that are HDF5 but not quite porepipe results."""

import h5py
import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import read_binary_volume


def _volume(path, **attrs):
    with h5py.File(path, "w") as f:
        f.attrs["stage"] = "segment"
        dset = f.create_group("volumes").create_dataset("pore", data=np.ones((4, 4, 4), np.uint8))
        for key, value in {
            "voxel_um": 4.0,
            "origin_um": [0.0, 0.0, 0.0],
            "periodic": [1, 1, 1],
            **attrs,
        }.items():
            dset.attrs[key] = value
    return path


@pytest.mark.parametrize(
    ("key", "value"), [("voxel_um", "abc"), ("origin_um", "abc"), ("origin_um", ["a", "b", "c"])]
)
def test_a_text_geometry_attribute_is_one_line_naming_it(key, value, tmp_path):
    """numpy's 'could not convert string to float' escaped every reader of a volume before."""
    path = _volume(tmp_path / "v.h5", **{key: value})
    with pytest.raises(PorepipeError, match=f"attribute {key} = .*allowed") as err:
        read_binary_volume(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_open_result_of_a_file_whose_volumes_is_not_a_group_is_one_line(tmp_path):
    """A file whose ``volumes`` is a dataset, not a group, raised h5netcdf's raw OSError from open_result."""
    from porepipe import open_result

    path = tmp_path / "odd.h5"
    with h5py.File(path, "w") as f:
        f.attrs["stage"] = "segment"
        f.create_dataset("volumes", data=np.ones(3))
    with pytest.raises(PorepipeError, match="cannot read its groups") as err:
        open_result(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)
