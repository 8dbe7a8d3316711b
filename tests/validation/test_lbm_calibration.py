"""LBM calibration against analytic duct/slit solutions and the thesis's Table 6.2 (§6.1.5), small sizes.

The full tables (B up to 64, the B = 7 pressure-method box, the τ study) are in benchmarks/lbm_calibration.py.
"""

import numpy as np
import pytest

from porepipe.lbm import Settings
from porepipe.lbm import _calibration as cal
from porepipe.lbm._domain import build_lattice
from porepipe.lbm._solver import _threads_for, make_stepper

#: Table 6.2: ⟨|ε_v|⟩ on the middle cross-section, BGK τ̂ = 0.857, thesis set-up (6.1.26)
TABLE_6_2 = {4: 0.064099, 8: 0.021840, 16: 0.007241}
#: Eq. 6.1.37 values quoted in the spec digest (independent evaluation of the series)
KAPPA_TH = {4: 0.562308, 7: 1.722068, 8: 2.249232, 16: 8.996929}


def test_duct_series_matches_quoted_values():
    for b, value in KAPPA_TH.items():
        assert cal.square_duct_kappa(b) == pytest.approx(value, abs=1e-6)  # 7 digits printed


def test_duct_velocity_series_is_zero_on_the_walls_and_integrates_to_kappa():
    b = 10.0
    x = np.linspace(-b / 2, b / 2, 401)
    # on the walls the M = 200 series converges slowly (terms ~ 1/k³): residual ~1e-5 of the peak 1e1 (6.1.28)
    assert np.abs(cal.square_duct_velocity(b, x, np.full_like(x, b / 2), 1.0)).max() < 1e-5
    assert np.abs(cal.square_duct_velocity(b, np.full_like(x, b / 2), x, 1.0)).max() < 1e-5
    xm = (np.arange(160) + 0.5) / 160 * b - b / 2  # midpoint rule, 160² points: error ~1e-5 relative
    x1, x2 = np.meshgrid(xm, xm, indexing="ij")
    mean = cal.square_duct_velocity(b, x1, x2, 1.0).mean()
    assert mean == pytest.approx(cal.square_duct_kappa(b), rel=1e-4)


#: Table 6.2: ⟨|e_v|⟩ as printed, "[×10⁻⁶]" (lattice units)
TABLE_6_2_EV = {4: 0.300, 8: 0.114, 16: 0.068}


@pytest.mark.parametrize("b", [4, 8, 16])
def test_table_6_2_velocity_error_bgk(b):
    """Thesis set-up with chambers (L3 = 4B, force in 2 layers): ⟨|ε_v|⟩ reproduces Table 6.2 (rtol 1e-3: the
    thesis prints 5 significant digits and stops at its own convergence criterion).

    ⟨|e_v|⟩ (lattice units, b̂ = 1e-6): the printed column is 10 × ours at B = 4 and 16, i.e. its unit is 1e-7,
    not the printed 1e-6 — the same decade slip as the table's B column (printed 40 … 640 for B = 4 … 64). The
    tolerance is one unit of the last printed digit (0.001 of the printed number: 0.3 % at B = 4, 1.5 % at
    B = 16) because we stop at δv < 1e-6 where the thesis ran to a fixed t_end. No reading reproduces B = 8:
    there the thesis prints 0.114 where 10 × ours is 0.139 (ratio 0.820, measured; a duct of L3 = 39 instead
    of 4B = 32 layers, i.e. a drive 32/39 as large, gives 0.1140 with ε_v unchanged, but no stated set-up has it);
    the test pins that ratio
    (± 0.005, three printed digits) so that a change of the solver or of the definition shows up.
    """
    case = cal.square_duct(b, thesis_chambers=True)
    settings = Settings(
        collision="bgk", tau=0.857, window_steps=1000, tolerance_velocity=1e-6, tolerance_kappa=1e-6
    )
    run = cal.run_case(case, settings)
    assert run.converged
    eps_v, e_v = cal.mid_section_velocity_error(case, run, settings, b)
    assert eps_v == pytest.approx(TABLE_6_2[b], rel=1e-3)
    printed = e_v / 1e-7  # the thesis column's actual unit
    if b == 8:
        assert TABLE_6_2_EV[b] / printed == pytest.approx(0.820, abs=5e-3)
    else:
        assert printed == pytest.approx(TABLE_6_2_EV[b], abs=1e-3)


@pytest.mark.parametrize("b", [4, 8])
def test_table_6_1_changes_are_at_most_the_thesis_s(b):
    """Eq. 6.1.30 at the thesis's dt and t_end (Table 6.1), BGK τ̂ = 0.857, uniform start n_i = 1/19.

    The thesis's δρ grows in proportion to dt (1.74e-8 per step at every B: a density drift); our halfway
    bounce-back and collision conserve mass exactly, so the flow is at round-off by t_end (≈ 150 viscous times
    B²/ν̂ at B = 4): both changes must lie below the thesis's and at float64 round-off (1e-12: ~1e4 ulps).
    """
    dt, t_end, dv_thesis, drho_thesis = cal.TABLE_6_1[b]
    case = cal.square_duct(b, thesis_chambers=True)
    dv, drho = cal.convergence_changes(case, Settings(collision="bgk", tau=0.857), t_end, dt)
    assert dv < min(dv_thesis * 1e-8, 1e-12)
    assert drho < min(drho_thesis * 1e-4, 1e-12)


@pytest.mark.parametrize("collision", ["bgk", "mrt", "trt"])
def test_square_duct_b16_kappa_error_below_one_percent(collision):
    """Fig. 6.7 target: |ε_κ| < 1 % at B = 16 for BGK (τ̂ = 0.857, the calibrated value), MRT and TRT."""
    case = cal.square_duct(16, thesis_chambers=False)
    run = cal.run_case(case, Settings(collision=collision, tau=0.857))
    assert abs(cal.duct_kappa(case, run) / cal.square_duct_kappa(16) - 1) < 0.01


def _tau_series(collision, taus=(0.6, 1.0, 2.0), **extra):
    case = cal.square_duct(16, thesis_chambers=False)
    return np.array(
        [
            cal.duct_kappa(case, cal.run_case(case, Settings(collision=collision, tau=t, **extra)))
            for t in taus
        ]
    )


def test_trt_and_mrt_are_tau_independent_bgk_drifts():
    """Square duct B = 16, τ̂ ∈ {0.6, 1, 2}: TRT (Λ = 3/16) and MRT vary < 1 %, BGK by several per cent.

    TRT's wall position does not depend on τ at fixed Λ, so its spread is round-off/convergence only (1e-5).
    """
    trt, mrt, bgk = _tau_series("trt"), _tau_series("mrt"), _tau_series("bgk")
    spread = {k: (v.max() - v.min()) / v.mean() for k, v in (("trt", trt), ("mrt", mrt), ("bgk", bgk))}
    assert spread["trt"] < 1e-4
    assert spread["mrt"] < 0.01
    assert spread["bgk"] > 0.05
    assert bgk[-1] > bgk[0], "BGK overestimates more at large τ (thesis Fig. 6.6)"


@pytest.mark.parametrize("shape, tol", [("circle", 0.02), ("triangle", 0.03)])
def test_round_and_triangular_ducts(shape, tol):
    """κ̂ = B²/32 and B²/80 at B = 16 (relative to the voxelised duct area); staircase walls limit the
    agreement to a few per cent (thesis: "clearly larger errors than the square duct")."""
    b = 16
    cross = cal.circle_cross(b) if shape == "circle" else cal.triangle_cross(b)
    ref = cal.circle_duct_kappa(b) if shape == "circle" else cal.triangle_duct_kappa(b)
    case = cal.duct(cross)
    run = cal.run_case(case, Settings(collision="trt", tau=1.0))
    assert abs(cal.duct_kappa(case, run) / ref - 1) < tol


def test_slit_trt_magic_is_exact_and_second_order():
    """Plane Poiseuille flow, TRT Λ = 3/16: the node values are the exact parabola with walls halfway, so the
    node-averaged κ̂ is (h² + ½)/12 to round-off, i.e. h²/12 with the midpoint-rule error 1/(24) · 1/h² · h²…
    relative error 1/(2h²): second order in resolution."""
    errors = []
    for h in (4, 8, 16):
        case = cal.slit(h)
        run = cal.run_case(
            case, Settings(collision="trt", tau=0.8, tolerance_kappa=1e-9, tolerance_velocity=1e-8)
        )
        kappa = cal.duct_kappa(case, run)
        assert kappa == pytest.approx((h * h + 0.5) / 12, rel=1e-7)
        errors.append(kappa / cal.slit_kappa(h) - 1)
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    np.testing.assert_allclose(orders, 2.0, atol=0.01)


def test_pressure_methods_small_box():
    """Table 6.3 in a reduced box (20² × 40, L_S = 20, BGK τ̂ = 0.857): the fitted gradient (method 1) is
    within 1 %, the trimmed fit (method 2) agrees with the thesis's 1.73689 to 0.1 %, and the slices just
    outside the sample (method 4) are the worst (thesis: 4.6 %, rejected)."""
    case = cal.pressure_method_case(width=20, inlet=10, sample=20, outlet=10, force=(3, 8))
    run = cal.run_case(case, Settings(collision="bgk", tau=0.857, trim_layers=3, window_steps=1000))
    ref = cal.square_duct_kappa(7)
    err = {k.split("/")[0]: v / ref - 1 for k, v in run.estimates.items() if k.endswith("/mean")}
    assert abs(err["fit"]) < 0.01
    assert run.estimates["fit_trimmed/mean"] == pytest.approx(1.73689, rel=1e-3)
    assert abs(err["outside"]) == max(abs(e) for e in err.values())


def test_mass_is_conserved_to_round_off_in_the_periodic_set_up():
    """Random porous box, body force, 2000 MRT steps: Σ f changes by < 1e-12 relative (bounce-back and
    collision conserve mass exactly; only float64 summation round-off remains)."""
    pore = np.random.default_rng(7).random((12, 10, 10)) < 0.6
    lat = build_lattice(pore, (True, True, True), (0, 12), (0, 12))
    src = np.zeros(19 * lat.n_nodes)
    dst = np.zeros_like(src)
    step = make_stepper(Settings(collision="mrt", body_force=1e-5), lat)
    with _threads_for(lat.n_nodes):  # small lattice: serial, as the solver runs it
        step(src, dst, np.zeros((4, lat.n_nodes)), False, 2000)
    assert abs(np.sum(src)) < 1e-12 * lat.n_nodes  # zero-centred: Σ f̃ = total mass − N


def test_zero_body_force_gives_zero_flow():
    """No force: the rest state stays exactly at rest; a density disturbance decays with no net flow."""
    pore = np.random.default_rng(8).random((10, 8, 8)) < 0.6
    lat = build_lattice(pore, (True, True, True), (0, 0), (0, 10))  # empty force zone
    src = np.zeros(19 * lat.n_nodes)
    dst = np.zeros_like(src)
    fields = np.zeros((4, lat.n_nodes))
    step = make_stepper(Settings(collision="trt"), lat)
    with _threads_for(lat.n_nodes):
        step(src, dst, fields, True, 100)
        assert np.count_nonzero(src) == 0 and np.count_nonzero(fields) == 0
        src[: lat.n_nodes] = 1e-3 * np.random.default_rng(9).standard_normal(
            lat.n_nodes
        )  # rest population kick
        step(src, dst, fields, True, 3000)
    assert np.abs(fields[1:]).max() < 1e-9  # acoustic/viscous decay from 1e-3 over 3000 steps


def test_chamber_and_periodic_set_ups_agree_on_a_straight_duct():
    """8 × 8 duct in a 10 × 10 sample, 24 long: the thesis's chamber set-up with the trimmed pressure fit
    (method 2) gives the periodic body-force κ̂ within 1e-3; the end-slice method 3 lies within 3 % (entry and
    exit pressure jumps over a short sample, thesis §6.1.5). Mirroring a uniform duct changes nothing."""
    from porepipe.lbm import permeability

    pore = np.zeros((24, 10, 10), dtype=bool)
    pore[:, 1:9, 1:9] = True
    periodic = permeability(pore, "x", Settings(collision="trt"), progress=False).kappa_lu
    chamber = permeability(
        pore,
        "x",
        Settings(
            collision="trt", setup="chambers", inlet_layers=6, outlet_layers=6, force_layers=3, trim_layers=4
        ),
        progress=False,
    )
    assert chamber.estimates["fit_trimmed/mean"] == pytest.approx(periodic, rel=1e-3)
    assert chamber.kappa_lu == pytest.approx(periodic, rel=0.03)
    mirrored = permeability(pore, "x", Settings(collision="trt", mirror=True), progress=False).kappa_lu
    assert mirrored == pytest.approx(periodic, rel=1e-9)
