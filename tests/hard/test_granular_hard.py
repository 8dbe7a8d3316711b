"""Hard cases of the granular DEM: degenerate contacts, extreme aspect ratios, an unstable time step, NaN,
zero gravity, a particle outside every wall, bad input."""

import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "unit" / "granular"))
from naive_granular import floor, simulation, square

from porepipe._shared.errors import PorepipeError
from porepipe.granular import Settings, Simulation, run
from porepipe.scene import SceneError, load_scene, parse_scene

SOFT = {"young_N_m": 1e6, "density_kg_m2": 1000.0}


def _finite(sim):
    assert np.all(np.isfinite(sim.G)) and np.all(np.isfinite(sim.pout))


@pytest.mark.slow
def test_coincident_polygons_are_refused_at_the_start_and_finite_when_allowed():
    p = {"vertices_m": square(0.01), "position_m": (0.0, 0.0)}
    with pytest.raises(PorepipeError, match="initial placement overlaps"):
        simulation([p, p], dt_s=1e-6, material=SOFT).advance(1)
    sim = simulation([p, p], dt_s=1e-7, material=SOFT, guard={"max_overlap": 10.0, "max_move": 10.0})
    sim.advance(20)
    _finite(sim)
    # the fall-back normal for coincident centroids is +y: they separate along y, symmetrically
    assert sim.velocity[1, 1] > 0 > sim.velocity[0, 1]
    assert sim.velocity[0, 1] == pytest.approx(-sim.velocity[1, 1], rel=1e-12)


def test_vertex_exactly_on_an_edge_and_parallel_touching_edges():
    tip = {"vertices_m": [(0.0, 0.0), (0.01, 0.01), (-0.01, 0.01)], "position_m": (0.0, 0.02 / 3)}  # centroid
    flat = {"vertices_m": square(0.01), "position_m": (0.05, 0.005)}
    sim = simulation([tip, flat], [floor()], dt_s=1e-6, gravity_m_s2=(0.0, -9.81), material=SOFT)
    y_tip = sim.position[0, 1] + min(v[1] for v in sim.body[0, :3])
    assert y_tip == pytest.approx(
        0.0, abs=1e-15
    )  # the tip exactly on the floor's edge, the square flush on it
    sim.advance(1)
    # after one step they have sunk by g dt^2/2 = 5e-12 m: overlap areas of that order, finite normals
    assert np.all(sim.contacts()["area_m2"] < 1e-13)
    _finite(sim)
    sim.advance(3000)
    _finite(sim)
    c = sim.contacts()
    assert set(c["i"].tolist()) == {0, 1} and np.all(c["fn_N"] >= 0)


def test_needle_thin_polygon_uses_the_inscribed_radius():
    needle = [(-0.02, -1e-4), (0.02, -1e-4), (0.02, 1e-4), (-0.02, 1e-4)]
    sim = simulation(
        [{"vertices_m": needle, "position_m": (0.0, 0.008), "angle_rad": 0.3}],
        [floor()],
        gravity_m_s2=(0.0, -9.81),
        material={"young_N_m": 1e7, "density_kg_m2": 1000.0},
    )
    # Eq. 2.9 with m = pi r_in^2 rho (r_in = 0.1 mm), not the needle's mass (8x larger)
    assert sim.dt == pytest.approx(0.5 * 0.1 * math.pi * math.sqrt(math.pi * 1e-8 * 1000 / 1e7), rel=1e-12)
    touched = 0
    for _ in range(100):
        sim.advance(int(0.0005 / sim.dt))
        _finite(sim)
        touched += len(sim.contacts()["i"])
        assert sim.wv[0, :4, 1].min() > -2e-5  # never deeper than 1/5 of its thickness into the floor
    assert touched > 0


def test_too_large_dt_for_E_fires_the_guard_with_the_dt_to_try():
    p = {"vertices_m": square(0.01), "position_m": (0.0, 0.006), "velocity_m_s": (0.0, -1.0)}
    sim = simulation([p], [floor()], dt_s=1e-4, material={"young_N_m": 1e12, "density_kg_m2": 1000.0})
    with pytest.raises(PorepipeError, match=r"unstable at step \d+ .*rerun with granular.dt_s <= ") as err:
        sim.advance(1000)
    assert "(pi/10) sqrt(m_min/E)" in str(err.value)


def test_nan_velocity_is_caught():
    sim = simulation([{"vertices_m": square(0.01), "position_m": (0.0, 0.0)}], material=SOFT)
    sim.G[1, 0, 0] = np.nan
    with pytest.raises(PorepipeError, match="non-finite"):
        sim.advance(5)


def test_particle_outside_every_wall_falls_freely():
    sim = simulation(
        [{"vertices_m": square(0.01), "position_m": (5.0, -3.0)}],
        [floor()],
        dt_s=1e-4,
        gravity_m_s2=(0.0, -9.81),
        material=SOFT,
    )
    sim.advance(1000)
    _finite(sim)
    assert sim.position[0, 1] == pytest.approx(-3.0 - 0.5 * 9.81 * 0.1**2, rel=1e-12)
    assert len(sim.nb_j) == 0  # no candidate pairs at all


def test_bad_input_names_the_key():
    with pytest.raises(PorepipeError, match="granular particle 1: not a convex polygon"):
        Simulation(
            Settings.model_validate(
                {
                    "particles": [
                        {"vertices_m": square(0.01)},
                        {"vertices_m": [(0, 0), (1, 0), (0.1, 0.1), (0, 1)]},
                    ]
                }
            )
        )
    with pytest.raises(PorepipeError, match="granular wall 'w': not a convex polygon"):
        Simulation(
            Settings.model_validate(
                {
                    "particles": [{"vertices_m": square(0.01)}],
                    "walls": [{"name": "w", "vertices_m": [(0, 0), (1, 0), (1, 0)]}],
                }
            )
        )
    with pytest.raises(PorepipeError, match="no particles"):
        Simulation(Settings())
    with pytest.raises(SceneError, match="granular.material.young_N_m"):
        parse_scene({"name": "x", "analyses": ["granular"], "granular": {"material": {"young_N_m": -1}}})
    with pytest.raises(SceneError, match="granular.dt_seconds"):
        parse_scene({"name": "x", "analyses": ["granular"], "granular": {"dt_seconds": 1}})


def test_granular_scene_needs_no_box_or_resolutions_but_others_still_do():
    one = [{"position_m": (0.0, 0.0), "shape": {"size_m": (0.001, 0.001)}}]
    scene = parse_scene(
        {"name": "g", "analyses": ["granular"], "granular": {"duration_s": 0.1, "particles": one}}
    )
    assert scene.granular.duration_s == 0.1 and scene.domain is None
    with pytest.raises(SceneError, match="resolutions_um"):
        parse_scene({"name": "x", "domain": {"size_um": [10, 10, 10]}, "spheres": {"inline": [[1, 1, 1, 1]]}})


@pytest.mark.parametrize(
    "coord,force,kw,match",
    [
        ([0.5], [2.0], {}, "all 1 contacts lie at one coordinate 0.5"),
        ([0.5, 0.5], [2.0, 1.0], {}, "all 2 contacts lie at one coordinate 0.5"),
        ([0.1, 0.5], [2.0, 1.0], {"half_width": 0.0}, "half_width must be positive"),
        ([0.1, np.nan], [2.0, 1.0], {}, "must be finite"),
    ],
)
def test_pressure_profile_of_a_single_contact_or_a_zero_window(coord, force, kw, match):
    """One grain on a wall (or all contacts at one place) set the window half-width to 1e-300-ish: a pressure of
    1e299 N/m, silently; half_width 0 divided by zero; a NaN coordinate made every window NaN."""
    from porepipe.granular import pressure_profile

    with pytest.raises(PorepipeError, match=match):
        pressure_profile(coord, force, 1.0, **kw)
    if len(coord) == 1:  # with a window given, one contact is a plain box: F / (2 b) inside it
        p = pressure_profile(coord, force, 1.0, centres=[0.5], half_width=0.25)
        assert p["pressure"][0] == pytest.approx(
            2.0 / 0.5, rel=1e-15
        )  # exact but for the division's rounding


@pytest.mark.parametrize("what", ["analyse_heap", "analyse_silo"])
def test_heap_and_silo_read_outs_of_a_frame_without_grains(what, tmp_path):
    """A run that ends before its drop source inserts anything: every frame is empty. analyse_heap failed in
    numpy's concatenate, analyse_silo with 'Mean of empty slice'."""
    from porepipe import granular

    box_floor = {**floor(), "name": "box floor"}
    source = {"x_m": 0.0, "y_m": 0.1, "from_s": 1.0, "to_s": 2.0, "shape": {"size_m": (0.005, 0.005)}}
    settings = Settings.model_validate(
        {"walls": [box_floor], "drop_sources": [source], "duration_s": 1e-3, "material": SOFT}
    )
    tables = granular.read_granular(granular.run(settings, tmp_path / "g.h5", progress=False))
    with pytest.raises(PorepipeError, match=f"{what}: frame 10 has no active grains"):
        getattr(granular, what)(tables)


def test_force_directions_without_contacts():
    """A single grain in the air has no contacts: the normalised histogram was 0/0 (NaN and a RuntimeWarning)."""
    from porepipe.granular import force_directions

    sim = simulation([{"vertices_m": square(0.01), "position_m": (0.0, 0.0)}], material=SOFT)
    with pytest.raises(PorepipeError, match="force_directions: no contacts"):
        force_directions(sim.contacts())


@pytest.mark.parametrize(
    "mass,young,match",
    [
        (-1.0, 1e6, "min_mass_kg must be a positive finite number, got -1.0"),
        (0.0, 1e6, "min_mass_kg must be a positive finite number, got 0.0"),
        (1.0, 0.0, "young_N_m must be a positive finite number, got 0.0"),
        (1.0, math.inf, "young_N_m must be a positive finite number, got inf"),
    ],
)
def test_time_step_rule_refuses_a_mass_or_modulus_that_is_not_positive(mass, young, match):
    """A negative mass failed in math.sqrt ('math domain error'), E = 0 divided by zero, a zero mass or an infinite
    E gave dt = 0 silently."""
    from porepipe.granular import time_step_rule

    with pytest.raises(PorepipeError, match=f"time_step_rule: {match}"):
        time_step_rule(mass, young)


@pytest.mark.parametrize(
    "pressure,apex,match",
    [
        ([np.nan] * 3, 1.0, "nor NaN at the apex x = 1.0"),
        ([np.nan, 1.0, 2.0], 0.0, "nor NaN at the apex x = 0.0"),
        ([1.0, np.inf, 2.0], 1.0, "must not be infinite"),
    ],
)
def test_pressure_dip_of_a_profile_without_numbers(pressure, apex, match):
    """An all-NaN profile failed in numpy's nanargmax ('All-NaN slice encountered'); a NaN at the apex or an
    infinite pressure gave dip = NaN or 1 silently."""
    from porepipe.granular import pressure_dip

    with pytest.raises(PorepipeError, match=f"pressure_dip: pressure .*{match}"):
        pressure_dip([0.0, 1.0, 2.0], pressure, apex)


@pytest.mark.parametrize("centres", [[], [0.2, np.nan], [[0.2, 0.3]]])
def test_pressure_profile_refuses_empty_or_nan_centres(centres):
    """No centres failed in np.pad ('can't extend empty axis'); a NaN centre gave a pressure of 0 there."""
    from porepipe.granular import pressure_profile

    with pytest.raises(PorepipeError, match="pressure_profile: centres must be a non-empty 1-D array"):
        pressure_profile([0.1, 0.5], [2.0, 1.0], 1.0, centres=centres)


@pytest.mark.parametrize("outlet", [0.0, -0.01, 0.003, 0.2, np.nan])
def test_galton_funnel_outlet_between_a_ball_and_the_hopper_top(outlet):
    """An outlet of 0 (or under ~0.7 ball diameters) failed in the drop source's schema (a negative width_m), NaN in
    the wall schema; 0.003 m built a funnel no ball passes (a clog after the whole feed); 0.2 m, wider than the
    board, put the funnel's walls outside the side walls: no funnel, silently."""
    from porepipe.granular import GaltonBoard

    with pytest.raises(PorepipeError, match="GaltonBoard: outlet_m must be wider than a ball"):
        GaltonBoard(outlet_m=outlet)
    # inside the bounds the outlet is taken as given
    assert GaltonBoard(outlet_m=0.05).outlet[0] == pytest.approx(0.05, rel=1e-15)


def test_a_run_of_more_steps_than_the_counter_holds_is_refused_and_leaves_no_file(tmp_path):
    # 1e-30 m grains: dt = 1.3e-33 s, 8e31 steps in 0.1 s; before: numpy's casting error from linspace (traceback)
    tiny = [(0.0, 0.0), (1e-30, 0.0), (1e-30, 1e-30), (0.0, 1e-30)]
    settings = Settings.model_validate({"duration_s": 0.1, "particles": [{"vertices_m": tiny}]})
    with pytest.raises(
        PorepipeError, match=r"granular.duration_s = 0.1 s is 7.97e\+31 time steps .* \(2\^62\)"
    ):
        run(settings, tmp_path / "g.h5", progress=False)
    assert list(tmp_path.iterdir()) == []


# before: 1e80 m gave an infinite moment of inertia (a grain that never turns), 1e-100 m a zero one and dt = 0,
# 1e150 m a NaN one (written to the result), 1e200 m overflow warnings and then "not a convex polygon"
@pytest.mark.parametrize(
    "edge, match",
    [
        (1e80, r"mass 5e\+163 kg and moment of inertia inf kg m² must be positive finite"),
        (1e-100, r"mass 5e-197 kg and moment of inertia 0 kg m² must be positive finite"),
        (1e150, r"corner coordinates reach 1e\+150 m; allowed: \|x\|, \|y\| <= 1e\+100 m"),
        (1e200, r"corner coordinates reach 1e\+200 m"),
    ],
)
def test_polygons_whose_mass_properties_overflow_or_underflow_are_refused(edge, match):
    square_ = [(0.0, 0.0), (edge, 0.0), (edge, edge), (0.0, edge)]
    settings = Settings.model_validate({"particles": [{"vertices_m": square_, "position_m": (0.0, edge)}]})
    with pytest.raises(PorepipeError, match=rf"granular particle 0: {match}"):
        Simulation(settings)


def test_a_grain_dropped_onto_the_last_one_is_named_as_an_insertion_overlap_not_an_unstable_dt():
    # one grain per ms at the same point: the second goes in where the first has fallen 5 um; before: "unstable at
    # step 121 ... rerun with granular.dt_s <= ...", which no time step cures
    source = {"x_m": 0.0, "y_m": 0.05, "every_s": 0.001, "to_s": 0.003, "shape": {"size_m": (0.005, 0.005)}}
    sim = Simulation(Settings.model_validate({"drop_sources": [source]}))
    with pytest.raises(
        PorepipeError,
        match=r"one step after granular.drop_sources\[0\] inserted particle\(s\) \[1\] at t = 0.001 s: .*\(every_s\)",
    ):
        sim.advance(round(0.003 / sim.dt))


def test_the_guard_advises_a_dt_within_the_damping_bound_when_the_run_is_past_it():
    # damping 1e6 bounds dt at 2.7e-11 s (c dt <= 0.15, Gear); before: the guard advised dt/2 (2.2e-5 s), and every
    # rerun with its advice failed again, halving the step each time
    p = {"vertices_m": square(0.01), "position_m": (0.0, 0.0051), "velocity_m_s": (0.0, -0.5)}
    material = {"young_N_m": 1e6, "density_kg_m2": 1000.0, "damping": 1e6}
    bound = simulation([p], [floor()], material=material).dt_damping
    with pytest.raises(PorepipeError, match=r"and the damping bound .* rerun with granular.dt_s <= ") as err:
        simulation([p], [floor()], material=material, dt_s=4.4e-5).advance(100)
    advised = float(str(err.value).rsplit("<= ", 1)[1])
    assert advised == pytest.approx(bound, rel=1e-2)  # printed to 3 digits
    sim = simulation([p], [floor()], material=material, dt_s=advised)
    sim.advance(2000)
    _finite(sim)


@pytest.mark.parametrize("steps", [math.nan, math.inf, 2.7, -5, True, "4"])
def test_advance_refuses_a_step_count_that_is_not_a_whole_number_at_least_0(steps):
    # before: NaN and inf raised a raw ValueError/OverflowError, 2.7 ran 2 steps, -5 and True ran 0 and 1 silently
    sim = simulation([{"vertices_m": square(0.01), "position_m": (0.0, 0.1)}])
    with pytest.raises(PorepipeError, match=r"^Simulation.advance: steps must be a whole number >= 0, got "):
        sim.advance(steps)
    assert sim.step == 0
    sim.advance(np.int64(2))
    sim.advance(3.0)
    assert sim.step == 5


def test_a_duration_shorter_than_half_a_step_is_refused_and_0_says_it_writes_the_start(tmp_path, capsys):
    # before: duration_s = 1e-6 s at dt = 1.5e-5 s rounded to 0 steps and wrote the initial state without a word
    grain = {"vertices_m": square(0.01), "position_m": (0.0, 0.1)}
    short = Settings.model_validate({"particles": [grain], "duration_s": 1e-6, "dt_s": 1e-5})
    with pytest.raises(
        PorepipeError,
        match=r"^granular.duration_s = 1e-06 s is shorter than half a time step \(dt = 1e-05 s\), so the run would",
    ):
        run(short, tmp_path / "g.h5", progress=False)
    assert list(tmp_path.iterdir()) == []
    run(short.model_copy(update={"duration_s": 0.0}), tmp_path / "g.h5", progress=False)
    assert (
        "granular.duration_s = 0: no time step; the result holds the initial state alone"
        in capsys.readouterr().err
    )


def test_a_grain_that_flies_too_fast_without_a_contact_is_named_as_such_not_as_an_unstable_dt():
    # the guard allows 0.2 inscribed radii (1 mm) per step: 10 m/s at dt = 1e-4 s, reached after ~0.05 s of fall;
    # before: "unstable at step N ... rerun with granular.dt_s <= dt/2", which only delays the stop
    grain = {"vertices_m": square(0.01), "position_m": (5.0, -3.0), "velocity_m_s": (0.0, -9.5)}
    sim = simulation([grain], [floor()], dt_s=1e-4, gravity_m_s2=(0.0, -9.81), material=SOFT)
    with pytest.raises(
        PorepipeError,
        match=r"^granular: particle 0 moved 0.001 m in one step without a contact at step \d+ \(t = 0.05\d* s\): "
        r"it flies at 10 m/s and 0 rad/s at \(5, -3.\d+\) m, outside every wall's reach, and "
        r"granular.guard.max_move = 0.2 inscribed radii allows 0.001 m per step .* not an unstable dt .*"
        r"raise granular.guard.max_move$",
    ):
        sim.advance(1000)


class _Stopped(Exception):
    pass


def _start_only(monkeypatch):
    def stop(self, steps):
        raise _Stopped

    monkeypatch.setattr(Simulation, "advance", stop)


def test_a_run_planned_longer_than_a_day_says_so_in_one_line_before_its_first_step(
    tmp_path, monkeypatch, capsys
):
    # 1e-9 m grains: dt = 1.25e-12 s, 8e10 steps in 0.1 s (~60 h measured); before: the run started silently and only
    # its progress line showed an ETA of ~117 h. No override exists, so it is a warning, not a refusal
    _start_only(monkeypatch)
    tiny = [(0.0, 0.0), (1e-9, 0.0), (1e-9, 1e-9), (0.0, 1e-9)]
    settings = Settings.model_validate({"duration_s": 0.1, "particles": [{"vertices_m": tiny}]})
    with pytest.raises(_Stopped):
        run(settings, tmp_path / "g.h5", progress=False)
    err = capsys.readouterr().err
    assert re.search(
        r"^porepipe: granular: 7.97e\+10 time steps of dt = 1.25e-12 s for duration_s = 0.1 s with 1 particle\(s\) "
        r"would take about [\d.]+ h on one core .*dt comes from the lightest grain .* shorten granular.duration_s or set "
        r"a larger granular.dt_s$",
        err,
        re.M,
    )
    # the longest shipped scene (1e4 grains, 1e6 steps, ~1 h) is not warned about
    settings = load_scene(
        Path(__file__).parents[2] / "config" / "scenes" / "granular-silo-stepped.yaml"
    ).granular
    with pytest.raises(_Stopped):
        run(settings, tmp_path / "g.h5", progress=False)
    assert "would take about" not in capsys.readouterr().err


def test_grains_that_overlap_as_placed_are_counted_in_one_line_before_the_run(tmp_path, capsys):
    # below the guard (0.3 r_eq²) a start overlap was accepted silently and pushed the grains apart: granular-box with
    # g = 0 went from rest to 0.011 J/m. Blocks may overlap by construction (jittered FCC), so a line, not a refusal
    a, b = square(0.01), square(0.01)
    grains = [
        {"vertices_m": a, "position_m": (0.0, 0.1)},
        {"vertices_m": b, "position_m": (0.0098, 0.1)},  # 0.2 mm into the first: 2e-6 m² = 0.063 r_eq²
        {"vertices_m": a, "position_m": (0.2, 0.005)},  # flush on the floor: touching is no overlap
        {"vertices_m": a, "position_m": (0.4, 0.0049)},  # 0.1 mm into the floor
    ]
    settings = Settings.model_validate(
        {
            "particles": grains,
            "walls": [floor()],
            "gravity_m_s2": (0.0, 0.0),
            "duration_s": 1e-3,
            "material": SOFT,
            "output": {"series_every": 5},
        }
    )
    out = run(settings, tmp_path / "g.h5", progress=False)
    lines = [x for x in capsys.readouterr().err.splitlines() if "overlap as placed" in x]
    assert lines == [
        "porepipe: granular: 1 grain-grain and 1 grain-wall pair(s) overlap as placed, the largest by 0.063 r_eq² "
        "(particle 0 and particle 1; granular.guard.max_overlap 0.3): they push apart in the first steps, which adds "
        "kinetic energy; to start without overlaps, widen the block's grid_m, lower its jitter_fraction or move the "
        "particles"
    ]
    from porepipe.granular import read_granular

    energy = read_granular(out)["series"].kinetic_energy_J.values
    assert energy[0] == 0.0 and energy[-1] > 0.0  # the energy the line warns about
    grains[1]["position_m"], grains[3]["position_m"] = (0.0101, 0.1), (0.4, 0.005)
    run(
        settings.model_copy(update={"particles": Settings.model_validate({"particles": grains}).particles}),
        out,
    )
    assert "overlap as placed" not in capsys.readouterr().err
