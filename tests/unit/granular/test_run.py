"""Stage plumbing: the result file (xarray-readable frames, contacts, series, cost), checkpoint/resume
bit-identical to an uninterrupted run, stale checkpoints discarded, the CLI and the workflow rule."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from naive_granular import simulation

from porepipe._shared.store import read_attrs
from porepipe.granular import Settings, read_granular, run
from porepipe.granular import _run as granular_run

REPO = Path(__file__).parents[3]
SMALL = {
    "duration_s": 0.03,
    "dt_s": 2e-5,
    "checkpoint_every_steps": 400,
    "box": {"lower_m": (0, 0), "upper_m": (0.06, 0.1)},
    "blocks": [
        {
            "lower_m": (0, 0),
            "upper_m": (0.06, 0.05),
            "grid_m": (0.012, 0.012),
            "shape": {
                "size_m": (0.005, 0.005),
                "corners": 7,
                "angle_mode": "RAND1",
                "orientation_dist": "EQUAL",
            },
        }
    ],
    "output": {"frames": 4, "series_every": 100},
}


def test_result_file_layout(tmp_path):
    out = run(Settings.model_validate(SMALL), tmp_path / "g.h5", seed=1, scene="small", progress=False)
    d = read_granular(out)
    frames, contacts, series = d["frames"], d["contacts"], d["series"]
    assert frames.position_m.shape == (5, 20, 2) and frames.time_s.values[-1] == pytest.approx(0.03)
    assert set(contacts.data_vars) >= {
        "i",
        "j",
        "fx_N",
        "fy_N",
        "sx_m",
        "sy_m",
        "fn_N",
        "ft_N",
        "area_m2",
        "frame",
    }
    assert len(contacts.contact) > 0 and np.all(
        contacts.fn_N.values >= 0
    )  # never attractive without cohesion
    assert len(series.sample) == 16
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert "vertices_m" in ds
    attrs = read_attrs(out)
    assert attrs["stage"] == "granular" and attrs["wall_s"] > 0 and attrs["steps"] == 1500
    assert attrs["effects"] == "none"


def test_every_unit_of_a_granular_result_is_one_pint_reads_and_the_right_dimension(tmp_path):
    pint = pytest.importorskip("pint")
    ureg = pint.UnitRegistry()
    out = run(Settings.model_validate(SMALL), tmp_path / "g.h5", seed=1, scene="small", progress=False)
    tables = read_granular(out)
    for group, ds in tables.items():
        for name, var in ds.variables.items():
            if var.dtype.kind in "biuf":
                assert "units" in var.attrs, f"{group}/{name} has no units"
                ureg.Unit(var.attrs["units"])  # raises if pint cannot parse it
    frames, series = tables["frames"], tables["series"]
    dimension = {"position_m": "[length]", "angle_rad": "", "velocity_m_s": "[length]/[time]"}
    dimension |= {
        "angular_velocity_rad_s": "1/[time]",
        "mass_kg": "[mass]",
        "inertia_kg_m2": "[mass]*[length]**2",
    }
    for name, dim in dimension.items():
        assert ureg.Unit(frames[name].attrs["units"]).dimensionality == ureg.get_dimensionality(dim), name
    # truth: the kinetic energy the series records at the last frame's time is 1/2 m v^2 + 1/2 I w^2 of that frame,
    # each term converted by pint from the stored units to joule (exact up to float round-off: 1e-12)
    t_end = float(frames.time_s.values[-1])
    k = int(np.argmin(np.abs(series.time_s.values - t_end)))
    assert series.time_s.values[k] == pytest.approx(t_end, rel=1e-12)
    act = frames.active.values[-1].astype(bool)

    def q(name, values):
        return ureg.Quantity(values, frames[name].attrs["units"])

    v2 = (q("velocity_m_s", frames.velocity_m_s.values[-1]) ** 2).sum(axis=1)
    w2 = q("angular_velocity_rad_s", frames.angular_velocity_rad_s.values[-1]) ** 2
    kinetic = 0.5 * (
        q("mass_kg", frames.mass_kg.values) * v2 + q("inertia_kg_m2", frames.inertia_kg_m2.values) * w2
    )
    recorded = ureg.Quantity(series.kinetic_energy_J.values[k], series.kinetic_energy_J.attrs["units"])
    assert kinetic[act].sum().to("J").magnitude == pytest.approx(recorded.to("J").magnitude, rel=1e-12)


def test_simulation_restore_is_bit_identical():
    s = Settings.model_validate({**SMALL, "gravity_m_s2": (0, -9.81)})
    from porepipe.granular import Simulation

    a = Simulation(s, 1)
    a.advance(2000)
    b = Simulation(s, 1)
    b.advance(1400)
    assert len(b.contacts()["i"]) > 2  # resumed with live contacts (springs and previous overlaps)
    state = b.state()
    c = Simulation(s, 1)
    c.restore(state)
    c.advance(600)
    assert a.rebuilds > 1
    np.testing.assert_array_equal(a.G, c.G)
    np.testing.assert_array_equal(a.ft, c.ft)


def test_interrupted_run_resumes_identically(tmp_path, monkeypatch):
    settings = Settings.model_validate(SMALL)
    ref = run(settings, tmp_path / "ref.h5", seed=2, progress=False)
    ck = tmp_path / "ck.npz"

    def crash(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(granular_run, "_write", crash)
    with pytest.raises(KeyboardInterrupt):
        run(settings, tmp_path / "out.h5", seed=2, checkpoint=ck, progress=False)
    assert ck.is_file() and not (tmp_path / "out.h5").exists()
    with np.load(ck) as z:
        spent = float(z["spent_wall_s"]), float(z["spent_cpu_s"])  # what the killed process spent to it
    assert spent[0] > 0 and spent[1] > 0
    monkeypatch.undo()
    calls = []
    original = granular_run.Simulation.restore
    monkeypatch.setattr(
        granular_run.Simulation, "restore", lambda self, st: (calls.append(1), original(self, st))
    )
    out = run(settings, tmp_path / "out.h5", seed=2, checkpoint=ck, resume=True, progress=False)
    assert calls and not ck.exists()
    a, b = read_granular(ref), read_granular(out)
    for key in ("frames", "contacts", "series"):
        xr.testing.assert_equal(a[key], b[key])  # values and coords exactly (the attrs carry wall times)
    # the result's cost counts the killed process up to its checkpoint, and says so
    attrs = read_attrs(out)
    assert (attrs["resumed_wall_s"], attrs["resumed_cpu_s"]) == spent
    assert attrs["wall_s"] > spent[0] and attrs["cpu_s"] > spent[1]


def test_stale_checkpoint_is_discarded(tmp_path):
    ck = tmp_path / "ck.npz"
    np.savez(ck, key=np.array("not-this-scene"))
    out = run(
        Settings.model_validate(SMALL), tmp_path / "g.h5", seed=1, checkpoint=ck, resume=True, progress=False
    )
    assert out.is_file() and not ck.exists()


def test_cli_and_bad_scene(tmp_path):
    scene = tmp_path / "s.yaml"
    scene.write_text(
        "name: s\nanalyses: [granular]\ngranular:\n  duration_s: 0.001\n  dt_s: 1.0e-5\n"
        "  particles:\n    - {vertices_m: [[0, 0], [0.01, 0], [0.01, 0.01]]}\n"
    )
    exe = [sys.executable, "-m", "porepipe.cli"]
    ok = subprocess.run(
        [*exe, "granular", str(scene), "-o", str(tmp_path / "g.h5"), "--quiet"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert ok.returncode == 0, ok.stderr
    scene.write_text(
        "name: s\nanalyses: [granular]\ngranular:\n  particles:\n"
        "    - {vertices_m: [[0, 0], [0.01, 0], [0.002, 0.002], [0, 0.01]]}\n"
    )
    bad = subprocess.run(
        [*exe, "granular", str(scene), "-o", str(tmp_path / "b.h5")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert bad.returncode == 2
    assert (
        "granular particle 0: not a convex polygon" in bad.stderr
        and len(bad.stderr.strip().splitlines()) == 1
    )
    assert not (tmp_path / "b.h5").exists() and not list(tmp_path.glob(".b.h5*"))


def test_workflow_dry_run_has_the_granular_rule(tmp_path):
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "porepipe.cli",
            "run",
            str(REPO / "config/scenes/granular-box.yaml"),
            "-n",
            "--cores",
            "1",
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        check=False,
    )
    assert res.returncode == 0, res.stdout + res.stderr
    assert "rule granular:" in res.stdout or "granular" in res.stdout
    assert "results/granular-box/granular/granular.h5" in res.stdout


def test_zero_gravity_rest_is_exact():
    sim = simulation([{"vertices_m": [(0, 0), (0.01, 0), (0.01, 0.01)], "position_m": (0.3, 0.2)}])
    x0 = sim.position.copy()
    sim.advance(500)
    np.testing.assert_array_equal(sim.position, x0)


def test_cost_counts_only_active_particles(tmp_path):
    """``particle_steps`` sums the particles that are in the run, step by step: a block of 20 grains from the start
    gives exactly 20 x steps; a source that drops one grain every 2 ms from t = 0 into an empty box gives, with
    grain k live from its insertion, sum_k (T - t_k) / dt within the granularity of the count (taken per chunk of
    ``series_every`` steps: at most one grain's chunk per insertion), well below the final count x steps."""
    block = run(Settings.model_validate(SMALL), tmp_path / "b.h5", seed=1, progress=False)
    a = read_attrs(block)
    assert a["particle_steps"] == 20 * a["steps"]
    source = {
        "x_m": 0.03,
        "y_m": 0.08,
        "width_m": 0.0,
        "every_s": 0.002,
        "from_s": 0.0,
        "to_s": 0.02,
        "velocity_m_s": (0.0, -2.0),  # 4 mm down before the next grain: no overlap at insertion
        "shape": {"size_m": (0.002, 0.002), "corners": 6},
    }
    rain = {k: v for k, v in SMALL.items() if k != "blocks"} | {
        "drop_sources": [source],
        "output": {"frames": 2, "series_every": 10},
    }
    a = read_attrs(run(Settings.model_validate(rain), tmp_path / "r.h5", seed=1, progress=False))
    dt, steps = 2e-5, a["steps"]
    t_k = np.arange(0.0, 0.02 + 1e-12, 0.002)[: a["n_particles"]]
    expected = np.sum(np.round((0.03 - t_k) / dt))
    assert abs(a["particle_steps"] - expected) <= len(t_k) * 10
    assert a["particle_steps"] < 0.7 * a["n_particles"] * steps


def test_a_step_past_the_damping_bound_is_named_once_on_the_console(tmp_path, capsys):
    default = Settings.model_validate(SMALL | {"duration_s": 0.002, "dt_s": None})
    past = Settings.model_validate(SMALL | {"duration_s": 0.002})  # c dt 0.29, c_t dt 0.17 under Gear
    run(default, tmp_path / "default.h5", progress=False)
    assert "granular.dt_s" not in capsys.readouterr().err
    run(past, tmp_path / "past.h5", progress=False)
    lines = [x for x in capsys.readouterr().err.splitlines() if "granular.dt_s" in x]
    assert len(lines) == 1 and lines[0].startswith("porepipe: granular.dt_s = 2e-05 s is past")


def test_result_independent_of_checkpoint_interval(tmp_path):
    """checkpoint_every_steps is run control (porepipe._shared.run_control): another interval, with a checkpoint
    file given, ends in the same frames bit for bit and the same result hash."""
    results = []
    for every in (400, 137):
        settings = Settings.model_validate({**SMALL, "checkpoint_every_steps": every})
        out = tmp_path / f"g{every}.h5"
        run(settings, out, seed=1, scene="small", progress=False, checkpoint=tmp_path / f"c{every}.npz")
        results.append((read_granular(out)["frames"], read_attrs(out)["scene_hash"]))
    (frames_a, hash_a), (frames_b, hash_b) = results
    assert hash_a == hash_b
    for name in ("position_m", "velocity_m_s", "angular_velocity_rad_s"):
        np.testing.assert_array_equal(frames_a[name].values, frames_b[name].values)
