"""The report and the sweep on real engine output (LPT files written by porepipe.lpt), not only on fakes."""

import re

import numpy as np
import xarray as xr

from porepipe._shared.store import ResultWriter
from porepipe.lpt import Settings as LptSettings
from porepipe.lpt._run import run as lpt_file
from porepipe.report import build_report
from porepipe.report._settings import Settings
from porepipe.sweep import FULL, build_sweep, crop_corner


def test_lpt_results_join_the_sweep_and_the_report(tmp_path):
    rng = np.random.default_rng(4)
    coarse = (rng.random((8, 8, 8)) < 0.4).astype(np.uint8)
    lpt_paths, binaries = [], []
    for a, pore in ((2.0, coarse), (1.0, coarse.repeat(2, 0).repeat(2, 1).repeat(2, 2))):
        binary = tmp_path / f"binary_a{a:g}.h5"
        with ResultWriter(binary, stage="segment", scene="t") as w:
            w.write_volume("pore", pore, voxel_um=a)
        binaries.append(binary)
        out = tmp_path / f"lpt_a{a:g}.h5"
        lpt_file(binary, out, LptSettings(cell_voxels=[1, 2, 4], surface=False), plots=False, threads=1)
        lpt_paths.append(out)
    crop_corner(binaries[1], 8.0, tmp_path / "binary_a1_L8.h5")
    sub = tmp_path / "lpt_a1_L8.h5"
    lpt_file(
        tmp_path / "binary_a1_L8.h5",
        sub,
        LptSettings(cell_voxels=[1, 2, 4], surface=False),
        plots=False,
        threads=1,
    )
    ds = build_sweep([*lpt_paths, sub], binaries)
    assert {"lpt.phi_bar", "lpt.L_star_um"} <= set(ds.quantity.values)
    # a 2x refinement of the same voxels keeps the porosity exactly: phi_bar(a) is the same number at both a
    phi = ds.value.sel(quantity="lpt.phi_bar", sample_um=FULL).values
    assert phi[0] == phi[1] == coarse.mean()
    # the corner sub-sample (L = 8 µm = the coarse corner 4^3 refined) is its own sample column
    assert float(ds.value.sel(quantity="lpt.phi_bar", a_um=1.0, sample_um=8.0)) == coarse[:4, :4, :4].mean()
    with ResultWriter(tmp_path / "sweep.h5", stage="sweep") as w:
        w.write_table(ds)
    page = build_report(
        tmp_path / "sweep.h5", tmp_path / "rep" / "index.html", lpt=lpt_paths, settings=Settings(slices=False)
    ).read_text()
    assert "src='lpt.png'" in page and (tmp_path / "rep" / "lpt.png").is_file()
    with open(tmp_path / "rep" / "lpt.csv") as fh:
        assert len(fh.readlines()) == 1 + 2 * 3  # header + (2 resolutions x 3 cell sizes)
    assert re.search(r"no limit: 2 point\(s\) for 3 parameters", page)  # free p from 2 resolutions: refused
    with xr.open_dataset(lpt_paths[0], engine="h5netcdf") as raw:
        assert raw.sizes["L"] == 3
