"""Bad input to the VTK writers: a file or one PorepipeError line, never a broken file or VTK's own messages."""

import numpy as np
import pytest

pytest.importorskip("vtkmodules")

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter
from porepipe.export import export_result, write_image, write_points, write_polygons

_CUBE = np.ones((2, 2, 2), np.uint8)


@pytest.mark.parametrize(
    "fields, kwargs, match",
    [
        (
            {"x": np.zeros((0, 3, 3), np.uint8)},
            {},
            "has no voxel",
        ),  # before: VTK's error log, "could not write"
        (
            {"x": _CUBE},
            {"voxel_um": float("nan")},
            "voxel_um must be positive",
        ),  # before: written with NaN spacing
        ({"x": _CUBE}, {"voxel_um": 0.0}, "voxel_um must be positive"),  # before: written with spacing 0
        ({"x": _CUBE}, {"origin_um": (0.0, 0.0)}, "origin_um needs 3"),  # before: VTK's overload TypeError
        ({"x": np.ones((2, 2, 2, 2))}, {}, r"neither \(X, Y, Z\) nor \(X, Y, Z, 3\)"),  # before: IndexError
    ],
)
def test_write_image_refuses_a_grid_it_cannot_write(fields, kwargs, match, tmp_path):
    with pytest.raises(PorepipeError, match=match):
        write_image(tmp_path / "a.vti", fields, **{"voxel_um": 1.0, **kwargs})
    assert not (tmp_path / "a.vti").exists()


def test_write_image_takes_boolean_fields(tmp_path):
    # before: "Could not find a suitable VTK type for bool" (only export_result converted them)
    assert write_image(tmp_path / "b.vti", {"pore": _CUBE.astype(bool)}, voxel_um=1.0).stat().st_size > 0


def test_write_points_refuses_mismatched_arrays(tmp_path):
    with pytest.raises(PorepipeError, match=r"'radius_um' has 5 values for 3 point"):  # before: a broken .vtp
        write_points(tmp_path / "p.vtp", np.zeros((3, 3)), {"radius_um": np.ones(5)})
    with pytest.raises(PorepipeError, match=r"centres need shape \(N, 3\), got \(3, 2\)"):  # before: 2 points
        write_points(tmp_path / "p.vtp", np.zeros((3, 2)), {})
    assert not (tmp_path / "p.vtp").exists()


def test_write_polygons_refuses_a_face_outside_the_vertices(tmp_path):
    with pytest.raises(PorepipeError, match=r"face 0 \(\[0, 1, 7\]\) needs >= 3 vertex indices in 0..2"):
        write_polygons(tmp_path / "g.vtp", np.eye(3), [np.array([0, 1, 7])], {})  # before: a broken .vtp
    with pytest.raises(PorepipeError, match=r"'grain' has 4 values for 1 face"):
        write_polygons(tmp_path / "g.vtp", np.eye(3), [np.array([0, 1, 2])], {"grain": np.zeros(4)})
    assert not (tmp_path / "g.vtp").exists()


def _flow_result(path):
    """A 2×3×2 permeability result with fields: uniform flow along z beside a solid layer at y = 0."""
    u = np.zeros((3, 2, 3, 2))
    u[2, :, 1:, :] = 1e-4
    pressure = np.full((2, 3, 2), 1 / 3)
    pressure[:, 0, :] = np.nan
    with ResultWriter(path, stage="permeability") as w:
        for k, c in enumerate("xyz"):
            w.write_volume(f"velocity_{c}", u[k], voxel_um=1.0)
        w.write_volume("pressure", pressure, voxel_um=1.0)
        w.attrs.update(axis="z", tau=0.8, voxel_um=1.0, kappa_lu=0.1, kappa_m2=1e-13)
    return path


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"viscosity_pa_s": 0.0}, "viscosity_pa_s must be positive and finite"),  # before: ZeroDivisionError
        ({"viscosity_pa_s": float("nan")}, "viscosity_pa_s must be positive"),  # before: NaN velocities
        ({"gradient_pa_m": float("nan")}, "gradient_pa_m must be finite"),  # before: NaN fields written
        ({"gradient_pa_m": float("inf")}, "gradient_pa_m must be finite"),  # before: numpy warning of inf * 0
    ],
)
def test_export_result_refuses_a_fluid_without_a_meaning(kwargs, match, tmp_path):
    path = _flow_result(tmp_path / "perm_a1_z.h5")
    with pytest.raises(PorepipeError, match=match):
        export_result(path, tmp_path / "flow.vti", **kwargs)
    assert not (tmp_path / "flow.vti").exists()
    export_result(path, tmp_path / "flow.vti")  # the same result with the default fluid is written
