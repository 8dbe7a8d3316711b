"""`porepipe export` writes through VTK and VTK reads back what porepipe stored: volumes bit for bit, sphere
centres and radii exactly, polyhedral grains at their analytic corners, and LBM fields in SI units that satisfy
plane Poiseuille flow (u_max = G h² / 8μ) and Darcy's law (mean superficial velocity = κ G / μ)."""

import re

import h5py
import numpy as np
import pytest
import xarray as xr
import yaml

vtk_numpy = pytest.importorskip("vtkmodules.util.numpy_support")
from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLPolyDataReader  # noqa: E402

from porepipe._shared.errors import PorepipeError  # noqa: E402
from porepipe._shared.store import ResultWriter  # noqa: E402
from porepipe.cli import main  # noqa: E402

VOXEL_UM = 2.5
ORIGIN_UM = (10.0, -5.0, 0.0)


def _read(path, reader_class):
    reader = reader_class()
    reader.SetFileName(str(path))
    reader.Update()
    return reader.GetOutput()


def _cells(data, name, shape):
    """A cell array of an ImageData back as an (X, Y, Z[, 3]) array (VTK order: x fastest)."""
    flat = vtk_numpy.vtk_to_numpy(data.GetCellData().GetArray(name))
    if flat.ndim == 2:
        return np.stack([flat[:, k].reshape(shape, order="F") for k in range(3)], axis=-1)
    return flat.reshape(shape, order="F")


def test_grey_and_binary_volumes_round_trip_bit_for_bit_and_compressed(tmp_path):
    rng = np.random.default_rng(1)
    grey = rng.integers(0, 217, size=(7, 5, 3), dtype=np.uint8)
    path = tmp_path / "grey_a2.5.h5"
    with ResultWriter(path, stage="voxelize") as w:
        w.write_volume("grey", grey, voxel_um=VOXEL_UM, origin_um=ORIGIN_UM)
    assert main(["export", str(path), "-o", str(tmp_path / "grey.vti")]) == 0
    text = (tmp_path / "grey.vti").read_bytes()
    assert b"vtkZLibDataCompressor" in text
    image = _read(tmp_path / "grey.vti", vtkXMLImageDataReader)
    assert image.GetDimensions() == (8, 6, 4)  # points = voxels + 1: one cell per voxel
    assert image.GetSpacing() == (VOXEL_UM,) * 3
    assert image.GetOrigin() == ORIGIN_UM
    back = _cells(image, "grey", grey.shape)
    assert back.dtype == np.uint8
    np.testing.assert_array_equal(back, grey)


def test_packing_points_carry_their_radii(tmp_path):
    rng = np.random.default_rng(2)
    centres, radii = rng.uniform(0, 50, (40, 3)), rng.uniform(1, 3, 40)
    path = tmp_path / "packing.h5"
    with ResultWriter(path, stage="pack") as w:
        w.h5.create_dataset("centres_um", data=centres)
        w.h5.create_dataset("radii_um", data=radii)
        w.h5.create_dataset("types", data=np.zeros(40, np.int32))
    assert main(["export", str(path), "-o", str(tmp_path / "packing.vtp")]) == 0
    poly = _read(tmp_path / "packing.vtp", vtkXMLPolyDataReader)
    assert poly.GetNumberOfVerts() == 40
    np.testing.assert_array_equal(vtk_numpy.vtk_to_numpy(poly.GetPoints().GetData()), centres)
    np.testing.assert_array_equal(vtk_numpy.vtk_to_numpy(poly.GetPointData().GetArray("radius_um")), radii)


def _grains_table(centre, scale, rotation):
    """A decoration table of one unit cube grain (|x|, |y|, |z| <= 1/2) and one sphere grain."""
    normals = np.vstack([np.eye(3), -np.eye(3)])
    return xr.Dataset(
        {
            "centre_um": (("grain", "xyz"), np.array([centre, [0.0, 0.0, 0.0]])),
            "type": ("grain", np.array([0, 1])),
            "scale": ("grain", np.array([scale, 1.0])),
            "rotation": (("grain", "row", "col"), np.stack([rotation, np.eye(3)])),
            "kind": ("type", np.array([1, 0])),
            "plane_start": ("type", np.array([0, 6])),
            "plane_count": ("type", np.array([6, 0])),
            "normal": (("plane", "xyz"), normals),
            "offset": ("plane", np.full(6, 0.5)),
        }
    )


def test_grains_become_polygons_at_the_rotated_scaled_cube_corners(tmp_path):
    angle = 0.3
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    centre, scale = np.array([5.0, 6.0, 7.0]), 4.0
    path = tmp_path / "grains.h5"
    with ResultWriter(path, stage="decorate") as w:
        w.write_table(_grains_table(centre, scale, rotation))
    assert main(["export", str(path), "-o", str(tmp_path / "grains.vtp")]) == 0
    poly = _read(tmp_path / "grains.vtp", vtkXMLPolyDataReader)
    assert poly.GetNumberOfPolys() == 6
    points = vtk_numpy.vtk_to_numpy(poly.GetPoints().GetData())
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    expected = centre + scale * corners @ rotation.T
    assert len(points) == 8
    # each corner found once, to round-off of the half-space intersection (1e-12 of the 4 µm edge)
    distance = np.linalg.norm(points[:, None, :] - expected[None, :, :], axis=2)
    np.testing.assert_allclose(np.sort(distance.min(axis=1)), 0.0, atol=1e-9)
    assert sorted(distance.argmin(axis=1)) == list(range(8))
    faces = vtk_numpy.vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).reshape(6, 4)
    for face in faces:  # 4 corners of one face: one coordinate (in the grain frame) shared by all
        local = (points[face] - centre) @ rotation / scale
        assert np.isclose(np.abs(local), 0.5).all(axis=0).sum() >= 1 and np.ptp(local, axis=0).min() < 1e-9


def test_lbm_fields_in_si_units_follow_poiseuille_and_darcy(tmp_path):
    """A plane channel of h = 8 voxels along z with the lattice Poiseuille profile; solid layers at y = 0 and 9."""
    nx, ny, nz, h = 2, 10, 3, 8
    tau, g_lu = 0.8, 1e-6
    nu = (tau - 0.5) / 3
    y = np.arange(1, ny - 1) - 0.5  # node centres; walls halfway at y = 0.5 and 8.5 → distance from the wall
    profile = g_lu / (2 * nu) * y * (h - y)
    u = np.zeros((3, nx, ny, nz))
    u[2, :, 1:-1, :] = profile[None, :, None]
    pressure = np.full((nx, ny, nz), 1 / 3)
    pressure[:, [0, -1], :] = np.nan
    kappa_lu = nu * u[2].mean() / g_lu
    voxel_um = 2.0
    path = tmp_path / "perm_a2_z.h5"
    with ResultWriter(path, stage="permeability") as w:
        common = dict(voxel_um=voxel_um, origin_um=(0, 0, 0), periodic=(False,) * 3)
        for k, c in enumerate("xyz"):
            w.write_volume(f"velocity_{c}", u[k], **common)
        w.write_volume("pressure", pressure, **common)
        w.attrs.update(
            axis="z",
            tau=tau,
            voxel_um=voxel_um,
            kappa_lu=kappa_lu,
            kappa_m2=kappa_lu * (voxel_um * 1e-6) ** 2,
        )
    gradient, mu = 2.0e4, 1.0e-3
    out = tmp_path / "flow.vti"
    assert (
        main(["export", str(path), "-o", str(out), "--gradient-pa-m", "2e4", "--viscosity-pa-s", "1e-3"]) == 0
    )
    image = _read(out, vtkXMLImageDataReader)
    velocity = _cells(image, "velocity_m_s", (nx, ny, nz))
    solid = _cells(image, "solid", (nx, ny, nz))
    np.testing.assert_array_equal(solid, np.isnan(pressure))
    h_m = h * voxel_um * 1e-6
    # the lattice profile is the exact parabola at node centres: u(y) = G y (h − y) / 2μ in metres
    y_m = y * voxel_um * 1e-6
    np.testing.assert_allclose(velocity[0, 1:-1, 0, 2], gradient * y_m * (h_m - y_m) / (2 * mu), rtol=1e-12)
    # Darcy: mean superficial velocity (solid counted with 0) = κ G / μ
    np.testing.assert_allclose(
        velocity[..., 2].mean(), kappa_lu * (voxel_um * 1e-6) ** 2 * gradient / mu, rtol=1e-12
    )
    assert np.all(velocity[solid == 1] == 0)
    np.testing.assert_allclose(
        _cells(image, "pressure_Pa", (nx, ny, nz)), 0.0, atol=1e-12
    )  # uniform: no fluctuation


def test_wrong_suffix_and_fieldless_results_are_refused_in_one_line(tmp_path, capsys):
    path = tmp_path / "binary_a2.h5"
    with ResultWriter(path, stage="segment") as w:
        w.write_volume("pore", np.ones((2, 2, 2), bool), voxel_um=2.0)
    assert main(["export", str(path), "-o", str(tmp_path / "x.vtp")]) == 2
    assert "write it as .vti" in capsys.readouterr().err
    bare = tmp_path / "perm.h5"
    with ResultWriter(bare, stage="permeability") as w:
        w.attrs["axis"] = "z"
    with pytest.raises(PorepipeError, match="--write-fields"):
        from porepipe.export import export_result

        export_result(bare, tmp_path / "p.vti")
    assert not (tmp_path / "x.vtp").exists() and not (tmp_path / "p.vti").exists()
    with h5py.File(path) as f:
        assert f["volumes/pore"].dtype == bool


GRANULAR_SCENE = {
    "name": "g",
    "analyses": ["granular"],
    "granular": {
        "duration_s": 0.02,
        "dt_s": 2e-5,
        "box": {"lower_m": [0, 0], "upper_m": [0.06, 0.1]},
        "blocks": [
            {
                "lower_m": [0, 0],
                "upper_m": [0.06, 0.05],
                "grid_m": [0.012, 0.012],
                "shape": {"size_m": [0.005, 0.005], "corners": 7, "angle_mode": "RAND1"},
            }
        ],
        "output": {"frames": 3},
    },
}


@pytest.fixture(scope="module")
def granular_result(tmp_path_factory):
    folder = tmp_path_factory.mktemp("granular")
    (folder / "g.yaml").write_text(yaml.safe_dump(GRANULAR_SCENE))
    assert main(["granular", str(folder / "g.yaml"), "-o", str(folder / "g.h5"), "--quiet"]) == 0
    return folder / "g.h5"


def _polygon_area_centroid(xy):
    x, y = xy[:, 0], xy[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = cross.sum() / 2
    return area, np.array([((x + np.roll(x, -1)) * cross).sum(), ((y + np.roll(y, -1)) * cross).sum()]) / (
        6 * area
    )


def test_a_granular_frame_becomes_its_grains_and_walls_at_the_stored_positions(granular_result, tmp_path):
    from porepipe.granular import read_granular

    frames = read_granular(granular_result)["frames"]
    out = tmp_path / "frame.vtp"
    assert main(["export", str(granular_result), "-o", str(out), "--frame", "1"]) == 0
    poly = _read(out, vtkXMLPolyDataReader)
    points = vtk_numpy.vtk_to_numpy(poly.GetPoints().GetData())
    offsets = vtk_numpy.vtk_to_numpy(poly.GetPolys().GetOffsetsArray())
    connectivity = vtk_numpy.vtk_to_numpy(poly.GetPolys().GetConnectivityArray())
    particle = vtk_numpy.vtk_to_numpy(poly.GetCellData().GetArray("particle"))
    wall = vtk_numpy.vtk_to_numpy(poly.GetCellData().GetArray("wall"))
    active = frames["active"].values[1].astype(bool)
    assert sorted(particle[particle >= 0]) == list(np.flatnonzero(active))
    assert sorted(wall[wall >= 0]) == list(range(frames.sizes["wall"]))
    assert np.all(points[:, 2] == 0.0)
    corners = frames["n_corners"].values
    for cell in np.flatnonzero(particle >= 0):
        k = particle[cell]
        xy = points[connectivity[offsets[cell] : offsets[cell + 1]], :2]
        area, centroid = _polygon_area_centroid(xy)
        body_area, _ = _polygon_area_centroid(frames["vertices_m"].values[k, : corners[k]])
        # truth: the stored body outline (area unchanged by the rotation) and the stored centroid position of frame
        # 1 (the outline is kept about its centroid); 1e-12 relative: the rotation's round-off
        assert area == pytest.approx(body_area, rel=1e-12)
        np.testing.assert_allclose(centroid, frames["position_m"].values[1, k], rtol=0, atol=1e-12 * 0.1)
        # the corners themselves: the body outline turned counter-clockwise by the stored angle (the result's
        # convention, attrs["angles"]), then moved to the stored position
        c, s = np.cos(frames["angle_rad"].values[1, k]), np.sin(frames["angle_rad"].values[1, k])
        turned = frames["vertices_m"].values[k, : corners[k]] @ np.array([[c, -s], [s, c]]).T
        np.testing.assert_allclose(xy, turned + frames["position_m"].values[1, k], rtol=0, atol=1e-15)
    speed = vtk_numpy.vtk_to_numpy(poly.GetCellData().GetArray("speed_m_s"))[particle >= 0]
    expected = np.linalg.norm(frames["velocity_m_s"].values[1][particle[particle >= 0]], axis=1)
    np.testing.assert_array_equal(speed, expected)


def test_every_granular_frame_becomes_a_paraview_time_series(granular_result, tmp_path):
    from porepipe.granular import read_granular

    times = read_granular(granular_result)["frames"]["time_s"].values
    out = tmp_path / "heap.pvd"
    assert main(["export", str(granular_result), "-o", str(out)]) == 0
    text = out.read_text()
    files = [tmp_path / f for f in re.findall(r'file="([^"]+)"', text)]
    steps = [float(s) for s in re.findall(r'timestep="([^"]+)"', text)]
    assert steps == list(times) and len(files) == len(times)
    assert [f.parent.name for f in files] == ["heap_frames"] * len(times)
    for k, f in enumerate(files):
        single = tmp_path / f"single_{k}.vtp"
        assert main(["export", str(granular_result), "-o", str(single), "--frame", str(k)]) == 0
        assert f.read_bytes() == single.read_bytes()  # the series' frame k is the one-frame export of frame k
    assert (
        sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []
    )  # no temporary folder left


def test_granular_export_refuses_other_suffixes_and_frames_in_one_line(granular_result, tmp_path, capsys):
    assert main(["export", str(granular_result), "-o", str(tmp_path / "g.vti")]) == 2
    assert "write it as .vtp (one frame) or .pvd (every frame)" in capsys.readouterr().err
    assert main(["export", str(granular_result), "-o", str(tmp_path / "g.vtp"), "--frame", "99"]) == 2
    assert "frame 99 out of range" in capsys.readouterr().err
    assert main(["export", str(granular_result), "-o", str(tmp_path / "g.pvd"), "--frame", "0"]) == 2
    assert "--frame" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
