"""Hard cases of the Knudsen engine: degenerate geometry, bad input, no NaN."""

import math
from pathlib import Path

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.diffusion import Settings, equilibrium, prepare, square_capillary, transport
from porepipe.diffusion._cli import _USED_BY
from porepipe.diffusion._settings import USED_BY
from porepipe.scene import SceneError, parse_scene

S = Settings(batches=16, batch_particles=500, max_rounds=1)


def _finite(values):
    return all(math.isfinite(v) for v in values.values() if isinstance(v, float))


@pytest.mark.slow
def test_one_voxel_channel_equals_the_scaled_square_channel():
    """A 1 x 1 x 10 channel is the a = 30, L = 300 square channel scaled by 1/30: W = 0.119 (digest table)."""
    r = transport(np.ones((1, 1, 10), np.uint8), 2, S, seed=1)
    assert abs(r.values["W"] - 0.119) <= 3 * math.hypot(r.values["W_err"], 0.0005)
    assert r.values["mean_free_flight"] > 0 and _finite(r.values)


def test_partly_blocked_inlet_starts_only_in_open_pixels():
    """Only one inlet pixel is open and it leads straight to the outlet through a 1-voxel duct: no particle may
    start in the solid, so every flight history stays in that duct (four walls + two ends)."""
    pore = np.zeros((5, 5, 12), np.uint8)
    pore[2, 2, :] = 1
    r = transport(pore, 2, S, seed=2)
    geom = prepare(pore, axis=2)
    assert np.all(geom.codes[tuple(geom.cells(0).T)] > 0)
    assert abs(r.values["W"] - transport(np.ones((1, 1, 12), np.uint8), 2, S, seed=2).values["W"]) < 1e-12


def test_closed_pores_are_dropped_and_reported():
    pore = square_capillary(6, 20).pore.copy()
    pore[:, :, 10] = 0
    pore[2:4, 2:4, 10] = 1  # a throat keeps the path
    pore[0, 0, 3] = 0
    with_bubble = np.pad(pore, ((0, 3), (0, 0), (0, 0)))
    with_bubble[7, 2, 5] = 1  # an isolated bubble beside the channel
    r = transport(with_bubble, 2, S, seed=3)
    assert r.values["accessible_porosity"] < r.values["total_porosity"]
    assert _finite(r.values)


@pytest.mark.parametrize(
    "pore,match",
    [
        (np.zeros((4, 4, 4), np.uint8), "all solid"),
        (
            np.concatenate([np.ones((3, 3, 2)), np.zeros((3, 3, 1)), np.ones((3, 3, 2))], axis=2).astype(
                np.uint8
            ),
            "no face-connected pore path joins the inlet face z = 0 to the outlet face z = 4",
        ),
    ],
)
def test_clear_errors(pore, match):
    with pytest.raises(PorepipeError, match=match):
        transport(pore, 2, S)


def test_all_solid_equilibrium_and_bad_voxel_size():
    with pytest.raises(PorepipeError, match="all solid"):
        equilibrium(np.zeros((3, 3, 3), np.uint8), S)
    with pytest.raises(PorepipeError, match="voxel_um"):
        prepare(np.ones((3, 3, 3), np.uint8), voxel_um=(1.0, 0.0, 1.0))
    with pytest.raises(PorepipeError, match="3-D"):
        prepare(np.ones((3, 3), np.uint8))


def test_grazing_cube_lattice_msd_has_no_nan():
    """Periodic medium of cubes touching at edges (a checkerboard of solid cubes): flights graze edges and
    corners all the time; the result is finite and the particles stay in the pore space."""
    idx = np.indices((8, 8, 8)).sum(axis=0)
    pore = ((idx // 2) % 2 == 0).astype(np.uint8)  # 2-voxel checkerboard blocks meet along edges
    pore[:, :, :] |= (np.indices((8, 8, 8))[2] // 2 % 2 == 0).astype(np.uint8)
    r = equilibrium(
        pore, Settings(batches=8, batch_particles=100, max_rounds=1), periodic=(1, 1, 1), seed=4, t_end=200.0
    )
    assert _finite(r.values) and r.values["wall_hits"] > 0


def test_scene_section_rejects_misspelt_keys_and_bad_values():
    base = {
        "name": "t",
        "domain": {"size_um": [10, 10, 10]},
        "spheres": {"inline": [[5, 5, 5, 2]]},
        "resolutions_um": [1.0],
        "analyses": ["segment", "diffusion"],
    }
    scene = parse_scene({**base, "diffusion": {"wall_law": "isotropic"}})
    assert scene.diffusion.wall_law.value == "isotropic"
    with pytest.raises(SceneError) as err:
        parse_scene({**base, "diffusion": {"wal_law": "lambert", "accommodation": 2, "species": "Xe"}})
    text = str(err.value)
    assert (
        "diffusion.wal_law" in text and "diffusion.accommodation" in text and "unknown species 'Xe'" in text
    )


def test_surface_blocks_whose_ends_round_below_them_do_not_hang():
    """t_end = 10, 15 blocks: (2/3·k)/(2/3) rounds below k for some block ends, which made the time tally loop
    for ever on such an end. Every block holds N·(block length) particle-jiffies (gas + adsorbed: the particles
    are conserved); rtol 1e-12 for the round-off of a few dozen summed intervals."""
    from porepipe.diffusion import Adsorbate, surface_run
    from porepipe.diffusion import _surface_kernels as SK

    run = surface_run(
        np.ones((3, 3, 3), np.uint8),
        [Adsorbate("A", gas=5, adsorption=0.5, residence=2.0)],
        t_end=10.0,
        blocks=15,
    )
    per_block = run["blocks_tally"][:, 0, SK.S_GAS_T] + run["blocks_tally"][:, 0, SK.S_ADS_T]
    np.testing.assert_allclose(per_block, 5 * 10.0 / 15, rtol=1e-12)


@pytest.mark.parametrize(
    "pore_periodic,times,match",
    [
        ((np.ones((2, 2, 2), np.uint8), (1, 1, 1)), {"t_end": 5.0}, "no wall face"),
        ((np.ones((2, 2, 2), np.uint8), (0, 0, 0)), {"t_end": math.inf}, "t_end < inf"),
        ((np.ones((2, 2, 2), np.uint8), (0, 0, 0)), {"t_end": 5.0, "blocks": 2.5}, "whole number of blocks"),
    ],
)
def test_surface_run_refuses_what_never_ends(pore_periodic, times, match):
    """A pore without walls (a flight never ends) and an infinite t_end hung the event loop; 2.5 blocks was numpy's
    TypeError."""
    from porepipe.diffusion import Adsorbate, surface_run

    pore, periodic = pore_periodic
    with pytest.raises(PorepipeError, match=match):
        surface_run(pore, [Adsorbate("A", gas=2, adsorption=0.5, residence=1.0)], periodic=periodic, **times)


@pytest.mark.parametrize("t_samples", [[8.0, 2.0], [np.nan], [1.0, 20.0]])
def test_surface_sample_times_must_be_ascending_inside_the_run(t_samples):
    """The event loop takes the sample times in order: [8, 2] recorded the state at 8 twice, NaN and 20 > t_end the
    final state, all silently."""
    from porepipe.diffusion import Adsorbate, surface_run

    with pytest.raises(PorepipeError, match=r"t_samples must be ascending times in \[0, t_end = 10.0\]"):
        surface_run(np.ones((2, 2, 2), np.uint8), [Adsorbate("A", gas=2)], t_end=10.0, t_samples=t_samples)


def test_surface_with_no_active_site_is_refused():
    """active_fraction 1e-9 of 96 sites draws none active: the coverage was 0/0 (NaN and a RuntimeWarning)."""
    from porepipe.diffusion import Adsorbate, surface_run

    with pytest.raises(PorepipeError, match="active_fraction 1e-09 left none of the 96 sites active"):
        surface_run(np.ones((2, 2, 2), np.uint8), [Adsorbate("A", gas=2)], t_end=5.0, active_fraction=1e-9)


@pytest.mark.parametrize("n_part", [1, 3])
def test_edmd_with_fewer_particles_than_msd_groups_is_finite(n_part):
    """Setup edmd with 1 or 3 particles in a periodic box: the msd was averaged over 8 particle groups, most of them
    empty (NaN msd and D_self and a RuntimeWarning). Now a group per particle; one group has an infinite error.
    The msd is non-negative and grows (a free particle's msd is (v t)², so the last sample exceeds the first)."""
    from porepipe.diffusion._edmd import edmd_result

    settings = Settings(
        setup="edmd", gas={"particles": {"N2": n_part}, "voxel_nm": 2.0, "duration_ps": 5.0, "samples": 4}
    )
    r = edmd_result(np.ones((3, 3, 3), np.uint8), settings, 1.0, (1, 1, 1))
    msd = r.arrays["msd_nm2"].sum(axis=1)
    assert np.all(np.isfinite(msd)) and msd[-1] > msd[0] >= 0
    assert math.isfinite(r.values["D_self_nm2_ps"])
    assert (r.values["D_self_err_nm2_ps"] == math.inf) == (n_part == 1)


def test_edmd_whose_first_species_has_no_particles_tests_the_next():
    """particles {N2: 0, Ar: 12}: the speed test and Chapman-Enskog were taken over the absent N2 (mean of an empty
    slice: NaN and a RuntimeWarning). Now over Ar: the speed histogram holds its 12 particles, and D_CE is Ar's
    (the N2 value differs by its diameter and mass, so rel 1e-12 tells them apart)."""
    from porepipe.diffusion._edmd import chapman_enskog_d, edmd_result

    gas = {"particles": {"N2": 0, "Ar": 12}, "voxel_nm": 2.0, "duration_ps": 5.0, "samples": 4}
    r = edmd_result(np.ones((3, 3, 3), np.uint8), Settings(setup="edmd", gas=gas), 1.0, (1, 1, 1))
    assert r.arrays["speed_histogram"].sum() == 12 and 0 <= r.values["ks_pvalue"] <= 1
    n = 12 / 6.0**3
    d_ar = chapman_enskog_d(n, 2 * 0.1771, "Ar", 298.15) * 1e-6
    assert r.values["D_chapman_enskog_m2_s"] == pytest.approx(d_ar, rel=1e-12)


def test_thiele_modulus_negative_or_huge():
    """eta_of_phi(-2) gave 1 - 4/3 = -0.33 (the small-Φ series used for every Φ <= 1e-8), a wrong number; the
    series term Φ² was computed for every Φ and overflowed (a RuntimeWarning) above 1.3e154, e.g. inside
    phi_of_eta(1e-300). There tanh Φ = 1 to double precision, so Φ = 1/η (rel 1e-11: the bisection's 1e-12)."""
    from porepipe.diffusion import eta_of_phi, phi_of_eta

    with pytest.raises(PorepipeError, match=r"Thiele modulus must be >= 0 \(Φ = L·√\(k/D\)\), got -2.0$"):
        eta_of_phi(-2.0)
    assert phi_of_eta(1e-300) == pytest.approx(1e300, rel=1e-11)
    assert float(eta_of_phi(1e200)) == pytest.approx(1e-200, rel=1e-15)


@pytest.mark.parametrize(
    "x,d,d_err",
    [
        ([0.1, 0.2, 0.3], [1.0, np.nan, 2.0], [0.1, 0.1, 0.1]),
        ([0.1, 0.2], [1.0, 2.0], [0.1, np.inf]),
        ([0.1, np.inf, 0.3], [1.0, 1.5, 2.0], [0.1, 0.1, 0.1]),
    ],
)
def test_length_series_fit_refuses_non_finite_points(x, d, d_err):
    """A NaN D or an infinite r/L gave alpha = D0 = NaN silently; an infinite error (weight 0) left two points for
    two parameters with one of them weightless: LinAlgError 'Singular matrix'."""
    from porepipe.diffusion import fit_length_series

    with pytest.raises(PorepipeError, match="the length series needs finite values, D > 0 and errors > 0"):
        fit_length_series(x, d, d_err)


def test_event_driven_gas_refuses_non_finite_start():
    """An infinite temperature gave infinite speeds and a NaN velocity a NaN position after the first step, both
    silently; a NaN count was int()'s ValueError and a (1, 2) position numpy's reshape error."""
    from porepipe.diffusion import make_gas, mean_speed

    box = np.ones((3, 3, 3), np.uint8)
    one = {"positions": [[1.0, 1.0, 1.0]], "species": ["N2"]}
    with pytest.raises(PorepipeError, match="temperature_K must be a positive finite number, got inf"):
        make_gas(box, 2.0, {"N2": 3}, temperature_K=math.inf)
    with pytest.raises(PorepipeError, match="temperature_K must be a positive finite number, got inf"):
        mean_speed("N2", math.inf)
    with pytest.raises(PorepipeError, match="particle velocities must be finite"):
        make_gas(box, 2.0, {"N2": 0}, velocities=[[math.nan, 0.0, 0.0]], **one)
    with pytest.raises(PorepipeError, match="particle count of N2 must be a whole number >= 0, got nan"):
        make_gas(box, 2.0, {"N2": math.nan})
    with pytest.raises(
        PorepipeError, match=r"positions \(1, 2\) and velocities \(1, 2\) must both be \(1, 3\)"
    ):
        make_gas(box, 2.0, {"N2": 0}, positions=[[1.0, 1.0]], velocities=[[0.0, 0.0]], species=["N2"])


def test_edmd_in_a_box_without_walls_has_infinite_chord():
    """A periodic box of pore has no wall: the mean chord 4V/S is infinite and Kn = 0 exactly; the 1e-300 floor on
    S reported 8.6e302 nm and Kn = 2e-302 instead."""
    from porepipe.diffusion._edmd import edmd_result

    gas = {"particles": {"N2": 8}, "voxel_nm": 2.0, "duration_ps": 2.0, "samples": 4}
    r = edmd_result(np.ones((3, 3, 3), np.uint8), Settings(setup="edmd", gas=gas), 1.0, (1, 1, 1))
    assert r.values["mean_chord_nm"] == math.inf and r.values["Kn"] == 0.0  # exact by construction


@pytest.mark.parametrize(
    "kw,match",
    [
        ({"batches": 0}, "batches must be a whole number >= 1, got 0"),
        ({"batches": 2.5}, "batches must be a whole number >= 1, got 2.5"),
        ({"poisoning": math.inf, "rounds": 2}, "poisoning must be finite and >= 0"),
        ({"poisoning": math.nan, "rounds": 2}, "poisoning must be finite and >= 0"),
    ],
)
def test_reactive_pore_refuses_no_batches_and_endless_poisoning(kw, match):
    """batches = 0 divided by zero (particles // batches), 2.5 batches failed in numpy's zeros; an infinite
    poisoning made exp(-inf·0) NaN site factors (a RuntimeWarning), a NaN one was ignored silently."""
    from porepipe.diffusion import reactive_pore

    with pytest.raises(PorepipeError, match=match):
        reactive_pore(np.ones((2, 2, 4), np.uint8), 2, 0.1, particles=32, **kw)


@pytest.mark.parametrize("t_warm,blocks", [(5.0 - 1e-15, 16), (5.0 - 1e-9, 2)])
def test_surface_blocks_below_the_float_resolution_are_refused(t_warm, blocks):
    """A warmup ending 1e-15 before t_end = 5 left a window of one float spacing (8.9e-16) cut into 16 blocks of
    5.6e-17: the run returned one block at coverage 1/3 and fifteen at 0, a coverage of 0.02 +- 0.02, silently.
    Blocks of 5e-10 = 1e-10 t_end (ends resolved to ~2e-6 of their length) are below the bound as well."""
    from porepipe.diffusion import Adsorbate, surface_run

    with pytest.raises(PorepipeError, match=f"into {blocks} blocks gives blocks shorter than 1e-09 t_end"):
        surface_run(
            np.ones((2, 2, 2), np.uint8),
            [Adsorbate("A", gas=5, adsorption=0.5, residence=2.0)],
            t_end=5.0,
            t_warm=t_warm,
            blocks=blocks,
        )


@pytest.mark.parametrize(
    ("a_um", "words"),
    [
        (0.0, "positive, finite voxel size"),
        (-1.0, "positive, finite voxel size"),
        (math.nan, "positive, finite"),
        (1e-6, "more than this machine's"),
    ],
)
def test_capillary_at_a_resolution_it_cannot_have_is_one_line(tmp_path, a_um, words):
    """``porepipe diffusion-capillary --a 0`` raised a ZeroDivisionError, ``--a 1e-6`` numpy's 466 TiB allocation
    error (a cylinder of radius 4 µm); both are refused before anything is built or written."""
    from porepipe.diffusion._capillary import CapillaryGeometry, write_capillary

    with pytest.raises(PorepipeError, match=words):
        write_capillary(
            CapillaryGeometry(kind="cylinder", radius_um=4.0, length_um=8.0), a_um, tmp_path / "b.h5"
        )
    assert list(tmp_path.iterdir()) == []


def test_diffusion_options_that_do_not_validate_are_one_line_in_the_house_format(tmp_path, capsys):
    """The diffusion CLI joined pydantic's text onto one line, with its '[type=…]' tags and 'For further information
    visit https://…' links; it now lays its options over the scene as the other stages do: key = value: reason."""
    from porepipe.cli import main

    code = main(
        [
            "diffusion",
            str(tmp_path / "missing.h5"),
            "-o",
            str(tmp_path / "d.h5"),
            "--accommodation",
            "2",
            "--target-rel-error",
            "-1",
        ]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "--accommodation = 2.0: Input should be less than or equal to 1" in err[0]
    assert "--target-rel-error = -1.0" in err[0] and "errors.pydantic.dev" not in err[0]
    assert not (tmp_path / "d.h5").exists()


@pytest.mark.parametrize(
    "update",
    [{"profile_bins": 10**10}, {"hit_map_bins": 10**6}, {"orientation_bins": 10**8}, {"batches": 10**11}],
)
def test_tallies_beyond_the_machine_are_one_line(update):
    """A hit map of 10⁶ bins a side (43.7 TiB) or 10¹¹ batches raised numpy's allocation error (exit code 1) after
    the geometry was built; now one line naming the settings, before any work."""
    with pytest.raises(PorepipeError, match="more than half this machine's"):
        transport(square_capillary(4, 8), 2, Settings().model_copy(update=update))
    with pytest.raises(PorepipeError, match="more than half this machine's"):
        equilibrium(np.ones((4, 4, 4), np.uint8), Settings().model_copy(update={"batches": 10**11}))


def test_an_empty_gas_on_the_command_line_is_refused(tmp_path, capsys):
    """``--setup edmd --gas-particles ''`` was taken as not given and ran the default gas."""
    from porepipe.cli import main

    code = main(
        [
            "diffusion",
            str(tmp_path / "b.h5"),
            "-o",
            str(tmp_path / "d.h5"),
            "--setup",
            "edmd",
            "--gas-particles",
            "",
        ]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--gas-particles wants SPECIES=N" in err[0]


def test_a_run_that_counted_nothing_has_not_met_its_target(capsys):
    """A Wicke-Kallenbach run of 1e-300 jiffies counts 0 ± 0: its relative error read 0, so it stopped after two
    rounds with 'target met'; it is now unknown (inf), and the run goes on to max_rounds and says it stopped by a
    limit."""
    settings = Settings(
        setup="wicke_kallenbach", wk_time_jiffies=1e-300, max_rounds=4, batches=2, batch_particles=4
    )
    result = transport(square_capillary(4, 8).pore, 2, settings)
    assert result.tallies.rounds == 4
    assert "stopped by a limit before the target" in capsys.readouterr().err


def _exact_line_fit(x, d, d_err):
    """The weighted fit of 1/D = c + s·x in exact rational arithmetic: (α, D₀, χ²/dof) as floats."""
    from fractions import Fraction as F

    xs, ys = [F(v) for v in x], [1 / F(v) for v in d]
    ws = [(F(dv) ** 2 / F(ev)) ** 2 for dv, ev in zip(d, d_err)]  # 1/σ², σ = D_err/D²
    s0, s1 = sum(ws), sum(w * v for w, v in zip(ws, xs))
    s2 = sum(w * v * v for w, v in zip(ws, xs))
    t0, t1 = sum(w * y for w, y in zip(ws, ys)), sum(w * v * y for w, v, y in zip(ws, xs, ys))
    det = s0 * s2 - s1 * s1
    c, s = (s2 * t0 - s1 * t1) / det, (s0 * t1 - s1 * t0) / det
    chi2 = sum(w * (y - c - s * v) ** 2 for w, y, v in zip(ws, ys, xs)) / max(len(xs) - 2, 1)
    return float(s / c), float(1 / c), float(chi2)


@pytest.mark.parametrize("scale", [1.0, 1e-200, 1e-300, 1e200, 1e300])
def test_length_series_fit_is_the_same_for_any_common_error_scale(scale):
    """Errors of 1e-200 overflowed the normal equations (weights 1/σ² = 1e400): α, D₀ and their errors came out
    NaN. The fit is now solved in exactly rescaled units: α and D₀ equal the exact rational fit of the same points
    (rel 1e-12) for any common factor on the errors, and the errors scale with it. χ²/dof scales as 1/factor²:
    beyond the float range it is inf, its value."""
    from porepipe.diffusion import fit_length_series

    x = np.array([0.5, 0.2, 0.1, 0.05, 0.02])
    d = 3.0 / (1.0 + 2.9 * x) * (1.0 + 1e-3 * np.array([1.0, -2.0, 0.5, 1.5, -1.0]))
    err = 1e-3 * d * np.array([1.0, 2.0, 0.5, 3.0, 1.0])
    alpha, d0, chi2 = _exact_line_fit(x, d, err)
    base = fit_length_series(x, d, err)
    fit = fit_length_series(x, d, err * scale)
    assert fit["alpha"] == pytest.approx(alpha, rel=1e-12) and fit["D0"] == pytest.approx(d0, rel=1e-12)
    assert base["chi2_per_dof"] == pytest.approx(chi2, rel=1e-9)
    for key in ("alpha_err", "D0_err"):
        assert fit[key] == pytest.approx(base[key] * scale, rel=1e-12)
    with np.errstate(over="ignore"):
        expected = chi2 / scale / scale
    assert fit["chi2_per_dof"] == (pytest.approx(expected, rel=1e-9) if np.isfinite(expected) else math.inf)


def test_length_series_fit_of_points_on_the_line_with_tiny_errors():
    """Data on the model with errors of 1e-200 (relative to D 1e-200, 1e-10 at D ~ 1e-300, 1e-500 at D ~ 1e300:
    σ of 1/D = 1e-800, below the float range): α and D₀ exact to rel 1e-12, their errors finite."""
    from porepipe.diffusion import fit_length_series

    x = np.array([0.5, 0.2, 0.1, 0.02])
    for d0 in (3.0, 3e-300, 3e300):
        d = d0 / (1.0 + 2.9 * x)
        fit = fit_length_series(x, d, np.full(4, 1e-200) if d0 >= 1 else 1e-10 * d)
        assert fit["alpha"] == pytest.approx(2.9, rel=1e-12) and fit["D0"] == pytest.approx(d0, rel=1e-12)
        assert 0 <= fit["alpha_err"] < 1e-9 and math.isfinite(fit["D0_err"])


def test_length_series_fit_refuses_errors_beyond_the_float_range_of_each_other():
    """A point whose error is 1e320 times another's has no weight; with fewer than two weighted lengths left the
    line is not determined, which is said in one line (it was a singular-matrix traceback or NaN)."""
    from porepipe.diffusion import fit_length_series

    with pytest.raises(PorepipeError, match="fewer than two distinct points keep a weight"):
        fit_length_series([0.5, 0.1], [1.0, 2.0], [1.0, 1e-320])


def test_bosanquet_fit_shares_the_rescaled_line():
    """The Bosanquet line 1/D = a + b·N had the same normal equations (NaN at errors of 1e-200), took a NaN D without
    a word and raised LinAlgError for two equal counts; it is now the length series' exactly rescaled fit."""
    from porepipe.diffusion._edmd import bosanquet_fit

    counts = np.array([200.0, 800.0, 2400.0, 4000.0])
    d = 1.0 / (0.5 + 2e-4 * counts) * (1.0 + 1e-3 * np.array([1.0, -1.0, 2.0, -0.5]))
    err = 1e-3 * d
    base, tiny = bosanquet_fit(counts, d, err), bosanquet_fit(counts, d, err * 1e-200)
    for key in ("intercept", "slope"):
        assert tiny[key] == pytest.approx(base[key], rel=1e-12)
        assert tiny[f"{key}_err"] == pytest.approx(base[f"{key}_err"] * 1e-200, rel=1e-12)
    exact_slope = _exact_line_fit(counts, d, err)
    assert base["slope"] / base["intercept"] == pytest.approx(exact_slope[0], rel=1e-12)
    assert 1 / base["intercept"] == pytest.approx(exact_slope[1], rel=1e-12)
    for bad in ((counts, np.where(counts > 300, d, np.nan), err), ([800.0, 800.0], d[:2], err[:2])):
        with pytest.raises(PorepipeError, match="the Bosanquet fit needs"):
            bosanquet_fit(*bad)


#: a valid command-line value of each setup-specific option of ``porepipe diffusion``
_SAMPLE = {
    "wall_speed": ["--wall-speed", "thermal"],
    "inlet_law": ["--inlet-law", "isotropic"],
    "inlet_speed": ["--inlet-speed", "mean"],
    "initial_speed": ["--initial-speed", "mean"],
    "species": ["--species", "He"],
    "gas_particles": ["--gas-particles", "N2=10"],
    "collisions": ["--no-collisions"],
    "checkpoint": ["--checkpoint", "c.npz"],
}
#: options every setup reads (or, --resume, that the workflow passes to every run): not in the table
_EVERY_SETUP = {
    "help",
    "binary",
    "axis",
    "out",
    "scene",
    "seed",
    "threads",
    "resume",
    "setup",
    "wall_law",
    "func",
}


def _diffusion_parser():
    from porepipe.cli import build_parser

    parser = build_parser()
    return next(a for a in parser._actions if a.dest == "command").choices["diffusion"]


def _mode_settings(mode: str) -> Settings:
    if mode == "length_series":
        return Settings(lengths=[4, 8])
    if mode == "reaction_study":
        return Settings(setup="reaction", reactions={"series": [{"w": 0.1}]})
    return Settings(setup=mode)


def test_every_diffusion_option_is_either_for_every_setup_or_in_the_one_table():
    """A new option of ``porepipe diffusion`` must be classified: read by every setup, or listed with the setups
    that read it (so the refusal below knows it)."""
    from porepipe.diffusion._settings import MODES as _MODES

    dests = {a.dest for a in _diffusion_parser()._actions}
    assert set(_USED_BY) <= dests
    assert dests - set(_USED_BY) - _EVERY_SETUP == set()
    assert all(set(modes) <= set(_MODES) and modes for modes in _USED_BY.values())


@pytest.mark.parametrize("dest", sorted(_USED_BY))
def test_a_setup_specific_option_given_for_another_setup_is_refused(dest):
    """``--reaction-w 0.5`` with setup transmission (and every other option a setup does not read) was ignored
    without a word; now one line names the option, the setups that read it and this run's. Given for a setup that
    reads it, or not given at all (its default), nothing is refused."""
    from porepipe.diffusion._cli import _option, _refuse_unused
    from porepipe.diffusion._settings import MODES as _MODES

    parser = _diffusion_parser()
    given = parser.parse_args(["b.h5", *_SAMPLE.get(dest, [_option(dest), "4"])])
    assert getattr(given, dest) is not None
    bare = parser.parse_args(["b.h5"])
    for mode in _MODES:
        settings = _mode_settings(mode)
        _refuse_unused(bare, settings)
        if mode in _USED_BY[dest]:
            _refuse_unused(given, settings)
            continue
        with pytest.raises(PorepipeError) as err:
            _refuse_unused(given, settings)
        text = str(err.value)
        assert "\n" not in text and text.startswith(f"{_option(dest)} is read only by ")
        assert f"this run is {_MODES[mode]}" in text
        assert all(_MODES[m] in text for m in _USED_BY[dest])


def test_reaction_w_under_transmission_is_refused_before_any_work(tmp_path, capsys):
    from porepipe.cli import main

    out = tmp_path / "d.h5"
    code = main(["diffusion", str(tmp_path / "b.h5"), "-o", str(out), "--reaction-w", "0.01"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and not out.exists()
    assert "--reaction-w is read only by setup reaction; this run is setup transmission" in err[0]


def test_mean_speed_at_the_top_of_the_float_range_is_finite():
    """8·R·T overflowed above T ~ 1e307 K: v̄ = inf and every m²/s value of a finite setting inf; √T apart it is the
    same law (v̄ ∝ √T, rel 1e-14)."""
    from porepipe.diffusion import mean_speed
    from porepipe.diffusion._edmd import mean_speed_nm_ps

    assert mean_speed("N2", 1.7e308) == pytest.approx(mean_speed("N2", 1.7) * 1e154, rel=1e-14)
    assert mean_speed_nm_ps("N2", 1.7e308) == pytest.approx(mean_speed("N2", 1.7e308) * 1e-3, rel=1e-14)
    assert mean_speed("He", 298.15) == pytest.approx(math.sqrt(8 * 8.31441 * 298.15 / (math.pi * 4.0026e-3)))


@pytest.mark.parametrize("setup", ["transmission", "wicke_kallenbach", "reaction"])
def test_a_pore_space_without_wall_is_refused_in_one_line(setup):
    """All pore with both lateral axes periodic: transmission and Wicke-Kallenbach raised ZeroDivisionError (4V/S
    with S = 0), setup reaction gave η = NaN."""
    from porepipe.diffusion import reactive_pore

    pore = np.ones((3, 3, 5), np.uint8)
    with pytest.raises(PorepipeError, match="has no wall"):
        if setup == "reaction":
            reactive_pore(pore, 2, 0.5, periodic=(1, 1, 0), particles=20, batches=2)
        else:
            transport(pore, 2, Settings(setup=setup, batches=2, batch_particles=4), periodic=(1, 1, 0))


def test_voxel_edges_whose_ratio_overflows_are_refused():
    """Edges 1e-150, 1 and 1e150 µm: the pore volume in units of the smallest edge was inf, W = 0 ± 0 silently; the
    closed-pore path did not check the edges at all (NaN edges gave NaN results)."""
    pore = square_capillary(4, 8).pore
    with pytest.raises(PorepipeError, match="differ too much"):
        transport(pore, 2, Settings(batches=2, batch_particles=4), voxel_um=(1e-150, 1.0, 1e150))
    with pytest.raises(PorepipeError, match="differ too much"):
        equilibrium(pore, Settings(batches=2, batch_particles=4), voxel_um=(1e-150, 1.0, 1e150))
    with pytest.raises(PorepipeError, match="voxel_um must be positive and finite"):
        equilibrium(pore, Settings(batches=2, batch_particles=4), voxel_um=math.nan)


def test_nothing_transmitted_is_not_exact():
    """Two particles that both return gave W = 0 ± 0; the error is now that of one particle more (1/N)."""
    settings = Settings(batches=2, batch_particles=1, max_rounds=1)
    v = transport(square_capillary(2, 64).pore, 2, settings, seed=3).values  # W ~ 0.04: both return
    assert v["W"] == 0 and v["particles"] == 2 and v["W_err"] == 0.5 and v["D_err"] > 0


def test_msd_over_a_time_its_positions_cannot_resolve_is_refused():
    """An msd of 1e-300 jiffies gave D_zz = -8e252 (round-off over round-off; before, 0/0); 1e-10 jiffies still runs
    (the ballistic D = <v²>t/3... small, finite)."""
    pore, s = np.ones((1, 1, 4), np.uint8), Settings(setup="msd", batches=4, batch_particles=16, max_rounds=2)
    with pytest.raises(PorepipeError, match="msd slope would be round-off"):
        equilibrium(pore, s, periodic=(0, 0, 1), t_end=1e-300)
    v = equilibrium(pore, s, periodic=(0, 0, 1), t_end=1e-10).values
    assert (
        0 < v["D_zz"] < 1e-9 and v["mean_free_flight"] == math.inf and v["mean_free_flight_err"] == math.inf
    )


def test_a_dilute_gas_in_a_small_periodic_box_gets_three_cells_per_axis():
    """One N2 in a periodic 2³ box of 10 nm voxels was refused as 'spans 20 nm, less than 3 collision diameters'
    (it is 50): the dilute gas's wide cells were 2 per axis. The cells are now split to 3 per periodic axis; a box
    truly below 3 diameters is still refused, naming the diameter."""
    from porepipe.diffusion._edmd import edmd_result, make_gas

    settings = Settings(setup="edmd", gas={"particles": {"N2": 1}, "duration_ps": 20.0})
    v = edmd_result(np.ones((2, 2, 2), np.uint8), settings, 0.01, (1, 1, 1), seed=1).values
    assert math.isfinite(v["D_self_m2_s"]) and v["D_self_m2_s"] > 0
    with pytest.raises(PorepipeError, match=r"less than 3 collision diameters \(0.3798 nm\)"):
        make_gas(np.ones((2, 1, 1), np.uint8), 0.5, {"N2": 1}, periodic=(1, 0, 0))


@pytest.mark.parametrize(
    "gas,top,match",
    [
        ({"particles": {"N2": 100}, "duration_ps": 20.0}, {"temperature_K": 1e300}, "would need more than"),
        ({"particles": {"N2": 10}, "duration_ps": 1e-300}, {}, "msd \\(D_self\\) would be round-off"),
        ({"particles": {"N2": 10}, "duration_ps": 20.0}, {"temperature_K": 1e-300}, "would be round-off"),
    ],
)
def test_edmd_runs_that_cannot_end_or_resolve_are_refused(gas, top, match):
    """A 1e300 K gas (1e150 cell crossings per particle) hung for ever; 1e-300 ps or 1e-300 K gave D_self = NaN or
    0, its particles' motion below the resolution of their positions."""
    from porepipe.diffusion._edmd import edmd_result

    with pytest.raises(PorepipeError, match=match):
        edmd_result(np.ones((2, 2, 2), np.uint8), Settings(setup="edmd", gas=gas, **top), 0.01, (1, 1, 1))


def test_edmd_without_a_single_event_has_an_infinite_free_path():
    """One N2 alone in a closed 20 nm box for 20 ps hits nothing: λ_eff read 9.5 nm (the path it flew)."""
    from porepipe.diffusion._edmd import edmd_result

    settings = Settings(setup="edmd", gas={"particles": {"N2": 1}, "duration_ps": 20.0})
    v = edmd_result(np.ones((2, 2, 2), np.uint8), settings, 0.01, (0, 0, 0), seed=1).values
    assert v["events"] == 0 and v["lambda_eff_nm"] == math.inf


def test_a_reaction_too_rare_to_count_is_not_eta_zero_exactly():
    """w = 1e-300: no product is ever made, η read 0 ± 0 (η → 1 as w → 0); its error is now that of one product
    more, 1/(w·hits), which says the run could not measure it."""
    from porepipe.diffusion import reactive_pore

    out = reactive_pore(square_capillary(4, 8).pore, 2, 1e-300, particles=64, batches=4)
    assert out["products"] == 0 and out["eta"] == 0
    assert out["eta_err"] == pytest.approx(1.0 / (1e-300 * out["wall_hits"])) and out["r_eff_err"] > 0


def test_surface_hops_that_never_end_are_refused():
    """Ten particles that adsorb for ever and hop 1e11 times a jiffie for 1000 jiffies (1e15 events, decades) ran
    without end; a plain gas over 1e300 jiffies too."""
    from porepipe.diffusion import Adsorbate, surface_run

    pore = np.ones((3, 3, 3), np.uint8)
    with pytest.raises(PorepipeError, match="would need more than 1e\\+15 events"):
        surface_run(pore, [Adsorbate("A", gas=10, adsorption=1.0, hop_rate=1e11)], t_end=1e3, blocks=4)
    with pytest.raises(PorepipeError, match="would need more than"):
        surface_run(pore, [Adsorbate("A", gas=10)], t_end=1e300, blocks=4)


#: a scene whose diffusion section is filled in per test (analyses: diffusion on a segmented sphere)
_SCENE = {
    "name": "t",
    "domain": {"size_um": [10, 10, 10]},
    "spheres": {"inline": [[5, 5, 5, 2]]},
    "resolutions_um": [1.0],
    "analyses": ["segment", "diffusion"],
}


def _problems(section: dict) -> list[str]:
    with pytest.raises(SceneError) as err:
        parse_scene({**_SCENE, "diffusion": section})
    return err.value.problems


@pytest.mark.parametrize(
    "key,value,readers",
    [
        ("reactions", {"w": 0.1}, "setup reaction / a reaction study"),
        ("gas", {"duration_ps": 5.0}, "setup edmd"),
        ("surface", {"duration_jiffies": 5.0}, "setup surface"),
        ("wk_time_jiffies", 3.0, "setup wicke_kallenbach"),
        ("msd_samples", 8, "setup msd"),
        ("initial_speed", "mean", "setup msd"),
    ],
)
def test_a_scene_key_its_setup_ignores_is_one_problem_naming_it(key, value, readers):
    """``setup: transmission`` with ``reactions: {w: 0.1}`` (or gas, wk_time_jiffies, ...) was accepted and the key
    ignored without a word; now one problem line names the key, the setups that read it and the scene's."""
    (problem,) = _problems({"setup": "transmission", key: value})
    assert problem.startswith(f"diffusion.{key} = ")
    assert f": read only by {readers}" in problem
    assert "this scene's setup is transmission, which ignores it" in problem and "\n" not in problem


def test_a_scene_key_is_judged_only_when_given_and_for_the_run_it_makes():
    """Defaults are not given (``model_fields_set``): a bare section passes; a key given for the setup that reads it
    passes; inside a section the run's mode counts (a reaction study takes w from its series, so reactions.w set
    beside the series is ignored) and every ignored key is listed, the section once (not also its keys)."""
    ok = [
        {"setup": "transmission"},
        {"setup": "reaction", "reactions": {"w": 0.1, "z_bins": 4}, "batches": 4, "inlet_law": "isotropic"},
        {"setup": "edmd", "gas": {"duration_ps": 5.0}, "temperature_K": 300.0},
        {"setup": "wicke_kallenbach", "wk_time_jiffies": 3.0, "profile_bins": 4},
        {"setup": "reaction", "reactions": {"particles": 100, "series": [{"w": 0.1}]}},
        {"lengths": [2, 4], "target_rel_error": 0.1, "inlet_law": "isotropic"},
    ]
    for section in ok:
        parse_scene({**_SCENE, "diffusion": section})
    (study,) = _problems({"setup": "reaction", "reactions": {"w": 0.2, "series": [{"w": 0.1}]}})
    assert study.startswith(
        "diffusion.reactions.w = 0.2: read only by setup reaction; this scene's setup is "
        "reaction with diffusion.reactions.series (a reaction study), which ignores it"
    )
    problems = _problems({"setup": "msd", "gas": {"samples": 8}, "reactions": {"w": 0.2}, "profile_bins": 4})
    assert [p.split(" = ")[0] for p in problems] == [
        "diffusion.profile_bins",
        "diffusion.gas",
        "diffusion.reactions",
    ]
    (series,) = _problems({"lengths": [2, 4], "profile_bins": 4})
    assert "this scene's setup is transmission with diffusion.lengths (a length series)" in series
    # a scene may name the gas of a study whose numbers do not depend on it (documentation; the result records it)
    assert (
        parse_scene({**_SCENE, "diffusion": {"lengths": [2, 4], "species": "He"}}).diffusion.species == "He"
    )


def test_a_misspelt_setup_is_not_judged_as_its_default():
    """The second pass that finds checks hidden by a bad value validates with the bad key removed: a misspelt
    setup then read as transmission, and reactions set for setup reaction would be called ignored."""
    problems = _problems({"setup": "reacton", "reactions": {"w": 0.1}})
    assert len(problems) == 1 and problems[0].startswith("diffusion.setup = 'reacton'")


def test_the_scene_and_the_command_line_share_one_table_of_settings():
    """Every setting of the table exists, and each setup-specific option of ``porepipe diffusion`` takes its setups
    from the table (by its setting's name), so the two checks cannot disagree."""
    from porepipe.diffusion._cli import _SETTING
    from porepipe.diffusion._settings import USED_BY, used_by

    for setting in USED_BY:
        model = Settings
        for part in setting.split("."):
            assert part in model.model_fields, setting
            model = model.model_fields[part].annotation
    for dest, modes in _USED_BY.items():
        if dest != "checkpoint":
            assert modes == used_by(_SETTING.get(dest, dest)), dest


#: a section per mode of the one table (porepipe.diffusion._settings.MODES), as a scene or Settings(...) gives it
_MODE_SECTIONS = {
    "length_series": {"lengths": [4, 8]},
    "reaction_study": {"setup": "reaction", "reactions": {"series": [{"w": 0.1}]}},
}


def _with_setting(section: dict, setting: str, value) -> dict:
    """``section`` with ``setting`` (``key`` or ``section.key``) given explicitly as ``value``."""
    outer, _, key = setting.rpartition(".")
    if not outer:
        return {**section, key: value}
    return {**section, outer: {**section.get(outer, {}), key: value}}


@pytest.mark.parametrize("setting", sorted(USED_BY))
def test_settings_built_in_python_refuse_a_setting_their_setup_ignores_as_a_scene_does(setting):
    """``Settings(setup="transmission", reactions={"w": 0.5})`` was accepted in Python and the reactions ignored
    without a word, while a scene with the same section was refused. Now, for every setting of the one table and every
    mode, Python refuses exactly where the table says the mode does not read it (the scene's verdict too, and the
    command line's options take their modes from the same table): a ValueError naming the key and the setup. Its
    default, given explicitly, counts as given (as in a scene); merge_settings, whose merged dump sets every key,
    does not judge (the command line checks its own options)."""
    from pydantic import ValidationError

    from porepipe._shared.overrides import merge_settings
    from porepipe.diffusion._settings import MODES as _MODES
    from porepipe.diffusion._settings import SCENE_MAY_NAME, readers_text, used_by

    defaults = Settings().model_dump(mode="json")
    value = defaults
    for part in setting.split("."):
        value = value[part]
    for mode in _MODES:
        section = _with_setting(_MODE_SECTIONS.get(mode, {"setup": mode}), setting, value)
        ignored = mode not in used_by(setting) and setting not in SCENE_MAY_NAME
        if not ignored:
            Settings(**section)
            parse_scene({**_SCENE, "diffusion": section})
            continue
        with pytest.raises(ValueError) as err:
            Settings(**section)
        assert isinstance(err.value, ValidationError)
        ((loc, message),) = [(".".join(e["loc"]), e["msg"]) for e in err.value.errors()]
        assert setting.startswith(loc)  # the key, or its section where the whole section is unread
        setup = _mode_settings(mode).setup.value
        assert f"read only by {readers_text(USED_BY[loc])}; the setup is {setup}" in message
        (problem,) = _problems(section)
        assert problem.startswith(f"diffusion.{loc} = ") and f"this scene's setup is {setup}" in problem
        merged = merge_settings(
            Settings, section, {}, "diffusion settings"
        )  # the CLI's merge: not judged here
        assert merged.setup.value == setup


def test_the_command_line_may_change_a_scenes_setup(tmp_path):
    """The scene's keys are judged against the scene's setup when it loads; ``--setup`` over it runs the other
    setup (those keys unread, as before), while the options given on the command line are still judged."""
    import yaml

    from porepipe.diffusion._cli import _settings

    scene = tmp_path / "s.yaml"
    scene.write_text(yaml.safe_dump({**_SCENE, "diffusion": {"setup": "transmission", "profile_bins": 4}}))
    parser = _diffusion_parser()
    settings, _, _ = _settings(parser.parse_args(["b.h5", "--scene", str(scene), "--setup", "msd"]))
    assert settings.setup.value == "msd"
    with pytest.raises(PorepipeError, match="--hit-map-bins is read only by"):
        _settings(parser.parse_args(["b.h5", "--scene", str(scene), "--setup", "msd", "--hit-map-bins", "4"]))


@pytest.mark.parametrize(
    "path", sorted(Path(__file__).parents[2].glob("config/scenes/*.yaml")), ids=lambda p: p.stem
)
def test_every_shipped_scene_validates(path):
    """The shipped scenes set no key their setup ignores (the reaction studies and length series name their gas,
    which a scene may: SCENE_MAY_NAME)."""
    from porepipe.scene import load_scene

    load_scene(path)
