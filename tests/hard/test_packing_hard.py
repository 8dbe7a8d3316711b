"""Degenerate and extreme packing inputs: finite answers or a clear PorepipeError."""

import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from pydantic import ValidationError

from porepipe._shared.errors import PorepipeError
from porepipe.packing import Settings, build_neighbours, pack_spheres, sphere_overlaps
from porepipe.packing._api import check_damping

sys.path.insert(0, str(Path(__file__).parents[1] / "unit" / "packing"))
from naive_packing import neighbour_pairs


def _one_type(count=20, rmin=40.0, rmax=60.0, **stage):
    st = {
        "name": "s",
        "insert": ["a"],
        "steps": 50,
        "dt": 0.25,
        "k": {"a": 400},
        "damping": {"a": 4},
        **stage,
    }
    return Settings.model_validate(
        {
            "types": [{"name": "a", "count": count, "radius_um": {"min_um": rmin, "max_um": rmax}}],
            "stages": [st],
        }
    )


def test_coincident_centres_separate_to_equilibrium():
    from test_dynamics import Run  # the bare kernel driver of the unit tests

    run = Run([[50.0, 50, 50], [50.0, 50, 50]], [10.0, 10.0], [0, 0], [200.0] * 3, [100.0], [0.3], [1.0], 0.1)
    for _ in range(1500):
        run.step()
    assert np.isfinite(run.x).all()
    # they leave along the tie-break direction and settle at dx_eq = 20 - 0.15 * 20 = 17 µm
    assert np.linalg.norm(run.x[1] - run.x[0]) == pytest.approx(17.0, rel=1e-6)


def test_sphere_far_from_all_others_is_finite_and_unconverged():
    x = np.array([[10.0, 10, 10], [30.0, 10, 10], [150.0, 150, 150]])
    r = np.array([10.0, 10.0, 5.0])
    sig, conv = sphere_overlaps(x, r, np.zeros(3, np.int64), [300.0] * 3, [True] * 3, [0.3])
    np.testing.assert_array_equal(sig, [0.0, 0.0, -np.inf])  # the pair touches exactly: sigma = 0
    np.testing.assert_array_equal(conv, [0, 0, 0])
    # a lone sphere in a run: no force, it stays put without stochastic forces and the run ends unconverged
    p = pack_spheres(_one_type(count=1, rmin=5, rmax=5), [300.0] * 3, True, seed=0)
    assert not p.all_converged and np.isfinite(p.centres_um).all()
    assert p.max_overlap[0] == -np.inf


def test_radius_ratio_100_to_1_neighbour_search_scales():
    rng = np.random.default_rng(1)
    box = np.array([200.0, 200.0, 200.0])
    r = np.concatenate([np.full(4, 50.0), np.full(30000, 0.5)])
    x = rng.random((r.size, 3)) * box
    types = np.zeros(r.size, np.int64)
    build_neighbours(x, r, types, box, np.ones(3, bool), np.ones((1, 1), np.uint8), 1.3, 0.15)  # compile
    t0 = time.perf_counter()
    start, idx = build_neighbours(x, r, types, box, np.ones(3, bool), np.ones((1, 1), np.uint8), 1.3, 0.15)
    elapsed = time.perf_counter() - t0
    # all-pairs work would be 4.5e8 distance tests (> 1 s even compiled); the class grids need ~1e6. 2 s leaves
    # room for a loaded shared machine
    assert elapsed < 2.0
    sub = np.concatenate([np.arange(4), rng.choice(np.arange(4, r.size), 300, replace=False)])
    ref = neighbour_pairs(x[sub], r[sub], box, np.ones(3, bool), 1.3, 0.15)
    got = {
        (a, b)
        for a in range(sub.size)
        for b in range(a + 1, sub.size)
        if sub[b] in set(idx[start[sub[a]] : start[sub[a] + 1]].tolist())
    }
    assert got == ref


def test_box_smaller_than_two_largest_radii_is_refused():
    with pytest.raises(PorepipeError, match=r"smaller than 2 R_max"):
        pack_spheres(_one_type(count=3), [100.0, 300.0, 300.0], True, seed=0)
    with pytest.raises(PorepipeError, match=r"interaction reach"):
        pack_spheres(_one_type(count=3), [200.0, 300.0, 300.0], True, seed=0)


def test_damping_at_and_beyond_the_limit():
    # Xi = 2/dt exactly is allowed (C- = 0: overdamped first-order relaxation) and stays finite
    p = pack_spheres(_one_type(count=15, damping={"a": 8.0}), [400.0] * 3, True, seed=1)
    assert np.isfinite(p.centres_um).all()
    with pytest.raises(ValidationError, match="exceeds 2/dt"):
        _one_type(damping={"a": 8.0001})
    with pytest.raises(PorepipeError, match="exceeds 2/dt"):
        check_damping(np.array([1.0, 9.0]), 0.25, "test")


def test_zero_spheres_of_a_type_and_empty_stage():
    settings = Settings.model_validate(
        {
            "types": [
                {"name": "a", "count": 30, "radius_um": {"min_um": 40, "max_um": 60}},
                {"name": "b", "count": 0, "radius_um": {"min_um": 1, "max_um": 2}},
            ],
            "stages": [
                {
                    "name": "s",
                    "insert": ["a", "b"],
                    "steps": 30,
                    "dt": 0.25,
                    "k": {"a": 400},
                    "damping": {"a": 4},
                }
            ],
        }
    )
    p = pack_spheres(settings, [600.0] * 3, True, seed=0)
    assert p.radii_um.size == 30 and np.all(p.types == 0)
    empty = settings.model_copy(update={"stages": [settings.stages[0].model_copy(update={"insert": ["b"]})]})
    q = pack_spheres(empty, [600.0] * 3, True, seed=0)
    assert q.radii_um.size == 0 and q.all_converged


def test_runaway_time_step_stops_with_a_message():
    with pytest.raises(PorepipeError, match=r"step \d+: (runaway sphere|non-finite).*dt = 3"):
        pack_spheres(_one_type(count=60, dt=3.0, damping={"a": 0.1}, steps=200), [400.0] * 3, True, seed=0)


def test_bad_settings_name_the_key():
    with pytest.raises(ValidationError, match="unknown type"):
        Settings.model_validate(
            {
                "types": [{"name": "a", "count": 1, "radius_um": {"min_um": 1, "max_um": 2}}],
                "stages": [{"insert": ["b"]}],
            }
        )
    with pytest.raises(ValidationError, match="exactly one of count"):
        Settings.model_validate({"types": [{"name": "a", "radius_um": {"min_um": 1, "max_um": 2}}]})
    with pytest.raises(PorepipeError, match="at least one"):
        pack_spheres(Settings(), [10.0] * 3)


def test_neighbour_search_refuses_centres_outside_a_periodic_box():
    """The minimum image assumes coordinates in [0, L): a centre at L or beyond is an error naming the axis, not a
    silently wrong list; sphere_overlaps wraps user coordinates itself and gives the wrapped answer."""
    x = np.array(
        [[10.0, 10, 10], [310.0, 10, 10]]
    )  # the second is the first's neighbour at x = 10 after wrapping
    r = np.array([6.0, 6.0])
    with pytest.raises(PorepipeError, match="periodic axis x span"):
        build_neighbours(
            x,
            r,
            np.zeros(2, np.int64),
            np.full(3, 300.0),
            np.ones(3, bool),
            np.ones((1, 1), np.uint8),
            1.3,
            0.0,
        )
    sig, _ = sphere_overlaps(x, r, np.zeros(2, np.int64), [300.0] * 3, [True] * 3, [0.3])
    np.testing.assert_array_equal(sig, [1.0, 1.0])  # coincident after wrapping: sigma = 2r / 2r


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
@pytest.mark.parametrize("key", ["initial_velocity", "adaptive trigger"])
def test_non_finite_settings_are_refused_by_the_schema(key, value):
    # before: a NaN initial velocity validated and the run then blamed dt (issue 20, item 8)
    raw = _one_type().model_dump(mode="python")
    if key == "initial_velocity":
        raw["initial_velocity"] = (0.0, value, 0.0)
        where = "initial_velocity"
    else:
        raw["stages"][0]["adaptive_radii"] = {"types": ["a"], "trigger": value}
        where = "trigger"
    with pytest.raises(ValidationError, match=rf"{where}[\s\S]*finite number"):
        Settings.model_validate(raw)


def test_changed_settings_discard_the_old_checkpoint_and_success_deletes_it(tmp_path, capsys):
    # issue 20, item 1: a changed scene resumed the old checkpoint and wrote its spheres under the new hash
    from porepipe.packing._api import checkpoint_key
    from porepipe.packing._io import save_checkpoint
    from porepipe.packing._types import State

    box = np.array([400.0, 400.0, 400.0])
    old = _one_type(count=12).model_copy(update={"checkpoint_every": 5})
    new = _one_type(count=20).model_copy(update={"checkpoint_every": 5})
    ckpt = tmp_path / "ckpt.h5"
    pack_spheres(old, box, seed=1, checkpoint_path=ckpt)
    assert not ckpt.exists()  # deleted on success (before: kept forever)
    # the checkpoint of a killed run of the old scene, then the new scene run with resume (as pack.smk does)
    save_checkpoint(ckpt, State.empty(), key=checkpoint_key(old, box, np.array([True] * 3), 1, Path(".")))
    resumed = pack_spheres(new, box, seed=2, checkpoint_path=ckpt, resume=True)
    assert "discarding checkpoint" in capsys.readouterr().err
    fresh = pack_spheres(new, box, seed=2)
    np.testing.assert_array_equal(
        resumed.centres_um, fresh.centres_um
    )  # the new scene's spheres, not the old ones
    assert len(resumed.radii_um) == 20
    assert not ckpt.exists()


def test_a_resumed_packing_carries_the_cost_its_checkpoint_records(tmp_path):
    """A resumed run's cost includes what the earlier processes spent up to the checkpoint (written with it); a
    checkpoint written before that record resumes with the earlier cost unknown (NaN), a fresh run carries none."""
    from porepipe._shared.cost import SpentClock
    from porepipe.packing._api import checkpoint_key
    from porepipe.packing._io import save_checkpoint
    from porepipe.packing._types import State

    box, settings = np.array([400.0] * 3), _one_type(count=12)
    key = checkpoint_key(settings, box, np.array([True] * 3), 1, Path("."))
    ckpt = tmp_path / "ckpt.h5"
    save_checkpoint(ckpt, State.empty(), key=key, clock=SpentClock((40.0, 30.0)))
    with h5py.File(ckpt, "r") as f:
        spent = float(f.attrs["spent_wall_s"]), float(f.attrs["spent_cpu_s"])
    assert 40.0 <= spent[0] < 41.0 and 30.0 <= spent[1] < 31.0
    assert pack_spheres(settings, box, seed=1, checkpoint_path=ckpt, resume=True).carried == spent
    save_checkpoint(ckpt, State.empty(), key=key)  # no cost recorded
    assert np.isnan(pack_spheres(settings, box, seed=1, checkpoint_path=ckpt, resume=True).carried).all()
    assert pack_spheres(settings, box, seed=1).carried == (0.0, 0.0)


def test_matching_checkpoint_still_resumes(tmp_path):
    from porepipe.packing._api import checkpoint_key

    settings = _one_type(count=12)
    key = checkpoint_key(settings, np.array([400.0] * 3), np.array([True] * 3), 1, Path("."))
    assert key == checkpoint_key(
        settings.model_copy(update={"checkpoint_every": 7}),
        np.array([400.0] * 3),
        np.array([True] * 3),
        1,
        Path("."),
    )  # run control does not enter the key
    assert key != checkpoint_key(settings, np.array([400.0] * 3), np.array([True] * 3), 2, Path("."))


@pytest.mark.parametrize(
    "change, match",
    [
        ({"x": [[np.nan, 10, 10], [25, 10, 10]]}, "must be finite"),  # before: a segmentation fault
        ({"r": [8.0]}, r"radii need shape \(2,\)"),  # before: a segmentation fault
        ({"r": [8.0, 0.0]}, "sphere 1 has radius 0.0"),
        ({"types": [0, 3]}, r"types span 0..3, outside 0..0"),  # before: read past the type tables
        ({"types": [0]}, r"types need \(2,\) integers"),
        ({"sig": [np.nan]}, "max_overlap_t needs one finite value per type"),
        ({"box": [20.0, 100, 100]}, "too small for the interaction reach"),  # before: sigma of its own image
        ({"periodic": [True, True]}, "periodic must be one flag or 3"),
    ],
)
def test_sphere_overlaps_refuses_what_the_kernels_cannot_read(change, match):
    args = {
        "x": [[10.0, 10, 10], [25.0, 10, 10]],
        "r": [8.0, 8.0],
        "types": [0, 0],
        "box": [100.0] * 3,
        "periodic": [True] * 3,
        "sig": [0.3],
    }
    args.update(change)
    x, r, types, box, periodic, sig = (np.asarray(args[k]) for k in args)
    with pytest.raises(PorepipeError, match=match):
        sphere_overlaps(x, r, types, box, periodic, sig)


def test_neighbour_search_refuses_a_type_outside_pair_on():
    x, r = np.array([[10.0, 10, 10], [25.0, 10, 10]]), np.array([8.0, 8.0])
    with pytest.raises(PorepipeError, match=r"types span 0..1, outside 0..0"):
        build_neighbours(
            x, r, np.array([0, 1]), np.full(3, 100.0), np.ones(3, bool), np.ones((1, 1), np.uint8), 1.0, 0.0
        )
