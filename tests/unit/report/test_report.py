"""Report pieces: Pareto front and cost per digit against brute force / closed form, thesis tables, the page."""

import json
import re

import numpy as np
import pytest
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter
from porepipe.report import build_report, cost_per_digit, error_cost_table, pareto_front, thesis_tables
from porepipe.report._settings import Settings, ThesisTable
from porepipe.sweep import build_sweep


def naive_front(cost, err):
    """A run is on the front if no other run is at most as costly and at most as wrong, and better in one."""
    out = []
    for i in range(len(cost)):
        dominated = any(
            cost[j] <= cost[i] and err[j] <= err[i] and (cost[j] < cost[i] or err[j] < err[i])
            for j in range(len(cost))
            if j != i
        )
        if not dominated:
            out.append(i)
    return sorted(out)


def test_pareto_front_matches_brute_force():
    rng = np.random.default_rng(11)
    for _ in range(20):
        cost, err = rng.random(15), rng.random(15)
        assert sorted(pareto_front(cost, err).tolist()) == naive_front(cost, err)


def test_cost_per_digit_of_a_power_law():
    # err = cost^-1/2: one more digit (err / 10) costs 10^2 = 100 times more
    cost = np.array([1.0, 8.0, 64.0, 512.0])
    assert cost_per_digit(cost, cost**-0.5) == pytest.approx(100.0, rel=1e-12)
    assert np.isnan(cost_per_digit([1.0], [0.1]))


def _empty_sweep():
    ds = xr.Dataset(coords={"quantity": np.array([], dtype=object), "a_um": [1.0], "sample_um": [np.inf]})
    ds["value"] = (("quantity", "a_um", "sample_um"), np.zeros((0, 1, 1)))
    return ds


def test_formula_two_point_limit_on_table_6_4_inputs():
    """Unit test of the formula 2κ_hr − κ_lr (linear in 1/L_S, L_S = 300, 600) on the thesis's l.r./h.r. inputs:
    on integers it gives the printed κ_extrap exactly."""
    (t64,) = thesis_tables(_empty_sweep(), [ThesisTable.t6_4], None)
    assert all(row[-2] == 0 for row in t64.rows)


def test_formula_porosity_regression_on_table_7_2_inputs():
    """Unit test of the two-point lines and the φ*-on-φ** regression on the thesis's bounds (7 digits): the
    printed lines and limit follow within 5e-7 (the rounding of 7-digit inputs and a 6-digit limit)."""
    (t72,) = thesis_tables(_empty_sweep(), [ThesisTable.t7_2], None)
    assert np.abs(np.array([row[-2] for row in t72.rows])).max() < 5e-7


def test_tables_without_pipeline_results_show_no_numbers(tmp_path):
    """No scene results and no calibration record: Tables 5.1, 5.2, 7.3, 6.2 and 6.3 say so and leave the
    porepipe column empty (no number compared with the thesis's own)."""
    which = [ThesisTable.t5_1, ThesisTable.t5_2, ThesisTable.t7_3, ThesisTable.t6_2, ThesisTable.t6_3]
    tables = thesis_tables(_empty_sweep(), which, "PP", calibration=tmp_path / "missing.json")
    assert all("no matching results" in t.note for t in tables[:3])
    for t in tables[3:]:
        assert "no pipeline run" in t.note
        ours = t.columns.index("porepipe" if "porepipe" in t.columns else "porepipe kappa")
        assert all(row[ours] == "" and row[-1] == "not run" for row in t.rows)


def test_calibration_tables_take_porepipe_numbers_from_the_record(tmp_path):
    """Tables 6.2/6.3 copy a calibration record's values row by row, name its run and cost, and leave rows the
    record lacks empty; an unreadable record is one clear error."""
    record = {
        "source": "benchmarks/lbm_calibration.py --max-b 8",
        "machine": "test",
        "table_6_2": [
            {"B": 8, "setup": "thesis", "eps_v": 0.0218, "e_v_1e-7": 0.139, "steps": 3000, "wall_s": 1.5},
        ],
        "table_6_3": [{"method": "ends", "kappa": 1.70, "eps_kappa": -0.0128}],
        "table_6_3_cost": {"box": "40x40x80", "steps": 12000, "wall_s": 60.0},
    }
    path = tmp_path / "lbm_calibration.json"
    path.write_text(json.dumps(record))
    t62, t63 = thesis_tables(_empty_sweep(), [ThesisTable.t6_2, ThesisTable.t6_3], None, calibration=path)
    filled = [r for r in t62.rows if r[3] != ""]
    assert [(r[0], r[1], r[3]) for r in filled] == [(8, "<|eps_v|>", 0.0218), (8, "<|e_v|> [1e-7]", 0.139)]
    assert filled[0][4] == pytest.approx(0.0218 - 0.021840) and "3000 steps" in filled[0][-1]
    assert "--max-b 8" in t62.note
    (ends,) = [r for r in t63.rows if r[3] != ""]
    assert ends[0] == "method 3" and ends[3] == 1.70 and ends[4] == pytest.approx(-1.28)
    assert "40x40x80 box, 12000 steps" in ends[-1]
    path.write_text("{not json")
    with pytest.raises(PorepipeError, match="lbm_calibration.json is unreadable"):
        thesis_tables(_empty_sweep(), [ThesisTable.t6_2], None, calibration=path)


def _synthetic_sweep(tmp_path):
    paths = []
    for a in (4.0, 2.0, 1.0, 0.5):
        ds = xr.Dataset(
            {"q": ((), 1.0 + 0.1 * a**1.5 + 1e-4 * (-1) ** int(np.log2(a) + 4)), "r": ((), 2.0 - a)}
        )
        with ResultWriter(tmp_path / "eng" / f"eng_a{a:g}.h5", stage="eng", scene="t", threads=2) as w:
            w.write_table(ds)
        paths.append(tmp_path / "eng" / f"eng_a{a:g}.h5")
    grey, binary = [], []
    for a in (4.0, 2.0):
        n = int(16 / a)
        for name, files, kind in (("grey", grey, "voxelize"), ("pore", binary, "segment")):
            path = tmp_path / f"{'grey' if name == 'grey' else 'binary'}_a{a:g}.h5"
            with ResultWriter(path, stage=kind) as w:
                levels = 3 if name == "grey" else 2  # a binary volume holds 0 and 1 only
                w.write_volume(name, (np.arange(n**3).reshape(n, n, n) % levels).astype(np.uint8), voxel_um=a)
            files.append(path)
    sweep = build_sweep(paths, grey + binary)
    with ResultWriter(tmp_path / "sweep.h5", stage="sweep", scene="t") as w:
        w.write_table(sweep)
    return tmp_path / "sweep.h5", sweep, grey, binary


def test_report_page_is_self_contained(tmp_path):
    sweep_path, sweep, grey, binary = _synthetic_sweep(tmp_path)
    rows = error_cost_table(sweep, ["eng.q", "eng.r"])
    assert {r["quantity"] for r in rows} == {"eng.q", "eng.r"} and all(r["rel_err"] > 0 for r in rows)
    out = build_report(
        sweep_path,
        tmp_path / "rep" / "index.html",
        grey=grey,
        binary=binary,
        settings=Settings(thesis_tables=[ThesisTable.t6_4]),
    )
    page = out.read_text()
    links = re.findall(r"(?:src|href)='([^']+)'", page)
    assert {"quantities.png", "error_cost.png", "sections.png", "limits.csv"} <= set(links)
    # Table 6.4 re-derives the thesis's own numbers, which this scene did not produce: named, not shown
    assert "table_6_4.csv" not in links and "Thesis tables 6.4: not shown" in page
    assert all((out.parent / link).is_file() for link in links)  # every link is a local file: renders offline
    assert "http" not in page.lower() and "<script" not in page.lower()
    assert "porepipe version" in page and re.search(r"threads of the runs</td><td[^>]*>2</td>", page)
    assert page.count("<table>") >= 2  # machine, limits (no benchmark records here: no start-up table)


def test_report_needs_a_sweep(tmp_path):
    path = tmp_path / "x.h5"
    with ResultWriter(path, stage="x") as w:
        w.write_table(xr.Dataset({"v": ((), 1.0)}))
    with pytest.raises(PorepipeError, match="not a sweep result"):
        build_report(path, tmp_path / "r" / "index.html")
