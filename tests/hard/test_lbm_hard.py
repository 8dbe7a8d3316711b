"""LBM hard cases: one-voxel throats, blocked and all-pore samples, float32 over 10⁶ steps, τ near ½, bad input."""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.lbm import Settings, StabilityError, Walls, permeability
from porepipe.lbm import _calibration as cal
from porepipe.lbm._walls import Q_MIN, coefficients


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
    # no wall: no throat either (a 1-voxel sample warned of a ~1-voxel throat beside κ = ∞ before)
    for sample in (pore, np.ones((1, 1, 1), dtype=bool)):
        res = permeability(sample, "x", Settings(), progress=False)
        assert res.throat_voxels == np.inf and res.warning == ""
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


def test_multireflection_walls_refuse_mrt_low_tau_and_mpi():
    """walls=mr1 needs a two-rate operator (trt/bgk), τ ≥ 0.55 (it diverged below) and one process (it reads two
    nodes behind the wall, the MPI slabs exchange one layer): each refused in one line naming the key."""
    with pytest.raises(ValueError, match="walls=mr1 needs collision"):
        Settings(walls="mr1", collision="mrt")
    with pytest.raises(ValueError, match="walls=mr1 needs tau"):
        Settings(walls="mr1", tau=0.52)
    Settings(walls="mr1", collision="bgk", tau=0.55)

    class _Distributed:
        distributed = True

    with pytest.raises(PorepipeError, match="walls = mr1 is not available under MPI"):
        permeability(np.ones((4, 4, 4)), "x", Settings(walls="mr1"), progress=False, comm=_Distributed())


def test_bad_volumes_are_refused():
    with pytest.raises(PorepipeError, match="binary"):
        permeability(np.full((4, 4, 4), 3), "x", progress=False)
    with pytest.raises(PorepipeError, match="3-D"):
        permeability(np.ones((4, 4)), "x", progress=False)
    with pytest.raises(PorepipeError, match="voxel_um"):
        permeability(np.ones((4, 4, 4)), "x", voxel_um=-1.0, progress=False)
    with pytest.raises(ValueError):
        permeability(np.ones((4, 4, 4)), "w", progress=False)


class _ConstantQ:
    """Wall geometry with the same q on every link: exact for walls normal to an axis at distance q."""

    def __init__(self, q):
        self.q = q

    def permuted(self, order):
        return self

    def fractions(self, nodes, pops):
        return np.full(len(pops), self.q)


class _RandomQ(_ConstantQ):
    def fractions(self, nodes, pops):
        return np.random.default_rng(self.q).uniform(1e-6, 1.0, len(pops))


def _slit_error(h, q, walls="cli", tau=0.857):
    """κ̂ of a slit of h nodes between walls q off the outer nodes against the nodal sum of the exact parabola."""
    pore = np.ones((2, 2, h + 1), dtype=bool)
    pore[:, :, 0] = False
    res = permeability(pore, "x", Settings(walls=walls, tau=tau), progress=False, geometry=_ConstantQ(q))
    width = h - 1 + 2 * q
    z = q + np.arange(h)
    assert res.converged and res.walls == walls
    return res.kappa_lu / (np.sum(z * (width - z) / 2) / (h + 1)) - 1


@pytest.mark.parametrize("q", [Q_MIN, 1.0])
def test_interpolated_walls_at_q_near_0_and_1_converge_at_second_order(q):
    """Slit, walls at the smallest q kept (Q_MIN = 0.1 off the outer nodes) and q = 1 (at the next nodes): converged,
    τ-independent to 1e-5, error ≤ 6 % at h = 8 (measured at q → 0 and 1: +3.6 %, −5.0 %; halfway: +54 %, −28 %)
    and ≥ 3× smaller at h = 16. A wall closer than Q_MIN is treated as at Q_MIN."""
    np.testing.assert_array_equal(
        coefficients(np.array([1e-6]), np.array([True]), Walls.cli),
        coefficients(np.array([Q_MIN]), np.array([True]), Walls.cli),
    )
    e8 = _slit_error(8, q)
    assert abs(e8) < 0.06
    assert abs(_slit_error(8, q, tau=0.6) - e8) < 1e-5 and abs(_slit_error(8, q, tau=1.8) - e8) < 1e-5
    assert abs(_slit_error(16, q)) * 3 < abs(e8)
    assert abs(_slit_error(8, q, walls="halfway")) > 4 * abs(e8)


@pytest.mark.parametrize("q", [Q_MIN, 0.3, 1.0])
def test_multireflection_walls_are_exact_for_the_slit_parabola(q):
    """MR1 (Ginzburg et al. 2008) is exact for Poiseuille flow at any q and τ: κ̂ equals the nodal sum of the exact
    parabola to the run's stop tolerance 1e-5 (measured ≤ 9e-7 at τ = 0.6, ≤ 3e-9 at 1.8), where CLI is off by
    +3.1, +1.7 and −5.0 % at q = 0.1, 0.3, 1 (h = 8)."""
    for tau in (0.6, 1.8):
        assert abs(_slit_error(8, q, walls="mr1", tau=tau)) < 1e-5
    assert abs(_slit_error(8, q, walls="cli")) > 0.01


@pytest.mark.parametrize("geometry", ["throat", "plate"])
def test_interpolated_walls_do_not_diverge_where_halfway_converges(geometry):
    """One-voxel throat between two channels, and a one-voxel-thick plate with a 2 × 2 hole; random q ∈ (0, 1]
    on every link (the worst mix of q → 0 and q → 1), τ = 0.51 (MR1: 0.55, its floor) … 2: CLI, MR1 and BFL converge
    like halfway; CLI's
    and MR1's κ̂ within a factor 2 of halfway's (measured 0.91-1.0); BFL's is τ-dependent (up to 3× at τ = 2), so
    only finite and positive."""
    pore = np.zeros((12, 6, 6), dtype=bool)
    pore[:, 1:5, 1:5] = True
    pore[6, 1:5, 1:5] = False
    if geometry == "throat":
        pore[6, 2, 2] = True
    else:
        pore[:, :, :] = True
        pore[6] = False
        pore[6, 2:4, 2:4] = True
    half = permeability(pore, "x", Settings(walls="halfway", tau=0.6), progress=False).kappa_lu
    for walls in ("cli", "mr1", "bfl"):
        for tau in (0.55 if walls == "mr1" else 0.51, 0.6, 2.0):
            res = permeability(
                pore, "x", Settings(walls=walls, tau=tau), progress=False, geometry=_RandomQ(3)
            )
            assert res.converged and np.isfinite(res.kappa_lu) and res.kappa_lu > 0
            assert walls == "bfl" or 0.5 < res.kappa_lu / half < 2.0


def test_narrow_throats_warn_with_the_expected_error():
    """A 3 × 3 duct: the narrowest throat is 3 voxels (< 4), the result carries a warning naming the RMS halfway
    error of circular ducts that wide (27 %, benchmarks/lbm_calibration.py --throats); a 6-wide duct does not."""
    pore = np.zeros((4, 5, 5), dtype=bool)
    pore[:, 1:4, 1:4] = True
    res = permeability(pore, "x", progress=False)
    assert res.throat_voxels == pytest.approx(3.0) and "±27 %" in res.warning
    wide = np.zeros((4, 8, 8), dtype=bool)
    wide[:, 1:7, 1:7] = True
    assert permeability(wide, "x", progress=False).warning == ""


def _grey_and_binary(tmp_path, shift: int):
    """A 6³ grey volume (g = 0 pore, 216 matrix: a 3 × 3 duct along x) and the binary volume of it rolled by ``shift``
    along y: ``shift = 0`` is its own segmentation, another shift a grey volume of some other sample."""
    from porepipe._shared.store import ResultWriter

    grey = np.full((6, 6, 6), 216, dtype=np.uint8)
    grey[:, 1:4, 1:4] = 0
    geometry = {"voxel_um": 1.0, "periodic": (True, True, True)}
    with ResultWriter(tmp_path / "grey_a1.h5", stage="voxelize", scene="t") as w:
        w.write_volume("grey", grey, **geometry)
    with ResultWriter(tmp_path / "binary_a1.h5", stage="segment", scene="t") as w:
        pore = np.roll(grey <= 108, shift, axis=1).astype(np.uint8)
        w.write_volume("pore", pore, attrs={"threshold": 108}, **geometry)
    return tmp_path / "grey_a1.h5", tmp_path / "binary_a1.h5"


def test_a_grey_volume_that_is_not_the_binarys_is_refused_in_one_line(tmp_path, capsys):
    """``--grey`` of another sample of the same shape gave a κ with walls from the wrong grey values (most links
    without a level crossing fell back to halfway) silently; now one line naming the file, before any output."""
    from porepipe.cli import main

    grey, binary = _grey_and_binary(tmp_path, shift=2)
    out = tmp_path / "perm.h5"
    argv = ["permeability", str(binary), "--axis", "x", "--walls", "cli", "--grey", str(grey), "-o", str(out)]
    assert main([*argv, "--max-steps", "200", "--accept-unconverged"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(grey) in err[0] and "differs from it in 72 of 216 voxels" in err[0]
    assert not out.exists()
    grey, binary = _grey_and_binary(tmp_path, shift=0)  # its own grey volume is accepted
    assert main([*argv, "--max-steps", "200", "--accept-unconverged"]) == 0 and out.exists()
