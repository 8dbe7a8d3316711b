"""The CLI layer: minkowski_a{a}.h5 read back with xarray equals the in-memory API; units and boundary stored."""

import numpy as np
import pytest
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter
from porepipe.minkowski import minkowski_functionals
from porepipe.minkowski._run import THRESHOLD_GROUP
from porepipe.minkowski._run import run as minkowski_file
from porepipe.minkowski._settings import Settings


@pytest.fixture()
def volumes(tmp_path):
    rng = np.random.default_rng(4)
    grey = rng.integers(0, 217, (11, 9, 13)).astype(np.uint8)
    with ResultWriter(tmp_path / "grey_a2.h5", stage="voxelize", scene="t") as w:
        w.write_volume("grey", grey, voxel_um=2.0, periodic=(True, False, True))
    with ResultWriter(tmp_path / "binary_a2.h5", stage="segment", scene="t") as w:
        w.write_volume("pore", (grey <= 120).astype(np.uint8), voxel_um=2.0, periodic=(True, False, True))
    return tmp_path, grey


def test_file_matches_api_and_carries_units(volumes):
    path, grey = volumes
    out = path / "minkowski_a2.h5"
    minkowski_file(path / "binary_a2.h5", out, Settings(slab_planes=3), grey_path=path / "grey_a2.h5")
    ds = xr.open_dataset(out, engine="h5netcdf").load()
    expected = minkowski_functionals(grey <= 120, 2.0, (True, False, True))
    for name in ("phi", "S_V", "K_V", "T_V", "chi", "histogram"):
        np.testing.assert_array_equal(
            ds[name].values, expected[name].values
        )  # same integers, same arithmetic
    assert (ds.S_V.attrs["units"], ds.K_V.attrs["units"], ds.T_V.attrs["units"]) == (
        "µm^-1",
        "µm^-2",
        "µm^-3",
    )
    assert ds.attrs["boundary"] == "mixed" and list(ds.attrs["periodic"]) == [1, 0, 1]
    assert ds.attrs["adjacency_pair"] == "pore6_matrix26"
    thr = xr.open_dataset(out, engine="h5netcdf", group=THRESHOLD_GROUP).load()
    np.testing.assert_array_equal(thr.histogram.sel(g_th=120).values, expected.histogram.values)
    assert int(thr.g_th.max()) == int(grey.max())


def test_missing_volume_is_a_clear_error(volumes):
    path, _ = volumes
    with pytest.raises(PorepipeError, match="no volume 'pore'"):
        minkowski_file(path / "grey_a2.h5", path / "out.h5")
    assert not (path / "out.h5").exists()
