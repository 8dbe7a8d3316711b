"""Tables 5.1/5.2 from two scenes' sweeps (PP and FP, report.thesis_rows_from) and the REV table, on constructed sweeps.

The sweeps are built by hand, so every number in a row is known: the tables must copy the pipeline's value, put the
thesis's printed value beside it (Zauner 2020 Tables 5.1 and 5.2, from the spec digest) and take the difference.
"""

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from porepipe.report import thesis_tables
from porepipe.report._rev import rev_rows
from porepipe.report._settings import ThesisTable

PHI, KAPPA = "minkowski.phi[pore]", "permeability_z.kappa_mD"


def _sweep(values: dict, a=(1.0, 0.5), samples=(40.0, np.inf), rev=None):
    """values: (quantity, a, sample) -> value; rev: (quantity, a, sample) -> (spread, count)."""
    quantities = sorted({q for q, _, _ in values})
    shape = (len(quantities), len(a), len(samples))
    ds = xr.Dataset(
        coords={"quantity": np.array(quantities, dtype=object), "a_um": list(a), "sample_um": list(samples)}
    )
    for name in ("value", "rev_spread", "cpu_s"):
        ds[name] = (("quantity", "a_um", "sample_um"), np.full(shape, np.nan))
    ds["rev_count"] = (("quantity", "a_um", "sample_um"), np.zeros(shape, dtype=int))
    for (q, ai, s), v in values.items():
        at = {"quantity": q, "a_um": ai, "sample_um": s}
        ds["value"].loc[at] = v
        ds["cpu_s"].loc[at] = 2.5
        ds["rev_count"].loc[at] = 1
    for (q, ai, s), (spread, count) in (rev or {}).items():
        at = {"quantity": q, "a_um": ai, "sample_um": s}
        ds["rev_spread"].loc[at] = spread
        ds["rev_count"].loc[at] = count
    return ds


@pytest.fixture
def sweeps():
    pp = _sweep({(PHI, 1.0, np.inf): 0.19, (KAPPA, 1.0, 40.0): 700.0}, rev={(KAPPA, 1.0, 40.0): (35.0, 8)})
    fp = _sweep({(PHI, 1.0, np.inf): 0.17, (PHI, 0.5, np.inf): 0.168, (KAPPA, 1.0, np.inf): 190.0})
    return pp, fp


def _row(table, label, quantity):
    (row,) = [r for r in table.rows if r[0] == label and r[1].startswith(quantity)]
    return dict(zip(table.columns, row))


def test_rows_of_both_models_come_from_their_own_scenes(sweeps):
    pp, fp = sweeps
    t51, t52 = thesis_tables(fp, [ThesisTable.t5_1, ThesisTable.t5_2], "FP", others={"PP": pp})
    assert [r[0] for r in t51.rows[::4]] == [
        f"{m} a = {a:g} um" for m in ("PP", "FP") for a in (1, 0.5, 0.25)
    ]
    pp1, fp1 = _row(t51, "PP a = 1 um", "phi"), _row(t51, "FP a = 1 um", "phi")
    assert (pp1["thesis"], pp1["porepipe"]) == (0.182749, 0.19)  # thesis Table 5.1, PP a = 1 µm
    assert (fp1["thesis"], fp1["porepipe"]) == (0.165780, 0.17)
    assert pp1["difference"] == pytest.approx(0.19 - 0.182749, abs=1e-15)
    assert "whole volume, 2.5 CPU s" in fp1["source and cost"]
    assert np.isnan(_row(t51, "PP a = 0.5 um", "phi")["porepipe"])  # not run: no number
    assert t51.scene_values and t52.scene_values


def test_permeability_row_from_a_sub_sample_says_so_with_its_rev_spread(sweeps):
    pp, fp = sweeps
    (t52,) = thesis_tables(fp, [ThesisTable.t5_2], "FP", others={"PP": pp})
    pp1, fp1 = _row(t52, "PP a = 1 um", "kappa"), _row(t52, "FP a = 1 um", "kappa")
    assert (pp1["thesis"], pp1["porepipe"]) == (660.2, 700.0)  # thesis Table 5.2
    assert pp1["source and cost"].startswith("sub-sample L = 40 um ± 35 (REV spread of 8)")
    assert (fp1["thesis"], fp1["porepipe"]) == (200.7, 190.0)
    assert fp1["source and cost"].startswith("whole volume")


def test_without_thesis_rows_from_only_the_scenes_model_is_shown(sweeps):
    _, fp = sweeps
    (t51,) = thesis_tables(fp, [ThesisTable.t5_1], "FP")
    assert {r[0].split()[0] for r in t51.rows} == {"FP"}


def test_rev_table_lists_only_quantities_with_several_sub_samples(sweeps):
    pp, _ = sweeps
    rows = rev_rows(pp)
    assert len(rows) == 1
    quantity, unit, a, edge, count, mean, spread, whole = rows[0]
    assert (quantity, a, edge, count, mean, spread) == (KAPPA, 1.0, 40.0, 8, 700.0, 35.0)
    assert np.isnan(whole)
    assert rev_rows(_sweep({(PHI, 1.0, np.inf): 0.2})) == []


def test_missing_sweep_of_a_thesis_rows_scene_is_one_clear_error(tmp_path, monkeypatch):
    """report.thesis_rows_from names a scene whose sweep was not built: one line naming the key and the file."""
    from types import SimpleNamespace

    from porepipe._shared.errors import PorepipeError
    from porepipe.report._run import thesis_row_sweeps
    from porepipe.report._settings import Settings

    monkeypatch.chdir(tmp_path)
    scene = SimpleNamespace(report=Settings(thesis_rows_from={"PP": "thesis-pp"}))
    with pytest.raises(
        PorepipeError, match=r"report\.thesis_rows_from\.PP: results/thesis-pp/sweep/sweep\.h5"
    ):
        thesis_row_sweeps(scene)
    (tmp_path / "results/thesis-pp/sweep").mkdir(parents=True)
    (tmp_path / "results/thesis-pp/sweep/sweep.h5").write_bytes(b"")
    assert thesis_row_sweeps(scene) == {"PP": Path("results/thesis-pp/sweep/sweep.h5")}


def test_a_row_costs_its_run_and_the_making_of_its_binary_volume(sweeps):
    _, fp = sweeps
    fp = fp.assign(upstream_cpu_s=(("a_um", "sample_um"), [[np.nan, 7.0], [np.nan, 30.0]]))
    (t51,) = thesis_tables(fp, [ThesisTable.t5_1], "FP")
    assert _row(t51, "FP a = 1 um", "phi")["source and cost"] == (
        "whole volume, 2.5 CPU s (+ 7.0 CPU s to voxelise and segment)"
    )
    assert _row(t51, "FP a = 0.5 um", "phi")["source and cost"].endswith(
        "(+ 30.0 CPU s to voxelise and segment)"
    )


@pytest.mark.parametrize(
    ("edge_voxels", "label"),
    [
        (100, "whole scene volume, 100³ um: a sub-volume of the thesis's 300³ um box, 2.5 CPU s"),
        (300, "whole volume, 300³ um, 2.5 CPU s"),
    ],
)
def test_a_whole_volume_row_names_its_edge_and_whether_it_is_the_thesis_box(sweeps, edge_voxels, label):
    """thesis-5.6.1-sub measures the corner [0, 100]³ um of the thesis's 300³ um box: its rows must not read as the
    whole box's. The sweep's ``voxels`` at a = 1 um give the edge."""
    _, fp = sweeps
    voxels = [[float(edge_voxels) ** 3] * 2, [float(2 * edge_voxels) ** 3] * 2]
    fp = fp.assign(voxels=(("a_um", "sample_um"), voxels))
    (t51,) = thesis_tables(fp, [ThesisTable.t5_1], "FP")
    assert _row(t51, "FP a = 1 um", "phi")["source and cost"] == label
    assert _row(t51, "FP a = 0.5 um", "phi")["source and cost"].startswith(label.split(",")[0])
