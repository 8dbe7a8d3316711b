"""LBM hard cases: one-voxel throats, blocked and all-pore samples, float32 over 10⁶ steps, τ near ½, bad input."""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.lbm import Settings, StabilityError, permeability
from porepipe.lbm import _calibration as cal


def test_one_voxel_wide_straight_throat():
    """A 1 × 1 channel through solid: every link of the fluid column is a wall link except along the flow.

    TRT Λ = 3/16 on this discrete problem: the steady column velocity follows from the lateral bounce-back
    alone; κ̂ must be finite, positive and below the continuum duct value B²/4·(1/3 − …) at B = 1 (0.0351)
    by less than a factor 2 either way (the staircase of a 1-voxel duct cannot be resolved).
    """
    pore = np.zeros((6, 3, 3), dtype=bool)
    pore[:, 1, 1] = True
    res = permeability(pore, "x", Settings(collision="trt", tau=1.0), progress=False)
    kappa_duct = res.kappa_lu * 9  # superficial over 3 × 3 -> per fluid area of 1 voxel
    assert res.converged and np.isfinite(res.kappa_lu) and res.kappa_lu > 0
    assert 0.5 < kappa_duct / cal.square_duct_kappa(1) < 2.0


def test_one_voxel_throat_between_two_pores_lowers_kappa():
    """Two 4 × 4 channel halves joined by a one-voxel hole: κ̂ stays finite and well below the open channel."""
    open_ = np.zeros((12, 6, 6), dtype=bool)
    open_[:, 1:5, 1:5] = True
    throat = open_.copy()
    throat[6, 1:5, 1:5] = False
    throat[6, 2, 2] = True
    s = Settings(collision="mrt")
    k_open = permeability(open_, "x", s, progress=False).kappa_lu
    res = permeability(throat, "x", s, progress=False)
    assert res.converged and 0 < res.kappa_lu < 0.5 * k_open


def test_fully_blocked_sample_returns_zero_at_once():
    pore = np.ones((8, 5, 5), dtype=bool)
    pore[4] = False
    for setup in ("periodic", "chambers"):
        res = permeability(
            pore,
            "z" if False else "x",
            Settings(setup=setup, inlet_layers=3, force_layers=1),
            voxel_um=3.0,
            progress=False,
        )
        assert res.kappa_lu == 0.0 and res.kappa_mD == 0.0 and res.steps == 0
        assert "no pore path" in res.reason and not np.isnan(res.kappa_m2)


def test_all_solid_sample_returns_zero():
    res = permeability(np.zeros((4, 4, 4), dtype=np.uint8), "y", progress=False)
    assert res.kappa_lu == 0.0 and res.n_nodes == 0


def test_all_pore_sample_is_unbounded_with_periodic_sides_and_a_duct_with_walls():
    """No solid and periodic sides: nothing resists the flow; κ = ∞ is returned with the reason, no run.
    With lateral walls the same sample is a square duct: κ̂ is bounded and equals the duct series (2 %)."""
    pore = np.ones((4, 8, 8), dtype=bool)
    free = permeability(pore, "x", Settings(), progress=False)
    assert free.kappa_lu == np.inf and free.steps == 0 and "unbounded" in free.reason
    walled = permeability(pore, "x", Settings(collision="trt", lateral="walls"), progress=False)
    assert walled.kappa_lu == pytest.approx(cal.square_duct_kappa(8), rel=0.02)  # B = 8 bounce-back: +1.4 %


def test_float32_million_steps_without_drift():
    """Slit of 4 nodes (8 lattice nodes in all), TRT: 10⁶ float32 steps stay within 1e-5 of the float64 κ̂.

    Zero-centred float32 storage keeps populations ~1e-5 with ~1e-12 resolution; the tolerance allows for the
    accumulated rounding of 10⁶ collisions (random walk ~1e3 × 1e-8 relative).
    """
    pore = np.zeros((2, 1, 6), dtype=bool)
    pore[:, :, 1:5] = True
    ref = permeability(pore, "x", Settings(collision="trt", tau=1.0), progress=False)
    # one window of 10⁶ steps: checks at steps 1, 2, 4, …, 2¹⁹ and 10⁶, none of which may stop the run
    long = permeability(
        pore,
        "x",
        Settings(
            collision="trt",
            tau=1.0,
            precision="float32",
            max_steps=1_000_000,
            window_steps=1_000_000,
            accept_unconverged=True,
        ),
        progress=False,
    )
    assert long.steps == 1_000_000
    kappas = long.history["kappa"][long.history["step"] >= 100_000]
    assert np.abs(kappas / ref.kappa_lu - 1).max() < 1e-5
    assert abs(long.total_mass / long.n_nodes - 1) < 1e-6  # float32 mass drift over 10⁶ steps


@pytest.mark.parametrize("collision", ["bgk", "trt", "mrt"])
def test_tau_0_51_is_stable_and_trt_stays_tau_independent(collision):
    """τ̂ = 0.51 (ν̂ = 1/300) runs stably on a 4 × 4 duct; TRT gives the same κ̂ as at τ̂ = 1 (1e-4)."""
    case = cal.square_duct(4, thesis_chambers=False)
    run = cal.run_case(case, Settings(collision=collision, tau=0.51, max_steps=400_000))
    assert run.converged and np.isfinite(run.kappa)
    if collision == "trt":
        ref = cal.run_case(case, Settings(collision="trt", tau=1.0))
        assert run.kappa == pytest.approx(ref.kappa, rel=1e-4)


def test_tau_too_close_to_half_is_refused_naming_tau():
    with pytest.raises(StabilityError, match="tau"):
        permeability(np.ones((4, 4, 4)), "x", Settings(tau=0.501), progress=False)


def test_bad_volumes_are_refused():
    with pytest.raises(PorepipeError, match="binary"):
        permeability(np.full((4, 4, 4), 3), "x", progress=False)
    with pytest.raises(PorepipeError, match="3-D"):
        permeability(np.ones((4, 4)), "x", progress=False)
    with pytest.raises(PorepipeError, match="voxel_um"):
        permeability(np.ones((4, 4, 4)), "x", voxel_um=-1.0, progress=False)
    with pytest.raises(ValueError):
        permeability(np.ones((4, 4, 4)), "w", progress=False)
