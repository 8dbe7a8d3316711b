"""The stage's file door: binary volume in, xarray-readable result out; units; thread-count independence;
checkpoint/resume; the CLI."""

import math
import warnings

import numpy as np
import pytest
import xarray as xr

from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import ResultWriter, read_attrs
from porepipe.cli import main as cli_main
from porepipe.diffusion import Settings, mean_speed, square_capillary, transport
from porepipe.diffusion._run import run
from porepipe.diffusion._species import jiffie_s

SMALL = Settings(batches=8, batch_particles=100, max_rounds=2, target_rel_error=1e-6)


def _binary(path, pore, voxel_um=0.01, periodic=(0, 0, 0)):
    with ResultWriter(path, stage="segment", scene="t", scene_hash="abc") as w:
        w.write_volume("pore", pore, voxel_um=voxel_um, periodic=periodic)
    return path


def test_thesis_units():
    """Digest §13.1: v̄(N2, 298 K) = 474.7 m/s; with 10 nm voxels one jiffie is 21.07 ps."""
    v = mean_speed("N2", 298.0)
    # the digest's 474.7 uses M = 28.0 g/mol; with 28.013 g/mol v̄ is sqrt(28/28.013) = 0.99977 times that
    assert v == pytest.approx(474.7 * math.sqrt(28.0 / 28.013), abs=0.01)
    assert jiffie_s(10e-9, v) == pytest.approx(21.07e-12, rel=5e-4)


def test_run_writes_readable_result_with_cost(tmp_path):
    binary = _binary(tmp_path / "binary_a0.01.h5", square_capillary(6, 30).pore)
    out = run(SMALL, binary, tmp_path / "d.h5", "z", seed=3, scene="t", threads=1)
    ds = xr.open_dataset(out, engine="h5netcdf")
    attrs = read_attrs(out)
    for key in ("wall_s", "cpu_s", "peak_mb", "threads", "scene_hash"):
        assert key in attrs
    assert attrs["stage"] == "diffusion" and attrs["axis"] == "z"
    w = float(ds["W"])
    assert 0 < w < 1 and float(ds["W_err"]) > 0
    # D = v̄ L W / 4 with L = 30 voxels of 10 nm and v̄ of N2 at the default 298.15 K
    vbar = mean_speed("N2", 298.15)
    assert float(ds["D_m2_s"]) == pytest.approx(vbar * 30 * 0.01e-6 * w / 4, rel=1e-12)
    assert ds["concentration"].dims == ("axial_bin",)
    assert "tortuosity" in ds and "definitions" in ds.attrs
    assert all(math.isfinite(float(ds[k])) for k in ds.data_vars if ds[k].ndim == 0)
    assert not (tmp_path / ".d.h5.checkpoint.npz").exists()


def test_nothing_transmitted_gives_finite_errors_not_nan():
    """A run in which no particle gets through (a long tube, one round of a few particles): W = 0 and Ψ = 0 with
    finite errors (Ψ's from D_eff's absolute error; it was 0 x inf = nan, with a RuntimeWarning), τ = inf."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        v = transport(
            square_capillary(4, 200).pore, 2, Settings(batches=2, batch_particles=2, max_rounds=1), seed=1
        )
    v = v.values
    assert v["W"] == 0.0 and v["psi"] == 0.0
    for k in ("psi_err", "labyrinth_factor_err"):
        assert math.isfinite(v[k]) and v[k] >= 0.0
    assert v["tortuosity"] == math.inf and v["tortuosity_err"] == math.inf


def test_errors_of_psi_chi_and_tau_are_those_of_d_eff():
    """Where something is transmitted: Ψ and χ carry D_eff's relative error, τ = ε/Ψ the same relative error."""
    v = transport(square_capillary(5, 40).pore, 2, SMALL, seed=9).values
    rel = v["D_eff_err"] / v["D_eff"]
    for k in ("psi", "labyrinth_factor", "tortuosity"):
        assert v[f"{k}_err"] == pytest.approx(v[k] * rel, rel=1e-12)


def test_same_numbers_for_one_and_two_threads():
    pore = square_capillary(5, 40).pore
    rows = []
    for threads in (1, 2):
        set_threads(threads)
        rows.append(transport(pore, 2, SMALL, seed=9).tallies.rows)
    set_threads(None)
    np.testing.assert_array_equal(rows[0], rows[1])


def test_checkpoint_resume_gives_the_same_numbers(tmp_path):
    pore = square_capillary(5, 40).pore
    ck = tmp_path / "ck.npz"
    full = transport(pore, 2, SMALL.model_copy(update={"max_rounds": 3}), seed=4).tallies.rows
    transport(
        pore, 2, SMALL.model_copy(update={"max_rounds": 3}), seed=4, checkpoint=ck
    )  # writes ck per round
    # pretend the run was killed after round 1: keep only that much, then resume to 3 rounds
    z = dict(np.load(ck))
    assert float(z["spent_cpu_s"]) > 0 and float(z["spent_wall_s"]) > 0  # what the run spent up to it
    z["rows"], z["rounds"] = z["rows"][:8], np.array(1)
    z["spent_wall_s"], z["spent_cpu_s"] = (
        np.array(7.5),
        np.array(3.25),
    )  # the killed process's cost to round 1
    np.savez(ck, **z)
    tallies = transport(pore, 2, SMALL.model_copy(update={"max_rounds": 3}), seed=4, checkpoint=ck).tallies
    np.testing.assert_array_equal(full, tallies.rows)
    assert tallies.carried == (7.5, 3.25)  # the result's writer adds it to wall_s / cpu_s
    # a checkpoint of another input (other seed) is discarded, not mixed in
    other = transport(pore, 2, SMALL.model_copy(update={"max_rounds": 3}), seed=5, checkpoint=ck).tallies
    assert other.rounds == 3 and not np.array_equal(other.rows, full)


def test_cli_end_to_end_and_bad_input(tmp_path, capsys):
    binary = _binary(tmp_path / "binary_a1.h5", square_capillary(4, 20).pore, voxel_um=1.0)
    args = "--axis z --batches 4 --batch-particles 200 --max-rounds 1 --wall-law isotropic --threads 1"
    rc = cli_main(["diffusion", str(binary), *args.split(), "--hit-map-bins", "4", "--orientation-bins", "3"])
    assert rc == 0
    out = tmp_path / "diffusion_a1_z.h5"
    assert out.is_file() and "W = " in capsys.readouterr().out
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert ds.attrs["settings"].count("isotropic") == 1
    # every wall hit is on a lateral face (a straight channel has no wall normal to z); the four lateral faces
    # share them alike (4 σ of a multinomial count); every flight is in the orientation histogram
    per_face = ds["hit_map"].sum(dim=("map_a", "map_b")).values
    assert per_face.sum() == int(ds["wall_hits"]) and per_face[4] == per_face[5] == 0
    mean = per_face[:4].mean()
    assert np.all(np.abs(per_face[:4] - mean) < 4 * np.sqrt(mean))
    assert int(ds["orientation"].sum()) == int(ds["flights"])
    solid = _binary(tmp_path / "solid_a1.h5", np.zeros((3, 3, 3), np.uint8))
    rc = cli_main(["diffusion", str(solid), "-o", str(tmp_path / "x.h5")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "all solid" in err[0]
    assert not list(tmp_path.glob("x.h5*")) and not list(tmp_path.glob(".x.h5*"))
    rc = cli_main(["diffusion", str(binary), "--accommodation", "1.5", "-o", str(tmp_path / "y.h5")])
    assert rc == 2 and "accommodation" in capsys.readouterr().err


@pytest.mark.parametrize(
    "setup,pore,periodic",
    [
        ("transmission", square_capillary(4, 12).pore, (0, 0, 0)),
        ("wicke_kallenbach", square_capillary(4, 12).pore, (0, 0, 0)),
        ("msd", np.pad(np.ones((4, 4, 4), np.uint8), ((1, 1), (1, 1), (0, 0))), (0, 0, 1)),
    ],
)
def test_a_run_stopped_by_max_rounds_says_the_target_was_not_met(tmp_path, capsys, setup, pore, periodic):
    """Two rounds against a target of 1e-6: the progress line said 'stopped by a limit', but the summary line on
    stdout and the result file did not; now both say the target was not met and that max_rounds stopped it."""
    binary = _binary(tmp_path / "binary_a0.01.h5", pore, periodic=periodic)
    out = tmp_path / "d.h5"
    tiny = ["--setup", setup, "--batches", "4", "--batch-particles", "20", "-o", str(out)]
    assert cli_main(["diffusion", str(binary), *tiny, "--max-rounds", "2", "--target-rel-error", "1e-6"]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    attrs = read_attrs(out)
    assert attrs["target_met"] == 0 and attrs["stopped_by"] == "max_rounds"
    assert attrs["rel_error"] > 1e-6 and math.isfinite(attrs["rel_error"])
    assert f"target NOT met: relative error {attrs['rel_error']:.2g} > target_rel_error 1e-06" in line
    assert "stopped by max_rounds = 2 -> " in line
    # a target the two rounds meet: said by the attributes, and no word on the line
    assert cli_main(["diffusion", str(binary), *tiny, "--target-rel-error", "0.9"]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    attrs = read_attrs(out)
    assert attrs["target_met"] == 1 and attrs["stopped_by"] == "target_rel_error" and "NOT met" not in line


def test_a_length_series_records_the_stop_of_each_length(tmp_path, capsys):
    """A length series runs one transmission per length: the result's attributes list what stopped each, and the
    table holds series_target_met and series_rel_error per length."""
    binary = _binary(tmp_path / "binary_a0.01.h5", square_capillary(3, 12).pore)
    settings = Settings(lengths=[3, 12], batches=4, batch_particles=20, max_rounds=2, target_rel_error=1e-6)
    out = run(settings, binary, tmp_path / "d.h5", "z", seed=1)
    attrs = read_attrs(out)
    assert attrs["target_met"] == 0 and attrs["stopped_by"] == "max_rounds,max_rounds"
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert ds["series_target_met"].values.tolist() == [0.0, 0.0]
    assert float(ds["series_rel_error"].max()) == pytest.approx(attrs["rel_error"], rel=1e-12)
    ds.close()
