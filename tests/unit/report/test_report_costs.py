"""The report on a tiny result set with known convergence and cost (see conftest.py): the numbers it prints."""

import csv
import math
import re

import numpy as np
import pint
import pytest

from porepipe import open_result
from porepipe._shared.store import read_table
from porepipe.report import startup_table


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_one_more_digit_costs_ten_to_three_over_p(tiny_report):
    root, _, page = tiny_report
    text = page.read_text()
    # error ∝ a^p, cost ∝ a^-3  =>  cost ∝ error^(-3/p): ×10^(3/p) per digit. The limit is fitted from exact
    # data, so the factor is exact up to the fit's round-off (rel 1e-6 covers it).
    factors = {}
    for m in re.finditer(r"digit of <b>([^<]+)</b> costs <b>×([0-9.e+,]+)</b>", text):
        factors[m[1]] = float(m[2].replace(",", ""))
    assert factors["porosity φ (eng, pore)"] == pytest.approx(1000.0, rel=1e-3)  # printed to 4 digits
    assert factors["specific surface S_V (eng, pore)"] == pytest.approx(10**1.5, rel=1e-3)
    assert len(factors) == 2  # the matrix twins are not headlined


def test_startup_is_separated_from_compute(tiny_report, tiny_laws):
    _, sweep, _ = tiny_report
    rows = startup_table(read_table(sweep))
    assert [r["stage"] for r in rows] == ["eng"] and rows[0]["jobs"] == len(tiny_laws["a_um"])
    assert rows[0]["job_minus_compute_s_per_job"] == pytest.approx(tiny_laws["startup_s"], abs=1e-9)
    compute = sum(tiny_laws["t0_s"] * a**-3 for a in tiny_laws["a_um"])
    assert rows[0]["compute_wall_s"] == pytest.approx(compute, rel=1e-12)


def test_limits_csv_holds_numbers_and_units(tiny_report, tiny_laws):
    root, _, _ = tiny_report
    rows = _rows(root / "report" / "limits.csv")
    by_q = {r["quantity"]: r for r in rows}
    assert "eng.S_V[matrix]" not in by_q and "eng.phi[matrix]" not in by_q  # twins left out
    for name, (q_inf, _, _, units) in tiny_laws["laws"].items():
        row = by_q[f"eng.{name}"]
        assert row["unit"] == units and row["power_status"] == "ok"
        # exact data: the free-p fit recovers q∞ to round-off of the variable-projection search
        assert float(row["power_q_inf"]) == pytest.approx(q_inf, rel=1e-6)
        assert float(row["power_err"]) >= 0 and math.isfinite(float(row["power_p"]))
    assert not any("±" in v for r in rows for v in r.values())  # no number stored as text


def test_page_labels_and_scale_bars(tiny_report):
    root, _, page = tiny_report
    text = page.read_text()
    assert re.search(r"<th[^>]*>unit</th>", text) and "µm⁻¹" in text
    assert "Thesis tables 5.1, 5.2, 7.3: not shown" in text  # the tiny scene reproduces no thesis model
    sections = _rows(root / "report" / "sections.csv")
    assert {float(r["a_um"]) for r in sections} == {4.0, 2.0}


def test_sweep_variables_carry_units_pint_reads(tiny_report):
    _, sweep, _ = tiny_report
    ureg = pint.UnitRegistry()
    ds = open_result(sweep)
    for name, var in ds.variables.items():
        if var.dtype.kind in "OUS":
            continue
        units = var.attrs.get("units") or (None if var.attrs.get("units_from") != "unit" else "per quantity")
        assert units is not None, f"sweep variable {name} has no units"
    for units in ds.unit.values:
        ureg.Unit(str(units))  # raises on a spelling pint does not know
    assert dict(zip(ds.quantity.values, ds.unit.values))["eng.S_V[pore]"] == "µm^-1"  # respelled from 1/um
    unsupported = ds.status.values != "ok"
    assert unsupported.any() and np.isnan(ds.q_inf.values[unsupported]).all()  # failed fits hold NaN
    assert np.isfinite(ds.q_inf.values[~unsupported]).all()
