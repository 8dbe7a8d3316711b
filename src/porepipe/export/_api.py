"""Writers of VTK XML files through the ``vtk`` library, and the dispatch from a porepipe result to them.

VTK itself (the reference implementation of the formats, from PyPI) writes every file: appended raw binary,
zlib-compressed. Volumes are cell data of an ImageData (one cell per voxel, x fastest as VTK wants), origin and
spacing in µm; packings are points with a ``radius_um`` array (Glyph → Sphere, scale by radius, in ParaView);
decorated grains are polygons, one per face.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import h5py
import numpy as np

from porepipe._shared.atomic import atomic_path
from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import VOLUME_GROUP, dataset_attrs, read_attrs, read_table, volume_names

#: water at 20 °C, Pa s: the default fluid of the exported LBM fields
WATER_VISCOSITY_PA_S = 1.0e-3
#: default applied pressure gradient, Pa/m (1 bar per 10 m)
DEFAULT_GRADIENT_PA_M = 1.0e4


def _vtk():
    try:
        from vtkmodules import vtkCommonCore, vtkCommonDataModel, vtkIOXML
        from vtkmodules.util import numpy_support
    except ImportError as err:
        raise PorepipeError(
            "porepipe export needs the vtk package: pip install 'porepipe[export]' (or pip install vtk)"
        ) from err
    return vtkCommonCore, vtkCommonDataModel, vtkIOXML, numpy_support


def _write(writer, data, path) -> Path:
    """Run a vtkXML*Writer on ``data`` into ``path`` atomically, zlib-compressed, appended raw binary."""
    writer.SetInputData(data)
    writer.SetCompressorTypeToZLib()
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    with atomic_path(path) as tmp:
        writer.SetFileName(str(tmp))
        if writer.Write() != 1:
            raise PorepipeError(f"vtk could not write {path}")
    return Path(path)


def _vtk_array(numpy_support, name: str, values: np.ndarray):
    array = numpy_support.numpy_to_vtk(np.ascontiguousarray(values), deep=True)
    array.SetName(name)
    return array


def write_image(path, fields: dict, *, voxel_um: float, origin_um=(0.0, 0.0, 0.0)) -> Path:
    """Write volumes as cell data of a VTK ImageData file (.vti).

    Parameters
    ----------
    path : path-like
        Output file (.vti).
    fields : dict of str -> (X, Y, Z) or (X, Y, Z, 3) ndarray
        Scalars or 3-vectors per voxel, all of one grid; each is written with its own dtype (uint8 stays uint8).
    voxel_um : float
        Voxel edge, µm (the file's spacing).
    origin_um : sequence of 3 float
        Corner of voxel (0, 0, 0), µm.

    Returns
    -------
    Path
        ``path``.
    """
    _, model, io, numpy_support = _vtk()
    shapes = {np.shape(v)[:3] for v in fields.values()}
    if len(shapes) != 1 or len(next(iter(shapes))) != 3:
        raise PorepipeError(f"write_image: fields need one common 3-D grid, got shapes {sorted(shapes)}")
    (shape,) = shapes
    _check_grid(fields, shape, voxel_um, origin_um)
    image = model.vtkImageData()
    image.SetDimensions(*(n + 1 for n in shape))
    image.SetSpacing(*(float(voxel_um),) * 3)
    image.SetOrigin(*(float(o) for o in origin_um))
    for name, values in fields.items():
        values = np.asarray(values)
        values = values.astype(np.uint8) if values.dtype == bool else values  # VTK has no bool arrays
        # VTK's cell order is x fastest: Fortran order of (X, Y, Z), i.e. C order of the transposed array
        if values.ndim == 4:
            flat = np.stack([values[..., k].ravel(order="F") for k in range(3)], axis=1)
        else:
            flat = values.ravel(order="F")
        image.GetCellData().AddArray(_vtk_array(numpy_support, name, flat))
    return _write(io.vtkXMLImageDataWriter(), image, path)


def _check_grid(fields: dict, shape, voxel_um, origin_um) -> None:
    """Refuse an empty grid, a voxel size that is not positive and finite, an origin that is not 3 finite numbers
    and a 4-D field that is not 3-vectors (VTK would write a broken file or fail with its own messages).
    """
    if min(shape) < 1:
        raise PorepipeError(f"write_image: the grid {shape} has no voxel; nothing to write")
    if not 0 < float(voxel_um) < np.inf:
        raise PorepipeError(f"write_image: voxel_um must be positive and finite, got {voxel_um}")
    if np.shape(origin_um) != (3,) or not np.all(np.isfinite(origin_um)):
        raise PorepipeError(f"write_image: origin_um needs 3 finite numbers, got {origin_um!r}")
    for name, values in fields.items():
        if np.ndim(values) not in (3, 4) or (np.ndim(values) == 4 and np.shape(values)[3] != 3):
            raise PorepipeError(
                f"write_image: field {name!r} of shape {np.shape(values)} is neither (X, Y, Z) nor (X, Y, Z, 3)"
            )


def _check_lengths(where: str, item: str, data: dict, n: int) -> None:
    """Refuse a per-point or per-face array whose length is not the number of points or faces."""
    for name, values in data.items():
        if len(np.atleast_1d(values)) != n:
            raise PorepipeError(
                f"{where}: {name!r} has {len(np.atleast_1d(values))} values for {n} {item}(s)"
            )


def write_points(path, centres_um: np.ndarray, point_data: dict) -> Path:
    """Write points (sphere centres) with per-point arrays as VTK PolyData (.vtp), one vertex cell each.

    Parameters
    ----------
    path : path-like
        Output file (.vtp).
    centres_um : (N, 3) ndarray
        Point coordinates, µm.
    point_data : dict of str -> (N,) ndarray
        Per-point values (e.g. ``radius_um``).

    Returns
    -------
    Path
        ``path``.
    """
    core, model, io, numpy_support = _vtk()
    centres = np.asarray(centres_um, dtype=np.float64)
    if centres.ndim != 2 or centres.shape[1] != 3:
        raise PorepipeError(f"write_points: centres need shape (N, 3), got {centres.shape}")
    _check_lengths("write_points", "point", point_data, len(centres))
    points = core.vtkPoints()
    points.SetData(_vtk_array(numpy_support, "points", centres))
    cells = model.vtkCellArray()
    n = len(centres)
    offsets = np.arange(n + 1, dtype=np.int64)
    cells.SetData(
        numpy_support.numpy_to_vtkIdTypeArray(offsets, deep=True),
        numpy_support.numpy_to_vtkIdTypeArray(np.arange(n, dtype=np.int64), deep=True),
    )
    poly = model.vtkPolyData()
    poly.SetPoints(points)
    poly.SetVerts(cells)
    for name, values in point_data.items():
        poly.GetPointData().AddArray(_vtk_array(numpy_support, name, np.asarray(values)))
    return _write(io.vtkXMLPolyDataWriter(), poly, path)


def write_polygons(path, vertices_um: np.ndarray, faces: list[np.ndarray], cell_data: dict) -> Path:
    """Write polygons as VTK PolyData (.vtp).

    Parameters
    ----------
    path : path-like
        Output file (.vtp).
    vertices_um : (V, 3) ndarray
        All vertices, µm.
    faces : list of int ndarray
        Each face's vertex indices, in order around the face.
    cell_data : dict of str -> (len(faces),) ndarray
        Per-face values (e.g. the grain each face belongs to).

    Returns
    -------
    Path
        ``path``.
    """
    core, model, io, numpy_support = _vtk()
    n_vertices = len(vertices_um)
    bad = [i for i, f in enumerate(faces) if len(f) < 3 or np.min(f) < 0 or np.max(f) >= n_vertices]
    if bad:
        raise PorepipeError(
            f"write_polygons: face {bad[0]} ({np.asarray(faces[bad[0]]).tolist()}) needs >= 3 vertex indices in "
            f"0..{n_vertices - 1}"
        )
    _check_lengths("write_polygons", "face", cell_data, len(faces))
    points = core.vtkPoints()
    points.SetData(_vtk_array(numpy_support, "points", np.asarray(vertices_um, dtype=np.float64)))
    offsets = np.concatenate([[0], np.cumsum([len(f) for f in faces])]).astype(np.int64)
    connectivity = np.concatenate(faces).astype(np.int64) if faces else np.zeros(0, np.int64)
    cells = model.vtkCellArray()
    cells.SetData(
        numpy_support.numpy_to_vtkIdTypeArray(offsets, deep=True),
        numpy_support.numpy_to_vtkIdTypeArray(connectivity, deep=True),
    )
    poly = model.vtkPolyData()
    poly.SetPoints(points)
    poly.SetPolys(cells)
    for name, values in cell_data.items():
        poly.GetCellData().AddArray(_vtk_array(numpy_support, name, np.asarray(values)))
    return _write(io.vtkXMLPolyDataWriter(), poly, path)


def _polyhedron_faces(normals: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Vertices and faces (each in order around its plane's normal) of {x : n·x <= d}, which holds the origin."""
    from scipy.spatial import HalfspaceIntersection

    vertices = HalfspaceIntersection(np.column_stack([normals, -offsets]), np.zeros(3)).intersections
    keep = np.unique(np.round(vertices, 12), axis=0, return_index=True)[1]
    vertices = vertices[np.sort(keep)]
    faces = []
    tol = 1e-9 * max(1.0, float(np.abs(offsets).max()))
    for n, d in zip(normals, offsets):
        on = np.flatnonzero(np.abs(vertices @ n - d) < tol)
        if len(on) < 3:
            continue
        centre = vertices[on].mean(axis=0)
        u = vertices[on[0]] - centre
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        rel = vertices[on] - centre
        faces.append(on[np.argsort(np.arctan2(rel @ v, rel @ u))])
    return vertices, faces


def grain_polygons(table) -> tuple[np.ndarray, list[np.ndarray], np.ndarray, int]:
    """World-space polygons of the polyhedral grains of a decoration table (``grains.h5``'s root Dataset).

    Parameters
    ----------
    table : xarray.Dataset
        With ``centre_um``, ``type``, ``scale``, ``rotation``, ``kind``, ``plane_start``, ``plane_count``,
        ``normal``, ``offset`` (as ``porepipe decorate`` writes them).

    Returns
    -------
    vertices_um : (V, 3) ndarray
    faces : list of int ndarray
        Vertex indices of each face, counter-clockwise seen from outside.
    face_grain : (len(faces),) ndarray of int64
        The grain each face belongs to.
    n_spheres : int
        Grains of sphere kind, which have no faces and are left out.
    """
    shapes = {}
    vertices, faces, face_grain, n_spheres, base = [], [], [], 0, 0
    for g, t in enumerate(table["type"].values.astype(int)):
        if int(table["kind"].values[t]) == 0:
            n_spheres += 1
            continue
        if t not in shapes:
            s, n = int(table["plane_start"].values[t]), int(table["plane_count"].values[t])
            shapes[t] = _polyhedron_faces(
                table["normal"].values[s : s + n], table["offset"].values[s : s + n]
            )
        local, local_faces = shapes[t]
        rotation = table["rotation"].values[g]
        world = table["centre_um"].values[g] + float(table["scale"].values[g]) * local @ rotation.T
        vertices.append(world)
        faces.extend(f + base for f in local_faces)
        face_grain.extend([g] * len(local_faces))
        base += len(local)
    all_vertices = np.concatenate(vertices) if vertices else np.zeros((0, 3))
    return all_vertices, faces, np.asarray(face_grain, dtype=np.int64), n_spheres


def _volumes(path) -> dict[str, dict]:
    """Name -> attributes of every volume in a result file."""
    with h5py.File(path, "r") as f:
        group = f.get(VOLUME_GROUP)
        # coordinate scales (x_um …) are not volumes; DIMENSION_LIST etc. are not metadata
        return {} if group is None else {name: dataset_attrs(group[name]) for name in volume_names(group)}


def _read_volume(path, name: str) -> np.ndarray:
    with h5py.File(path, "r") as f:
        return f[VOLUME_GROUP][name][...]


def _flow_fields(path, attrs: dict, gradient_pa_m: float, viscosity_pa_s: float) -> dict:
    """Velocity (m/s), pressure (Pa, relative to its mean) and solid mask of an LBM result, scaled by Darcy's law.

    Stokes flow is linear in the forcing: the lattice field scaled so that its mean superficial velocity along the
    flow axis is κ G / μ is the field of that gradient G and viscosity μ; the pressure scales with G·a over the
    lattice's effective gradient ν ū / κ (lattice units).
    """
    u = np.stack([_read_volume(path, f"velocity_{c}") for c in "xyz"], axis=-1)
    p = _read_volume(path, "pressure")
    solid = ~np.isfinite(p)
    axis = "xyz".index(attrs["axis"])
    mean_u_lu = float(u[..., axis].mean())  # superficial: solid voxels count with zero velocity
    kappa_lu, kappa_m2 = float(attrs["kappa_lu"]), float(attrs["kappa_m2"])
    if not (mean_u_lu > 0 and kappa_lu > 0):
        raise PorepipeError(
            f"{path}: no flow along {attrs['axis']} (mean velocity {mean_u_lu:g}); nothing to scale"
        )
    u_scale = kappa_m2 * gradient_pa_m / viscosity_pa_s / mean_u_lu
    nu_lu = (float(attrs["tau"]) - 0.5) / 3.0
    gradient_lu = nu_lu * mean_u_lu / kappa_lu
    p_scale = gradient_pa_m * float(attrs["voxel_um"]) * 1e-6 / gradient_lu
    pressure = np.where(solid, 0.0, (p - np.nanmean(p)) * p_scale)
    return {
        "velocity_m_s": np.where(solid[..., None], 0.0, u * u_scale),
        "pressure_Pa": pressure,
        "solid": solid.astype(np.uint8),
    }


def _check_fluid(gradient_pa_m, viscosity_pa_s) -> None:
    """Refuse a gradient that is not finite and a viscosity that is not positive and finite (NaN or Inf fields)."""
    if not np.isfinite(gradient_pa_m):
        raise PorepipeError(f"export: gradient_pa_m must be finite, got {gradient_pa_m}")
    if not 0 < viscosity_pa_s < np.inf:
        raise PorepipeError(f"export: viscosity_pa_s must be positive and finite, got {viscosity_pa_s}")


def granular_polygons(tables: dict, frame: int = -1) -> tuple[np.ndarray, list[np.ndarray], dict]:
    """The grains and walls of one frame of a ``granular.h5`` as polygons in the plane z = 0 (metres).

    Parameters
    ----------
    tables : dict
        Output of :func:`porepipe.granular.read_granular`.
    frame : int
        Frame index (negative counts from the end).

    Returns
    -------
    vertices_m : (V, 3) ndarray
        Every corner, z = 0.
    faces : list of int ndarray
        One polygon per active grain, then one per wall.
    cell_data : dict of str -> (len(faces),) ndarray
        ``particle`` (the grain's index, -1 for a wall), ``wall`` (the wall's index, -1 for a grain),
        ``speed_m_s`` and ``angular_velocity_rad_s`` (0 for walls).
    """
    from porepipe.granular import frame_particles

    parts = frame_particles(tables, frame)
    ds, f = tables["frames"], parts["index"]
    grains = np.flatnonzero(parts["active"])
    walls = [w[~np.isnan(w).any(axis=1)] for w in ds["wall_vertices_m"].values]
    outlines = [parts["polygons"][k] for k in grains] + walls
    starts = np.concatenate([[0], np.cumsum([len(o) for o in outlines])]).astype(np.int64)
    faces = [np.arange(starts[i], starts[i + 1]) for i in range(len(outlines))]
    xy = np.concatenate(outlines) if outlines else np.zeros((0, 2))
    vertices = np.column_stack([xy, np.zeros(len(xy))])
    no_wall, no_grain = np.full(len(grains), -1), np.full(len(walls), -1)
    speed = np.linalg.norm(ds["velocity_m_s"].values[f][grains], axis=1)
    cell_data = {
        "particle": np.concatenate([grains, no_grain]),
        "wall": np.concatenate([no_wall, np.arange(len(walls))]),
        "speed_m_s": np.concatenate([speed, np.zeros(len(walls))]),
        "angular_velocity_rad_s": np.concatenate(
            [ds["angular_velocity_rad_s"].values[f][grains], np.zeros(len(walls))]
        ),
    }
    return vertices, faces, cell_data


def write_granular_series(path, tables: dict) -> Path:
    """Every frame of a granular result as a ParaView time series: ``path`` (.pvd) names one .vtp per frame
    (:func:`granular_polygons`), in the folder ``<stem>_frames`` beside it. The frames are written into a hidden
    folder that replaces ``<stem>_frames`` only when all are written, so a failed export leaves none behind.

    Parameters
    ----------
    path : path-like
        The collection file (.pvd).
    tables : dict
        Output of :func:`porepipe.granular.read_granular`.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    folder = path.with_name(f"{path.stem}_frames")
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", dir=path.parent))
    rows = []
    try:
        for k, time_s in enumerate(tables["frames"]["time_s"].values):
            name = f"frame_{k:05d}.vtp"
            write_polygons(tmp / name, *granular_polygons(tables, k))
            rows.append(f'    <DataSet timestep="{float(time_s)!r}" file="{folder.name}/{name}"/>')
        if folder.exists():
            shutil.rmtree(folder)
        os.replace(tmp, folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">', "  <Collection>", *rows]
    with atomic_path(path) as out:
        out.write_text("\n".join([*lines, "  </Collection>", "</VTKFile>", ""]))
    return path


def export_result(
    path,
    out,
    *,
    gradient_pa_m: float = DEFAULT_GRADIENT_PA_M,
    viscosity_pa_s: float = WATER_VISCOSITY_PA_S,
    frame: int | None = None,
) -> str:
    """Write a porepipe result as a ParaView file; returns a one-line summary of what was written.

    Parameters
    ----------
    path : path-like
        A result: ``grey_a{a}.h5`` / ``binary_a{a}.h5`` (→ .vti), ``packing.h5`` (→ .vtp points with
        ``radius_um``), ``grains.h5`` (→ .vtp polygons), ``perm_a{a}_{axis}.h5`` written with fields
        (→ .vti with ``velocity_m_s``, ``pressure_Pa``, ``solid``), ``granular.h5`` (→ .vtp: one frame's grains
        and walls as polygons in metres; → .pvd: every frame, a ParaView time series).
    out : path-like
        The file to write; its suffix must be the one the result calls for.
    gradient_pa_m, viscosity_pa_s : float
        LBM results only: the applied pressure gradient (Pa/m) and the fluid's viscosity (Pa s) that turn the
        lattice fields into SI units (default 1e4 Pa/m, water).
    frame : int, optional
        Granular results written as .vtp only: the frame (negative counts from the end; default the last).

    Returns
    -------
    str
        What was written.
    """
    _check_fluid(gradient_pa_m, viscosity_pa_s)
    path, out = Path(path), Path(out)
    attrs = read_attrs(path)
    volumes = _volumes(path)
    with h5py.File(path, "r") as f:
        is_packing = "centres_um" in f and "radii_um" in f
    table = None if volumes or is_packing else read_table(path)
    if "velocity_x" in volumes:
        kind, suffix = "flow", ".vti"
    elif volumes:
        kind, suffix = "volume", ".vti"
    elif is_packing:
        kind, suffix = "packing", ".vtp"
    elif table is not None and {"normal", "offset", "centre_um"} <= set(table.variables):
        kind, suffix = "grains", ".vtp"
    elif attrs.get("stage") == "granular":
        kind, suffix = "granular", ".pvd" if out.suffix == ".pvd" else ".vtp"
    elif attrs.get("stage") == "permeability":
        raise PorepipeError(f"{path} holds no flow fields; rerun permeability with --write-fields")
    else:
        raise PorepipeError(
            f"{path} (stage {attrs.get('stage', '?')!r}) has nothing to export: porepipe export takes volumes, "
            "packings, grains, granular results and permeability results written with --write-fields"
        )
    if out.suffix != suffix:
        allowed = ".vtp (one frame) or .pvd (every frame)" if kind == "granular" else suffix
        raise PorepipeError(
            f"{path} is a {kind} result: write it as {allowed}, not {out.suffix or 'no suffix'}"
        )
    if frame is not None and (kind != "granular" or suffix == ".pvd"):
        holds = (
            "time series, which holds every frame" if kind == "granular" else "export, which has no frames"
        )
        raise PorepipeError(
            f"--frame {frame}: picks one frame of a granular result written as .vtp; {out.name} is a {kind} {holds}"
        )
    if kind == "granular":
        return _export_granular(path, out, -1 if frame is None else frame)
    if kind == "flow":
        meta = volumes["velocity_x"]
        fields = _flow_fields(path, attrs, gradient_pa_m, viscosity_pa_s)
        write_image(out, fields, voxel_um=float(meta["voxel_um"]), origin_um=meta["origin_um"])
        return f"velocity (m/s), pressure (Pa) and solid mask at G = {gradient_pa_m:g} Pa/m, μ = {viscosity_pa_s:g} Pa s -> {out}"
    if kind == "volume":
        meta = next(iter(volumes.values()))
        fields = {name: _read_volume(path, name) for name in volumes}
        write_image(out, fields, voxel_um=float(meta["voxel_um"]), origin_um=meta["origin_um"])
        return f"volume(s) {', '.join(fields)} ({'×'.join(map(str, next(iter(fields.values())).shape))} voxels) -> {out}"
    if kind == "packing":
        with h5py.File(path, "r") as f:
            centres, radii, types = f["centres_um"][...], f["radii_um"][...], f["types"][...]
        write_points(out, centres, {"radius_um": radii, "type": types})
        return f"{len(radii)} spheres (points with radius_um) -> {out}"
    vertices, faces, face_grain, n_spheres = grain_polygons(table)
    write_polygons(out, vertices, faces, {"grain": face_grain})
    skipped = f"; {n_spheres} sphere grains left out" if n_spheres else ""
    return f"{len(np.unique(face_grain))} grains as {len(faces)} polygons{skipped} -> {out}"


def _export_granular(path, out: Path, frame: int) -> str:
    from porepipe.granular import read_granular

    tables = read_granular(path)
    if out.suffix == ".pvd":
        write_granular_series(out, tables)
        frames = tables["frames"].sizes["frame"]
        return f"{frames} frames (grains and walls as polygons, m) -> {out} and {out.stem}_frames/"
    vertices, faces, cell_data = granular_polygons(tables, frame)
    write_polygons(out, vertices, faces, cell_data)
    grains, walls = int((cell_data["wall"] < 0).sum()), int((cell_data["wall"] >= 0).sum())
    index = frame % tables["frames"].sizes["frame"]
    time_s = float(tables["frames"]["time_s"].values[index])
    return f"frame {index} (t = {time_s:.6g} s): {grains} grains and {walls} walls as polygons (m, z = 0) -> {out}"


__all__ = [
    "export_result",
    "grain_polygons",
    "granular_polygons",
    "write_granular_series",
    "write_image",
    "write_points",
    "write_polygons",
]
