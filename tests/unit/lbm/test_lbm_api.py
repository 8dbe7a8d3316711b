"""Units, settings validation, result file + VTI export, checkpoint/resume and the CLI."""

import argparse

import numpy as np
import pytest
import xarray as xr
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLImageDataReader

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_attrs, read_volume
from porepipe.lbm import Settings, StabilityError, kappa_units, permeability
from porepipe.lbm._cli import register
from porepipe.lbm._io import write_vti


def test_units_of_one_square_micrometre():
    """κ̂ = 1 voxel² at 1 µm: 1e-12 m² = 1/0.9869233 D (thesis §4.4: 1 D = 0.9869 µm²)."""
    u = kappa_units(1.0, 1.0)
    assert u["kappa_m2"] == pytest.approx(1e-12, rel=1e-15)
    assert u["kappa_D"] == pytest.approx(1 / 0.9869233, rel=1e-12)
    assert u["kappa_mD"] == pytest.approx(1000 / 0.9869233, rel=1e-12)
    assert kappa_units(2.0, 3.0)["kappa_m2"] == pytest.approx(18e-12, rel=1e-15)


def test_settings_reject_unknown_keys_and_bad_force_zone():
    with pytest.raises(ValueError, match="extra"):
        Settings(colision="bgk")
    with pytest.raises(ValueError, match="force_layers"):
        Settings(inlet_layers=3, force_layers=3)
    with pytest.raises(ValueError):
        Settings(tau=0.5)
    with pytest.raises(ValueError, match="streaming=aa cannot run walls=mr1"):
        Settings(streaming="aa", walls="mr1")
    with pytest.raises(ValueError, match="streaming=aa with walls=cli needs precision=float64"):
        Settings(streaming="aa", walls="cli", precision="float32")
    assert Settings(streaming="aa", walls="halfway").streaming.value == "aa"
    assert Settings(streaming="aa", walls="cli").streaming.value == "aa"


def _slit(h=6, length=3):
    pore = np.zeros((length, 2, h + 2), dtype=bool)
    pore[:, :, 1:-1] = True
    return pore


def test_fields_follow_the_callers_axes_and_vti_reads_back(tmp_path):
    """Flow along y in a slit walled in z: v_y > 0 everywhere in the fluid, v_x = v_z = 0, NaN pressure in solid."""
    pore = np.moveaxis(_slit(), 0, 1)  # flow axis y
    res = permeability(pore, "y", Settings(collision="trt", write_fields=True), voxel_um=2.0, progress=False)
    assert res.velocity.shape == (3, *pore.shape)
    assert np.all(res.velocity[1][pore] > 0) and np.all(res.velocity[1][~pore] == 0)
    assert np.abs(res.velocity[[0, 2]]).max() < 1e-12 * res.velocity[1].max()
    assert np.isnan(res.pressure[~pore]).all() and np.isfinite(res.pressure[pore]).all()
    path = write_vti(tmp_path / "f.vti", {"velocity": res.velocity, "pressure": res.pressure}, spacing=2.0)
    reader = vtkXMLImageDataReader()  # VTK itself reads the file back
    reader.SetFileName(str(path))
    reader.Update()
    image = reader.GetOutput()
    assert image.GetDimensions() == tuple(n + 1 for n in pore.shape)  # one cell per voxel
    velocity = vtk_to_numpy(image.GetCellData().GetArray("velocity"))  # (cells, 3), x fastest
    np.testing.assert_array_equal(velocity[:, 1].reshape(pore.shape, order="F"), res.velocity[1])
    pressure = vtk_to_numpy(image.GetCellData().GetArray("pressure")).reshape(pore.shape, order="F")
    np.testing.assert_array_equal(np.isnan(pressure), np.isnan(res.pressure))


def test_checkpoint_resume_gives_the_same_answer(tmp_path):
    """A run stopped by the step limit resumes from its checkpoint and ends where an uninterrupted run ends."""
    pore = _slit(h=8)
    base = {"collision": "mrt", "window_steps": 50, "tolerance_kappa": 1e-8, "tolerance_velocity": 1e-7}
    full = permeability(pore, "x", Settings(**base), progress=False)
    ckpt = tmp_path / "run.ckpt.h5"
    with pytest.raises(StabilityError, match="not converged"):
        permeability(pore, "x", Settings(**base, max_steps=200), checkpoint=ckpt, progress=False)
    assert ckpt.is_file()
    resumed = permeability(pore, "x", Settings(**base), checkpoint=ckpt, progress=False)
    assert resumed.steps == full.steps
    assert resumed.kappa_lu == pytest.approx(full.kappa_lu, rel=1e-14)  # same arithmetic, same order
    np.testing.assert_array_equal(resumed.history["step"], full.history["step"])  # first part's history kept
    assert not ckpt.exists(), "a converged run removes its checkpoint"


def test_step_limit_before_the_first_check_says_so():
    """max_steps below the first full convergence window: the changes are still inf, and the error says that no
    check could run (not 'last δv=inf', which read as a blow-up); after a window it quotes the last full window's
    changes, also where the run ends on a shorter chunk (whose changes are inf)."""
    pore = _slit(h=8)
    with pytest.raises(StabilityError, match=r"no convergence check has run yet .*window_steps=50 and 100"):
        permeability(pore, "x", Settings(window_steps=50, max_steps=60), progress=False)
    with pytest.raises(StabilityError, match=r"not converged after 220 steps \(at step 200: δv=\d"):
        permeability(
            pore, "x", Settings(window_steps=50, max_steps=220, tolerance_kappa=1e-12), progress=False
        )


class _PlaneQ:
    """Every wall link cut at q = 0.3 (a slit's plates 0.3 off the outer nodes)."""

    def permuted(self, order):
        return self

    def fractions(self, nodes, pops):
        return np.full(len(pops), 0.3)


def test_multireflection_checkpoint_carries_the_link_state(tmp_path):
    """MR1 walls carry n⁻ per link from step to step; the checkpoint stores it, so a resumed run ends where an
    uninterrupted one ends (1e-14: same arithmetic; starting the state from zero instead is off by 1e-10)."""
    pore = _slit(h=8)
    base = {"walls": "mr1", "window_steps": 50, "tolerance_kappa": 1e-8}
    full = permeability(pore, "x", Settings(**base), progress=False, geometry=_PlaneQ())
    ckpt = tmp_path / "mr1.ckpt.h5"
    with pytest.raises(StabilityError, match="not converged"):
        permeability(
            pore, "x", Settings(**base, max_steps=200), checkpoint=ckpt, progress=False, geometry=_PlaneQ()
        )
    resumed = permeability(pore, "x", Settings(**base), checkpoint=ckpt, progress=False, geometry=_PlaneQ())
    assert full.walls == "mr1" and resumed.steps == full.steps
    assert resumed.kappa_lu == pytest.approx(full.kappa_lu, rel=1e-14)


def _binary(tmp_path, pore, name="binary_a2.h5"):
    path = tmp_path / name
    with ResultWriter(path, stage="segment", scene="t", scene_hash="h") as w:
        w.write_volume("pore", pore.astype(np.uint8), voxel_um=2.0)
    return path


def _parse(argv):
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    return parser.parse_args(["permeability", *argv])


def test_cli_writes_one_file_per_axis_with_units_and_history(tmp_path):
    pore = _slit(h=6, length=4)
    binary = _binary(tmp_path, pore)
    args = _parse([str(binary), "--axis", "x", "--collision", "trt", "--out-dir", str(tmp_path)])
    assert args.func(args) == 0
    out = tmp_path / "perm_a2_x.h5"
    attrs = read_attrs(out)
    assert (
        attrs["stage"] == "permeability" and attrs["collision"] == "trt" and attrs["precision"] == "float64"
    )
    assert attrs["kappa_m2"] == pytest.approx(attrs["kappa_lu"] * 4e-12, rel=1e-12)
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds["history_kappa"].size >= 2 and float(ds["kappa_mD"]) == pytest.approx(attrs["kappa_mD"])
        assert "ends/mean" not in ds["estimate"].values  # periodic set-up: body-force estimates only


def test_cli_failed_run_leaves_no_result_file(tmp_path):
    pore = _slit(h=6, length=4)
    binary = _binary(tmp_path, pore)
    out = tmp_path / "perm_a2_x.h5"
    args = _parse([str(binary), "--axis", "x", "--max-steps", "20", "--window-steps", "10", "-o", str(out)])
    with pytest.raises(PorepipeError, match="not converged"):
        args.func(args)
    assert not out.exists()
    args = _parse([str(binary), "--axis", "x", "--body-force", "0.5", "-o", str(out)])
    with pytest.raises(StabilityError, match="Mach number .* at step .*body_force"):
        args.func(args)
    assert not out.exists()


def test_cli_writes_fields_and_vti(tmp_path):
    pore = _slit(h=6, length=4)
    binary = _binary(tmp_path, pore)
    out = tmp_path / "perm_a2_z.h5"
    pore_z = np.moveaxis(pore, 0, 2)
    binary = _binary(tmp_path, pore_z, "binary_a2.h5")
    args = _parse([str(binary), "--axis", "z", "--write-fields", "--write-vti", "-o", str(out)])
    args.func(args)
    vz, vattrs = read_volume(out, "velocity_z")
    assert vattrs["voxel_um"] == 2.0 and np.all(vz[pore_z] > 0)
    assert out.with_suffix(".vti").is_file()


def test_check_schedule_ramps_then_follows_the_window():
    """Checks at 1, 2, 4, … (early blow-ups caught at once), then on multiples of the window (resumable)."""
    from porepipe.lbm._solver import _next_check

    done, seen = 0, []
    while done < 2000:
        done = _next_check(done, 500)
        seen.append(done)
    assert seen == [1, 2, 4, 8, 16, 32, 64, 128, 256, 500, 1000, 1500, 2000]


def test_scene_carries_the_permeability_section():
    """The scene model holds this stage's Settings under `permeability`, defaults filled in."""
    from pathlib import Path

    import yaml

    from porepipe.scene import load_scene, parse_scene

    scene_file = Path(__file__).parents[3] / "config" / "scenes" / "mini.yaml"
    scene = load_scene(scene_file)
    assert isinstance(scene.permeability, Settings)
    raw = yaml.safe_load(scene_file.read_text())
    assert scene.permeability == Settings(**raw["permeability"])  # given keys taken, the rest defaulted
    raw.pop("permeability")
    assert parse_scene(raw, scene_file.parent).permeability == Settings()  # no section: all defaults
