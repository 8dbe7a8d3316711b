"""A tiny set of results with known convergence and known cost, and the report built from it (no workflow run).

Two quantities converge as q(a) = q∞ + c·a^p with p = 1 (porosity) and p = 2 (S_V); every run costs
T0·(a / 1 µm)^-3 seconds of computation (what a 3-D volume costs), and each of its jobs 0.8 s more in Snakemake's
benchmark (start-up). So the error falls as cost^(-p/3) and one more correct digit costs exactly 10^(3/p) times more:
×1000 for the porosity and ×10^1.5 = ×31.6 for S_V. A grey and a binary ball at two resolutions feed the cross-sections.
"""

import csv
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from porepipe._shared.store import ResultWriter
from porepipe.report import build_report
from porepipe.report._settings import Settings
from porepipe.sweep import build_sweep

A_UM = (4.0, 2.0, 1.0, 0.5)
T0_S = 2.0
STARTUP_S = 0.8
#: (name, q∞, c, p, units)
LAWS = {
    "phi[pore]": (0.35, 0.02, 1.0, "1"),
    "S_V[pore]": (0.12, -0.004, 2.0, "µm^-1"),
}
EDGE_UM = 32.0
#: an Euler number that jumps about with resolution: no limit can be fitted (status non_monotonic, q_inf NaN)
CHI = {4.0: 3.0, 2.0: 5.0, 1.0: 2.0, 0.5: 6.0}


def _ball(n: int, a: float) -> np.ndarray:
    x = (np.arange(n) + 0.5) * a - EDGE_UM / 2
    r2 = x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2
    return r2 <= (EDGE_UM / 3) ** 2


def write_results(root: Path) -> tuple[list[Path], list[Path], list[Path]]:
    """Result files eng_a{a}.h5 with the laws above, their benchmark TSVs and grey/binary volumes."""
    (root / "cost").mkdir(parents=True, exist_ok=True)
    results, grey, binary = [], [], []
    for a in A_UM:
        phi_inf, phi_c, phi_p, _ = LAWS["phi[pore]"]
        sv_inf, sv_c, sv_p, _ = LAWS["S_V[pore]"]
        phi = phi_inf + phi_c * a**phi_p
        sv = sv_inf + sv_c * a**sv_p
        ds = xr.Dataset(
            {
                "phi": ("phase", [phi, 1.0 - phi], {"units": "1"}),
                "S_V": ("phase", [sv, sv], {"units": "1/um"}),  # an old spelling: the writer respells it
                "chi": ("phase", [CHI[a], CHI[a] - 1.0]),  # no units given: the writer must not invent one
            },
            coords={"phase": ["pore", "matrix"]},
        )
        path = root / "eng" / f"eng_a{a:g}.h5"
        with ResultWriter(path, stage="eng", scene="tiny", threads=1) as w:
            w.write_table(ds)
        wall = T0_S * a**-3
        with h5py.File(path, "a") as f:  # the computation's cost, as if measured
            f.attrs["wall_s"] = wall
            f.attrs["cpu_s"] = wall
        with open(root / "cost" / f"eng_a{a:g}.tsv", "w", newline="") as fh:
            out = csv.writer(fh, delimiter="\t")
            out.writerow(["s", "h:m:s", "max_rss", "cpu_time"])
            out.writerow([wall + STARTUP_S, "0:00:01", 100.0, wall + STARTUP_S])
        results.append(path)
    for a in A_UM[:2]:
        n = int(EDGE_UM / a)
        ball = _ball(n, a)
        for kind, name, data, files in (
            ("voxelize", "grey", np.where(ball, 0, 216).astype(np.uint8), grey),
            ("segment", "pore", ball.astype(np.uint8), binary),
        ):
            path = root / kind / f"{'grey' if name == 'grey' else 'binary'}_a{a:g}.h5"
            with ResultWriter(path, stage=kind, scene="tiny") as w:
                w.write_volume(name, data, voxel_um=a)
            with h5py.File(path, "a") as f:
                f.attrs["wall_s"] = f.attrs["cpu_s"] = (
                    0.0  # upstream cost left out: the cost law above is exact
                )
            files.append(path)
    return results, grey, binary


@pytest.fixture(scope="package")
def tiny_report(tmp_path_factory):
    """(results folder, sweep path, report page) of the tiny result set; the laws are this module's LAWS."""
    root = tmp_path_factory.mktemp("tiny")
    results, grey, binary = write_results(root)
    sweep = build_sweep(results, grey + binary, root / "cost")
    with ResultWriter(root / "sweep" / "sweep.h5", stage="sweep", scene="tiny") as w:
        w.write_table(sweep)
    page = build_report(
        root / "sweep" / "sweep.h5",
        root / "report" / "index.html",
        grey=grey,
        binary=binary,
        settings=Settings(dpi=60),
    )
    return root, root / "sweep" / "sweep.h5", page


@pytest.fixture(scope="package")
def tiny_laws():
    """The convergence laws and start-up time the tiny result set was made with."""
    return {"laws": LAWS, "startup_s": STARTUP_S, "t0_s": T0_S, "a_um": A_UM}
