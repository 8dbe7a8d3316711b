"""Packings that report convergence satisfy §5.1 (checked by an all-pairs scan), keep their radius distribution,
and are reproducible: same seed -> same packing, checkpoint -> resume -> same packing."""

import sys
from pathlib import Path

import h5py
import numba
import numpy as np
import pytest
import xarray as xr
from scipy import stats

from porepipe._shared.store import ResultWriter
from porepipe.packing import Settings, pack_spheres, read_packing, write_packing, write_xyzr_file
from porepipe.packing._api import HISTORY_TIMING

sys.path.insert(0, str(Path(__file__).parents[1] / "unit" / "packing"))
from naive_packing import max_overlaps

BOX = [600.0, 600.0, 600.0]
EXP = {"dist": "exponential", "min_um": 40, "max_um": 80, "alpha_per_um": 0.05}


def _settings(n=150, adapt=True, steps=600, **extra):
    stage = {
        "name": "one",
        "insert": ["a"],
        "steps": steps,
        "dt": 0.25,
        "k": {"a": 400},
        "damping": {"a": 4},
        "freezing": {"lock_step": 10},
        "stochastic_forces": {"step_size": 0.05},
    }
    if adapt:
        stage["adaptive_radii"] = {
            "types": ["a"],
            "trigger": 0.2,
            "rate": 0.01,
            "from_step": 20,
            "to_step": steps - 50,
            "quiet_steps": 10,
        }
    return Settings.model_validate(
        {
            "types": [{"name": "a", "count": n, "radius_um": EXP, "max_overlap": 0.3}],
            "stages": [stage],
            **extra,
        }
    )


def _assert_valid_packing(p, sigma_max):
    ref = max_overlaps(p.centres_um, p.radii_um, p.box_um, p.periodic)
    # the brute-force scan agrees with the engine's per-sphere max overlap to round-off (1e-12 relative)
    np.testing.assert_allclose(p.max_overlap, ref, rtol=1e-12)
    assert np.all((ref > 0) & (ref <= sigma_max))


@pytest.mark.parametrize("seed", [0, 1])
def test_converged_packing_satisfies_overlap_window(seed):
    p = pack_spheres(_settings(), BOX, True, seed=seed)
    assert p.all_converged
    assert p.history["converged"][-1] == p.radii_um.size == 150
    _assert_valid_packing(p, 0.3)


def test_radius_distribution_kept_without_adaptive_radii():
    # Without adaptive radii, 80 spheres in this box converge within the 600 steps for seeds 0, 1, 3, 5, 6, 7 of 0..7
    # (porepipe._shared.rng streams); seeds 2 and 4 end with 2 isolated spheres at the step limit. The test is about
    # the radius distribution of a converged packing, so it uses seed 0 (it used seed 2 under the old streams).
    p = pack_spheres(_settings(n=80, adapt=False), BOX, True, seed=0)
    assert p.all_converged
    _assert_valid_packing(p, 0.3)
    lo, hi, a = 40.0, 80.0, 0.05

    def cdf(r):
        r = np.clip(r, lo, hi)
        return (np.exp(-a * lo) - np.exp(-a * r)) / (np.exp(-a * lo) - np.exp(-a * hi))

    # KS at the 0.1 % level (80 radii): a correct pipeline fails one seed in a thousand
    assert stats.kstest(p.radii_um, cdf).pvalue > 1e-3


def test_same_seed_same_packing_and_other_seed_differs():
    a = pack_spheres(_settings(), BOX, True, seed=5)
    b = pack_spheres(_settings(), BOX, True, seed=5)
    c = pack_spheres(_settings(), BOX, True, seed=6)
    np.testing.assert_array_equal(a.centres_um, b.centres_um)
    np.testing.assert_array_equal(a.radii_um, b.radii_um)
    assert not np.array_equal(a.centres_um, c.centres_um)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs at least 2 numba threads to compare")
def test_one_and_two_threads_give_the_same_packing():
    """Pair forces are summed in a fixed order (slab colours one after the other, spheres in order within a slab)
    and the step reductions run over fixed chunks, so the thread count does not change a single bit (parallel_min_spheres = 0 forces the parallel kernels on)."""
    settings = _settings(n=150, parallel_min_spheres=0)
    runs = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        try:
            runs.append(pack_spheres(settings, BOX, True, seed=9))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    np.testing.assert_array_equal(runs[0].centres_um, runs[1].centres_um)
    np.testing.assert_array_equal(runs[0].radii_um, runs[1].radii_um)
    np.testing.assert_array_equal(runs[0].history["kinetic_energy"], runs[1].history["kinetic_energy"])


def test_checkpoint_resume_is_bit_identical(tmp_path, monkeypatch):
    import porepipe.packing._api as engine  # the name the engine calls (it imports _io's save_checkpoint at the top)

    settings = _settings(checkpoint_every=7)
    ref = pack_spheres(settings, BOX, True, seed=3)
    assert ref.stage_steps[0] > 28
    ck = tmp_path / "ck.h5"
    real_save = engine.save_checkpoint

    def save_then_die(path, state, key, clock):
        real_save(path, state, key, clock)
        if state.step >= 28:
            raise KeyboardInterrupt("simulated kill after the checkpoint of step 28")

    monkeypatch.setattr(engine, "save_checkpoint", save_then_die)
    with pytest.raises(KeyboardInterrupt):
        pack_spheres(settings, BOX, True, seed=3, checkpoint_path=ck)
    monkeypatch.setattr(engine, "save_checkpoint", real_save)
    with h5py.File(ck) as f:
        assert f.attrs["step"] == 28
        spent = float(f.attrs["spent_wall_s"]), float(f.attrs["spent_cpu_s"])  # the killed run's cost to it
    resumed = pack_spheres(settings, BOX, True, seed=3, checkpoint_path=ck, resume=True)
    assert resumed.carried == spent and spent[1] > 0  # the result's writer adds it to wall_s / cpu_s
    assert not ck.exists()  # a finished run deletes its checkpoint
    np.testing.assert_array_equal(resumed.centres_um, ref.centres_um)
    np.testing.assert_array_equal(resumed.radii_um, ref.radii_um)
    for key in set(ref.history) - set(HISTORY_TIMING):  # wall_s is the machine's, not the packing's
        np.testing.assert_array_equal(resumed.history[key], ref.history[key])
    assert (resumed.history["wall_s"] > 0).all()


def test_two_stage_fill_keeps_frozen_matrix_and_writes_result(tmp_path):
    settings = Settings.model_validate(
        {
            "types": [
                {"name": "big", "count": 60, "radius_um": EXP, "max_overlap": 0.3},
                {
                    "name": "small",
                    "count": 300,
                    "radius_um": {"min_um": 8, "max_um": 12, "initial_um": 12},
                    "max_overlap": 0.25,
                },
            ],
            "stages": [
                {
                    "name": "primary",
                    "insert": ["big"],
                    "steps": 400,
                    "dt": 0.25,
                    "k": {"big": 400},
                    "damping": {"big": 4},
                    "freezing": {"lock_step": 10},
                    "stochastic_forces": {"step_size": 0.05},
                    "adaptive_radii": {
                        "types": ["big"],
                        "trigger": 0.2,
                        "rate": 0.01,
                        "from_step": 20,
                        "to_step": 350,
                    },
                },
                # the protocol of §5.6.1 phase 2 (k ramps, damping ramp, radius window), plus deletion of the
                # unconverged fines at the end
                {
                    "name": "fill",
                    "insert": ["small"],
                    "steps": 800,
                    "dt": 0.25,
                    "frozen_types": ["big"],
                    "k": {
                        "big": {"start": 400, "end": 1, "from_step": 20, "to_step": 25},
                        "small": {"start": 1, "end": 20, "from_step": 25, "to_step": 40},
                    },
                    "damping": {"big": 1, "small": {"start": 1, "end": 2, "from_step": 30, "to_step": 40}},
                    "freezing": {"lock_step": 20},
                    "stochastic_forces": {"step_size": 0.05},
                    "adaptive_radii": {
                        "types": ["small"],
                        "trigger": 0.2,
                        "rate": 0.02,
                        "from_step": 50,
                        "to_step": 700,
                    },
                    "delete_unconverged": ["small"],
                },
            ],
        }
    )
    p = pack_spheres(settings, BOX, True, seed=4)
    primary = p.snapshots[0]
    assert p.stage_converged[0]
    big = p.types == 0
    # stage 2 froze the matrix: the big spheres did not move at all
    np.testing.assert_array_equal(p.centres_um[big], primary["centres_um"])
    assert p.all_converged
    ref = max_overlaps(p.centres_um, p.radii_um, p.box_um, p.periodic)
    sig_t = np.array([0.3, 0.25])[p.types]
    assert np.all((ref > 0) & (ref <= sig_t))
    small = p.radii_um[~big]
    assert small.size > 100 and small.min() >= 8 and small.max() <= 12
    # effects recorded per step: stage 2 rows carry the frozen_types bit
    assert np.all(p.history["effects"][p.history["stage"] == 1] & 16)

    out = tmp_path / "packing.h5"
    with ResultWriter(out, stage="pack", scene="t", scene_hash="x") as w:
        write_packing(w, p)
    back = read_packing(out)
    np.testing.assert_array_equal(back["centres_um"], p.centres_um)
    assert back["types"].dtype == np.int32 and back["all_converged"]
    hist = xr.open_dataset(out, engine="h5netcdf", group="history", phony_dims="sort").load()
    np.testing.assert_array_equal(hist["converged"].values, p.history["converged"])
    xyzr = tmp_path / "p.xyzr"
    write_xyzr_file(xyzr, p)
    np.testing.assert_array_equal(np.loadtxt(xyzr), np.column_stack([p.centres_um, p.radii_um]))
