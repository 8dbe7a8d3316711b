"""Hard cases of the Knudsen engine: degenerate geometry, bad input, no NaN."""

import math

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe.diffusion import Settings, equilibrium, prepare, square_capillary, transport
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

    with pytest.raises(PorepipeError, match="the length series needs finite r/L, D > 0 and errors > 0"):
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
    assert "accommodation = 2.0: Input should be less than or equal to 1" in err[0]
    assert "target_rel_error = -1.0" in err[0] and "errors.pydantic.dev" not in err[0]
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
