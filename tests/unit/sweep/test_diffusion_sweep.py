"""D_eff(a) in the sweep and the report: diffusion result files with known values and error bars.

Truths: (1) a synthetic D_eff(a) = D0 + c·a with Gaussian noise of known σ_i; the a → 0 limit of the weighted fit must
equal the closed-form weighted least-squares intercept and its 95 % half-width 1.96·sqrt((XᵀWX)⁻¹₀₀) (computed here
independently with numpy), and cover D0; (2) a history whose error is exactly k/√flights: the cost per digit follows
in closed form.
"""

import numpy as np
import pytest
import xarray as xr

from porepipe._shared.store import ResultWriter
from porepipe.report._diffusion import cpu_per_flight, digit_cost, section
from porepipe.sweep import FULL, build_sweep

A_UM = np.array([2.0, 1.5, 1.0, 0.75, 0.5])
D0, SLOPE = 3.0e-4, 2.0e-5  # m²/s, m²/s per µm
SIGMA = np.array([4.0, 3.0, 2.5, 2.0, 1.5]) * 1e-6
K_HIST = 0.8  # rel. error x sqrt(flights) of the synthetic histories


def _write(folder, a, d, err, history_flights):
    rel = K_HIST / np.sqrt(history_flights)
    ds = xr.Dataset(
        {
            "W": ((), 0.5),
            "W_err": ((), 0.01),
            "D_eff_m2_s": ((), d),
            "D_eff_err_m2_s": ((), err),
            "tortuosity": ((), 2.0 + a),
            "tortuosity_err": ((), 0.02),
            "history_flights": (("round",), history_flights),
            "history_particles": (("round",), history_flights / 10),
            "history_D_eff": (("round",), np.full(history_flights.size, 1.0)),
            "history_D_eff_err": (("round",), rel),
            "history_round_cpu_s": (("round",), np.r_[30.0, np.diff(history_flights) * 2e-6]),
        }
    )
    path = folder / f"diffusion_a{a:g}_z.h5"
    with ResultWriter(path, stage="diffusion", scene="t") as w:
        w.write_table(ds)
    return path


def _files(tmp_path, values):
    folder = tmp_path / "scene" / "diffusion"
    flights = np.array([1e4, 2e4, 4e4, 8e4])
    return [_write(folder, a, d, s, flights) for a, d, s in zip(A_UM, values, SIGMA)]


def _weighted_intercept(x, y, s):
    design = np.column_stack([np.ones_like(x), x])
    w = 1.0 / s**2
    cov = np.linalg.inv(design.T @ (design * w[:, None]))
    beta = cov @ design.T @ (w * y)
    return beta[0], 1.959963984540054 * np.sqrt(cov[0, 0])


def test_diffusion_quantities_carry_their_errors_into_the_weighted_limit(tmp_path):
    rng = np.random.default_rng(14)
    values = D0 + SLOPE * A_UM + SIGMA * rng.standard_normal(A_UM.size)
    ds = build_sweep(_files(tmp_path, values), exponent="linear")
    quantities = set(ds.quantity.values)
    assert {"diffusion_z.W", "diffusion_z.D_eff_m2_s", "diffusion_z.tortuosity"} <= quantities
    assert not any("_err" in q for q in quantities)  # error bars are not quantities of their own
    sel = ds.sel(quantity="diffusion_z.D_eff_m2_s", sample_um=FULL)
    np.testing.assert_allclose(sel.stat_err.sel(a_um=A_UM).values, SIGMA, rtol=1e-12)
    lim = ds.sel(quantity="diffusion_z.D_eff_m2_s", form="power", sample_um=FULL)
    assert lim.status.item() == "ok", lim.why.item()
    q_ref, err_ref = _weighted_intercept(A_UM, values, SIGMA)
    assert float(lim.q_inf) == pytest.approx(q_ref, rel=1e-9)
    assert float(lim.err_fit) == pytest.approx(err_ref, rel=1e-6)
    # the 95 % interval (max of fit and leave-one-out) covers the true D0 for this seed
    assert abs(float(lim.q_inf) - D0) <= float(lim.err)


def test_noise_free_line_extrapolates_exactly(tmp_path):
    values = D0 + SLOPE * A_UM
    ds = build_sweep(_files(tmp_path, values), exponent="linear")
    lim = ds.sel(quantity="diffusion_z.D_eff_m2_s", form="linear", sample_um=FULL)
    assert float(lim.q_inf) == pytest.approx(D0, rel=1e-9)


def test_cost_per_digit_follows_the_inverse_square_root_law():
    flights = np.array([1e4, 3e4, 1e5, 3e5])
    cost = digit_cost(flights, K_HIST / np.sqrt(flights))
    assert cost["slope"] == pytest.approx(0.5, rel=1e-9)
    assert cost["flights_for_1e-3"] == pytest.approx((K_HIST / 1e-3) ** 2, rel=1e-9)
    assert cost["flights_for_1e-4"] == pytest.approx(100 * (K_HIST / 1e-3) ** 2, rel=1e-9)
    # two rounds: no slope is claimed, the 1/sqrt(N) extrapolation still is
    two = digit_cost(flights[:2], K_HIST / np.sqrt(flights[:2]))
    assert np.isnan(two["slope"]) and two["flights_for_1e-3"] == pytest.approx((K_HIST / 1e-3) ** 2)
    # the first round's CPU (compilation) is left out
    assert cpu_per_flight(flights, [99.0, 2e4 * 1e-6, 7e4 * 1e-6, 2e5 * 1e-6]) == pytest.approx(1e-6)


def test_report_section_shows_the_limit_and_the_cost(tmp_path):
    values = D0 + SLOPE * A_UM
    ds = build_sweep(_files(tmp_path, values), exponent="linear")
    sweep_dir = tmp_path / "scene" / "sweep"
    sweep_dir.mkdir()
    out = tmp_path / "scene" / "report"
    out.mkdir()
    page = "".join(section(ds, sweep_dir / "sweep.h5", out, dpi=40))
    assert "Knudsen diffusion" in page
    assert f"{D0:.5g} ± " in page  # the limit row
    assert (out / "diffusion.png").stat().st_size > 0
    rows = (out / "diffusion_cost.csv").read_text().splitlines()
    assert len(rows) == 1 + A_UM.size
    need = float(rows[1].split(",")[2])
    assert need == pytest.approx((K_HIST / 1e-3) ** 2, rel=1e-9)
    cpu = float(rows[1].split(",")[4])
    assert cpu == pytest.approx(2e-6, rel=1e-9)
