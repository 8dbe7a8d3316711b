"""The run layer of permeability: --checkpoint F / --resume, refused incomplete volumes, unknown collisions."""

from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_attrs
from porepipe.cli import main
from porepipe.lbm import Settings
from porepipe.lbm._solver import make_stepper


def _binary(tmp_path):
    """A slit 6 voxels wide between two walls (z), 4 long in x: converges in a few hundred steps."""
    pore = np.zeros((4, 2, 8), dtype=np.uint8)
    pore[:, :, 1:-1] = 1
    path = tmp_path / "binary_a2.h5"
    with ResultWriter(path, stage="segment", scene="t", scene_hash="h") as w:
        w.write_volume("pore", pore, voxel_um=2.0)
    return path


def test_checkpoint_flag_is_written_on_the_step_limit_and_resumed(tmp_path):
    binary, ckpt, out = _binary(tmp_path), tmp_path / "perm.ckpt.h5", tmp_path / "perm_a2_x.h5"
    common = [
        str(binary),
        "--axis",
        "x",
        "--collision",
        "trt",
        "--window-steps",
        "10",
        "-o",
        str(out),
        "--checkpoint",
        str(ckpt),
    ]
    assert main(["permeability", *common, "--max-steps", "20"]) == 2  # step limit: error, no result ...
    assert not out.exists() and ckpt.is_file()  # ... but the checkpoint is kept
    with h5py.File(ckpt, "r") as f:
        first = int(f.attrs["step"])
        spent_wall, spent_cpu = float(f.attrs["spent_wall_s"]), float(f.attrs["spent_cpu_s"])
    assert first >= 20
    assert spent_wall > 0 and spent_cpu > 0  # what the interrupted process spent stepping to its checkpoint
    assert main(["permeability", *common, "--resume"]) == 0
    assert out.is_file() and not ckpt.exists()  # converged: checkpoint deleted
    history = read_attrs(out)
    assert history["steps"] > first
    # the result's cost counts the interrupted process too: its solver time is carried over and recorded
    assert history["resumed_step"] == first
    assert (history["resumed_wall_s"], history["resumed_cpu_s"]) == (spent_wall, spent_cpu)
    assert history["cpu_s"] > spent_cpu and history["wall_s"] > spent_wall


def test_a_checkpoint_without_its_cost_resumes_with_the_earlier_cost_marked_unknown(tmp_path):
    """A checkpoint written before checkpoints recorded their cost: the run resumes, its result says the earlier
    cost is not known (NaN) and counts its own."""
    binary, ckpt, out = _binary(tmp_path), tmp_path / "perm.ckpt.h5", tmp_path / "perm_a2_x.h5"
    common = [str(binary), "--axis", "x", "--window-steps", "10", "-o", str(out), "--checkpoint", str(ckpt)]
    assert main(["permeability", *common, "--max-steps", "20"]) == 2
    with h5py.File(ckpt, "a") as f:
        del f.attrs["spent_wall_s"], f.attrs["spent_cpu_s"]
    assert main(["permeability", *common, "--resume"]) == 0
    attrs = read_attrs(out)
    assert attrs["resumed_step"] >= 20
    assert np.isnan(attrs["resumed_cpu_s"]) and np.isnan(attrs["resumed_wall_s"])
    assert np.isfinite(attrs["cpu_s"]) and attrs["cpu_s"] > 0


def test_a_fresh_run_records_no_earlier_cost(tmp_path):
    binary, out = _binary(tmp_path), tmp_path / "perm_a2_x.h5"
    assert main(["permeability", str(binary), "--axis", "x", "-o", str(out), "--no-resume"]) == 0
    attrs = read_attrs(out)
    assert attrs["resumed_step"] == 0 and "resumed_cpu_s" not in attrs


def test_no_resume_discards_the_checkpoint(tmp_path):
    binary, ckpt, out = _binary(tmp_path), tmp_path / "c.h5", tmp_path / "perm_a2_x.h5"
    ckpt.write_text("not a checkpoint of this run")
    assert (
        main(
            [
                "permeability",
                str(binary),
                "--axis",
                "x",
                "--collision",
                "trt",
                "-o",
                str(out),
                "--checkpoint",
                str(ckpt),
                "--no-resume",
            ]
        )
        == 0
    )
    assert out.is_file() and not ckpt.exists()


def test_checkpoint_with_several_axes_is_refused(tmp_path):
    binary = _binary(tmp_path)
    assert (
        main(["permeability", str(binary), "--axis", "x", "--axis", "y", "--checkpoint", str(tmp_path / "c")])
        == 2
    )


def test_volume_without_voxel_size_is_refused_not_assumed(tmp_path, capsys):
    binary = _binary(tmp_path)
    with h5py.File(binary, "a") as f:
        del f["volumes/pore"].attrs["voxel_um"]
    assert main(["permeability", str(binary), "--axis", "x", "-o", str(tmp_path / "p.h5")]) == 2
    assert "binary_a2.h5" in capsys.readouterr().err and not (tmp_path / "p.h5").exists()


def test_unknown_collision_is_an_error_not_mrt():
    bogus = Settings().model_copy(
        update={"collision": "entropic"}
    )  # bypasses validation, as a new enum member would
    with pytest.raises(PorepipeError, match="collision.*entropic"):
        make_stepper(bogus, SimpleNamespace(force_nodes=(0, 0)))
