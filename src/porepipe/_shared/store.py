"""The HDF5 cache: one file per rule output, written atomically, with its cost attached.

Layout of a result file
-----------------------
- root attributes: ``stage``, ``scene``, ``scene_hash``, ``porepipe_version``, ``created``, ``wall_s``, ``cpu_s``
  (the computation: from the end of the command's start-up, :func:`porepipe._shared.cost.mark_compute_start`, or from the opening of the
  writer when used from Python), ``startup_s`` (interpreter start-up and imports before it; NaN from Python),
  ``peak_mb``, ``threads`` and whatever the stage adds;
- root group: at most one xarray Dataset of tables and curves (netCDF4 layout, so
  ``xarray.open_dataset(path, engine="h5netcdf")`` reads it); further Datasets go into named groups;
- ``/volumes/<name>``: chunked, compressed 3-D arrays with ``voxel_um``, ``origin_um`` and ``periodic`` attributes,
  whose axes are HDF5 dimension scales ``x_um``, ``y_um``, ``z_um`` (voxel centres in µm), so
  ``xarray.open_dataset(path, engine="h5netcdf", group="volumes")`` gives named dimensions with coordinates;
- ``/arrays/<name>``: other plain arrays (named dimensions where the writer gives them).

Every variable carries ``units`` in the one spelling of :mod:`porepipe._shared.units`; :func:`open_result` returns
the whole file as one :class:`xarray.Dataset`.

The file is written under a hidden temporary name in the target directory and renamed only when complete
(:mod:`porepipe._shared.atomic`: fsync, then rename), so a killed job never leaves a file that Snakemake or
:func:`read_attrs` would take as finished.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import hashlib
import json
import math
import resource
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import xarray as xr

from porepipe._shared import cost as _cost
from porepipe._shared.atomic import check_identity, commit, file_identity, prepare_output, temporary_path
from porepipe._shared.errors import PorepipeError
from porepipe._shared.run_control import without_run_control
from porepipe._shared.units import DIMENSIONLESS, MICROMETRE, annotate, canonical, centres_um, units_of
from porepipe._version import __version__

VOLUME_GROUP = "volumes"
ARRAY_GROUP = "arrays"
#: names of the coordinate (dimension-scale) datasets of a volume's axes
AXIS_NAMES = ("x_um", "y_um", "z_um")
#: Edge of a volume chunk in voxels (64^3 bytes = 256 KiB for uint8).
CHUNK_EDGE = 64


def hash_of(obj: Any) -> str:
    """Stable short hash of a JSON-serialisable object (e.g. the scene part a result depends on)."""
    text = json.dumps(obj, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def result_hash(
    stage: str, *, scene_part: Any = None, settings: Any = None, inputs: Sequence = (), **extra: Any
) -> str:
    """The hash of what determines a result, made the same way by every stage (root attribute ``scene_hash``).

    Parameters
    ----------
    stage : str
        The stage writing the result.
    scene_part : JSON-able, optional
        The parts of the scene the result depends on (:func:`porepipe.scene.scene_part`).
    settings : pydantic model or JSON-able, optional
        The stage's settings after command-line overrides; a model enters less its run-control fields
        (:mod:`porepipe._shared.run_control`: checkpoint and progress intervals, ranks), which change no result.
    inputs : sequence of path-like
        Result files it is computed from; each enters by its own ``scene_hash``, so a change upstream changes the
        hash downstream. Order matters (sort it where the inputs are a set).
    **extra : JSON-able
        Further arguments that change the result (a voxel size, an axis, a sub-sample edge).

    Returns
    -------
    str
        16 hex digits (:func:`hash_of` of the record).
    """
    if hasattr(settings, "model_dump"):
        settings = without_run_control(settings)
    record = {
        "stage": stage,
        "scene": scene_part,
        "settings": settings,
        "inputs": [read_attrs(p).get("scene_hash", "") for p in inputs],
        "extra": extra,
    }
    return hash_of(record)


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _volume_attrs(voxel_um: float, origin_um: Sequence[float], periodic: Sequence[bool]) -> dict:
    voxel_um = float(voxel_um)
    if not np.isfinite(voxel_um) or voxel_um <= 0:
        raise PorepipeError(f"voxel_um must be a positive number, got {voxel_um}")
    origin = [float(o) for o in origin_um]
    per = [int(bool(p)) for p in periodic]
    if len(origin) != 3 or len(per) != 3:
        raise PorepipeError(f"origin_um and periodic need 3 entries, got {origin_um!r} and {periodic!r}")
    return {"voxel_um": voxel_um, "origin_um": np.asarray(origin), "periodic": np.asarray(per, dtype=np.int8)}


class ResultWriter:
    """Context manager that writes one result file atomically and records its cost.

    Parameters
    ----------
    path : path-like
        Final file name. Its directory is created.
    stage : str
        Name of the stage that writes it.
    scene : str
        Scene name.
    scene_hash : str
        Hash of the scene part this result depends on (see :func:`hash_of`).
    threads : int, optional
        Thread count the stage used.

    Examples
    --------
    >>> with ResultWriter("out.h5", stage="segment", scene="mini", scene_hash="abc") as w:  # doctest: +SKIP
    ...     w.write_volume("pore", pore, voxel_um=2.0)
    ...     w.attrs["threshold"] = 108
    """

    def __init__(
        self, path, *, stage: str, scene: str = "", scene_hash: str = "", threads: int | None = None
    ):
        self.path = Path(path)
        self.tmp_path = temporary_path(self.path)
        self.attrs: dict[str, Any] = {
            "stage": stage,
            "scene": scene,
            "scene_hash": scene_hash,
            "porepipe_version": __version__,
            "threads": int(threads) if threads is not None else 0,
        }
        self._tables: list[tuple[xr.Dataset, str | None]] = []
        self._h5: h5py.File | None = None
        #: (wall s, CPU s) that earlier processes of a resumed run spent up to the checkpoint it resumed from: added
        #: to ``wall_s``/``cpu_s`` and kept as ``resumed_wall_s``/``resumed_cpu_s`` (NaN: not recorded there)
        self.carried: tuple[float, float] = (0.0, 0.0)

    # -- context -------------------------------------------------------------------------------------------------
    def __enter__(self) -> ResultWriter:
        prepare_output(self.path)
        self._t0 = time.perf_counter()
        self._c0 = time.process_time()
        self._startup = float("nan")
        if _cost.COMPUTE_MARK:  # under the porepipe command: the computation began when its start-up ended
            self._t0, self._c0, self._startup = _cost.COMPUTE_MARK[0]
        self._h5 = h5py.File(self.tmp_path, "w")
        self._identity = file_identity(self.tmp_path)
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                self._finish()
        finally:
            if self._h5 is not None:
                self._h5.close()
                self._h5 = None
            if exc_type is not None or not self.path.exists():
                self.tmp_path.unlink(missing_ok=True)
        return False

    def _finish(self) -> None:
        self._h5.close()
        self._h5 = None
        check_identity(self.tmp_path, self.path, self._identity)  # before anything could make the name again
        for ds, group in self._tables:
            ds.to_netcdf(self.tmp_path, engine="h5netcdf", mode="a", group=group)
        with h5py.File(self.tmp_path, "a") as f:
            self.attrs["created"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
            t1, c1 = time.perf_counter(), time.process_time()
            self.attrs["wall_s"] = t1 - self._t0
            self.attrs["cpu_s"] = c1 - self._c0
            if self.carried != (0.0, 0.0):
                self._add_carried()
            self.attrs["startup_s"] = self._startup
            self.attrs["peak_mb"] = _peak_mb()
            if (
                _cost.COMPUTE_MARK
            ):  # a second result of the same process counts from here; its start-up is paid
                _cost.COMPUTE_MARK[:] = [(t1, c1, 0.0)]
            for key, value in self.attrs.items():
                f.attrs[key] = value
        commit(self.tmp_path, self.path, self._identity)

    def _add_carried(self) -> None:
        wall, cpu = self.carried
        self.attrs["resumed_wall_s"], self.attrs["resumed_cpu_s"] = wall, cpu
        if math.isfinite(wall) and math.isfinite(cpu):
            self.attrs["wall_s"] += wall
            self.attrs["cpu_s"] += cpu

    # -- writers ---------------------------------------------------------------------------------------------------
    @property
    def h5(self) -> h5py.File:
        if self._h5 is None:
            raise RuntimeError("ResultWriter is not open; use it in a with-statement")
        return self._h5

    def create_volume(
        self,
        name: str,
        shape: Sequence[int],
        dtype,
        *,
        voxel_um: float,
        origin_um: Sequence[float] = (0.0, 0.0, 0.0),
        periodic: Sequence[bool] = (True, True, True),
        attrs: dict | None = None,
    ) -> h5py.Dataset:
        """Create an empty chunked, compressed volume to be filled slab by slab; returns the h5py dataset."""
        shape = tuple(int(s) for s in shape)
        if len(shape) != 3 or min(shape) < 1:
            raise PorepipeError(f"volume {name!r} needs a 3-D shape with positive sizes, got {shape}")
        chunks = tuple(min(s, CHUNK_EDGE) for s in shape)
        dset = self.h5.require_group(VOLUME_GROUP).create_dataset(
            name,
            shape=shape,
            dtype=dtype,
            chunks=chunks,
            compression="gzip",
            compression_opts=1,
            shuffle=True,
        )
        geometry = _volume_attrs(voxel_um, origin_um, periodic)
        units, lattice = canonical((attrs or {}).get("units", DIMENSIONLESS))
        for key, value in {**geometry, **(attrs or {}), "units": units}.items():
            dset.attrs[key] = value
        if lattice is not None:
            dset.attrs["lattice_units"] = lattice
        _attach_axes(self.h5[VOLUME_GROUP], dset, voxel_um, geometry["origin_um"])
        return dset

    def write_volume(self, name: str, data: np.ndarray, **kwargs) -> h5py.Dataset:
        """Write a whole in-memory volume; keyword arguments as for :meth:`create_volume`."""
        dset = self.create_volume(name, data.shape, data.dtype, **kwargs)
        dset[...] = data
        return dset

    def write_array(
        self, name: str, data: np.ndarray, attrs: dict | None = None, dims: Sequence[str] = ()
    ) -> h5py.Dataset:
        """Write a plain array under ``/arrays``; ``dims`` names its axes (index coordinates), units from the name."""
        group = self.h5.require_group(ARRAY_GROUP)
        dset = group.create_dataset(name, data=np.asarray(data))
        units, lattice = units_of(name, dset.dtype, (attrs or {}).get("units"))
        for key, value in {**(attrs or {}), **({"units": units} if units else {})}.items():
            dset.attrs[key] = value
        if lattice is not None:
            dset.attrs["lattice_units"] = lattice
        if dims:
            label_dims(group, {name: dims})
        return dset

    def write_table(self, ds: xr.Dataset, group: str | None = None) -> None:
        """Queue an xarray Dataset for the root group (``group=None``) or a named group; written on completion.

        Its variables get ``units`` in porepipe's spelling on the way (:func:`porepipe._shared.units.annotate`).
        """
        if any(g == group for _, g in self._tables):
            raise RuntimeError(f"a table for group {group!r} was already written; merge the Datasets first")
        self._tables.append((annotate(ds), group))


# -- named dimensions for plain HDF5 datasets ---------------------------------------------------------------------------
def _is_scale(dset) -> bool:
    return isinstance(dset, h5py.Dataset) and dset.is_scale


def _scale(group: h5py.Group, name: str, values: np.ndarray, units: str | None) -> h5py.Dataset:
    """The dimension-scale dataset ``name`` of ``group`` holding ``values``; created if missing."""
    if name in group:
        return group[name]
    dset = group.create_dataset(name, data=values)
    if units:
        dset.attrs["units"] = units
    dset.make_scale(name)
    return dset


def _attach_axes(group: h5py.Group, dset: h5py.Dataset, voxel_um, origin_um) -> None:
    """Attach coordinate scales x_um, y_um, z_um (voxel centres, µm) to a volume's three axes.

    Volumes of one file with the same grid share the scales; a volume on another grid gets its own
    (``x_um_<name>`` …), since one dimension name has one length.
    """
    voxel = np.broadcast_to(np.asarray(voxel_um, dtype=np.float64).ravel(), (3,))
    for axis, base in enumerate(AXIS_NAMES):
        coords = centres_um(dset.shape[axis], origin_um[axis], voxel[axis])
        name = base
        if name in group and not (
            group[name].shape == coords.shape and np.allclose(group[name][...], coords, rtol=1e-12, atol=0)
        ):
            name = f"{base}_{dset.name.rsplit('/', 1)[-1]}"
        dset.dims[axis].attach_scale(_scale(group, name, coords, MICROMETRE))


def label_dims(group: h5py.Group, dims_of: dict[str, Sequence[str]], coords: dict | None = None) -> None:
    """Name the axes of plain datasets of ``group`` by HDF5 dimension scales, so xarray reads them with named dims.

    Parameters
    ----------
    group : h5py.Group
        Where the datasets and their scales live.
    dims_of : dict of dataset name -> sequence of str
        The dimension name of each axis of each dataset (e.g. ``{"centres_um": ("sphere", "xyz")}``).
    coords : dict of dimension name -> array_like, optional
        Coordinate values of a dimension (e.g. ``{"xyz": ["x", "y", "z"]}``); others get 0, 1, 2 …
    """
    coords = coords or {}
    for name, dims in dims_of.items():
        dset = group[name]
        if len(dims) != dset.ndim:
            raise PorepipeError(
                f"dataset {name!r} has {dset.ndim} axes but {len(dims)} dimension names {dims}"
            )
        for axis, dim in enumerate(dims):
            values = coords.get(dim)
            if values is None:
                values = np.arange(dset.shape[axis], dtype=np.int64)
            values = np.asarray(values)
            if values.dtype.kind == "U":
                values = values.astype(h5py.string_dtype())
            units = DIMENSIONLESS if values.dtype.kind in "iuf" else None
            dset.dims[axis].attach_scale(_scale(group, dim, values, units))


# -- readers -----------------------------------------------------------------------------------------------------------
def _check_file(path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise PorepipeError(f"result file {path} does not exist")
    return path


#: attributes HDF5 dimension scales and netCDF keep for themselves (not metadata of the data)
_INTERNAL_ATTRS = frozenset(
    {"DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME", "_Netcdf4Dimid", "_Netcdf4Coordinates"}
)


def dataset_attrs(dset) -> dict:
    """The attributes of an h5py dataset, decoded, without the dimension-scale bookkeeping."""
    return {k: _decode(v) for k, v in dset.attrs.items() if k not in _INTERNAL_ATTRS}


def _decode(value):
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def read_attrs(path) -> dict:
    """Root attributes of a result file (the provenance and cost record)."""
    path = _check_file(path)
    with open_h5(path) as f:
        try:
            attrs = {k: _decode(v) for k, v in f.attrs.items()}
        except (OSError, RuntimeError, KeyError, TypeError, ValueError) as err:
            raise _damaged(path, err) from None
    if "stage" not in attrs:
        raise PorepipeError(f"{path} is not a porepipe result (no 'stage' attribute)")
    return attrs


#: the name of a binary volume (``binary_a{a}.h5``: uint8, 1 = pore, 0 = matrix)
BINARY_VOLUME = "pore"


def check_binary_values(values: np.ndarray, path, name: str = BINARY_VOLUME) -> np.ndarray:
    """Return ``values`` if it holds only 0 and 1; otherwise an error naming the file and the values found.

    One rule for every stage: a "binary" volume with other values (a label image, a grey volume under the wrong
    name) is refused, never read as "anything non-zero is pore" by one stage and refused by another.

    Parameters
    ----------
    values : ndarray
        Voxels read from a binary volume (uint8; other types are left to the caller's dtype check).
    path : path-like
        The file they came from (for the message).
    name : str, optional
        The volume's name (for the message).

    Returns
    -------
    ndarray
        ``values`` unchanged.
    """
    values = np.asarray(values)
    if values.size and values.dtype == np.uint8 and int(values.max()) > 1:
        found = np.flatnonzero(np.bincount(values.ravel(), minlength=256))
        shown = ", ".join(str(v) for v in found[:8]) + (", …" if found.size > 8 else "")
        raise PorepipeError(
            f"{path}: binary volume {name!r} holds the values {{{shown}}}; allowed: 0 (matrix) and 1 (pore) "
            "only (segment a grey or label volume first)"
        )
    return values


class _BinaryDataset:
    """An open binary volume whose every read is checked by :func:`check_binary_values` (else as h5py.Dataset)."""

    def __init__(self, dset: h5py.Dataset, path):
        self._dset, self._path = dset, path

    def __getattr__(self, attr):
        return getattr(self._dset, attr)

    def __getitem__(self, key):
        return check_binary_values(self._dset[key], self._path, self._dset.name.rsplit("/", 1)[-1])

    def __len__(self) -> int:
        return len(self._dset)


@contextlib.contextmanager
def open_h5(path) -> Iterator[h5py.File]:
    """Open an HDF5 file for reading; a damaged file is one :class:`PorepipeError` naming it.

    Covers the file that HDF5 cannot open (truncated, not HDF5) and h5py's errors from damaged metadata met inside
    the block (OSError, RuntimeError, KeyError from a broken object header), each with the file's name.
    """
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise PorepipeError(f"{path} is not a readable HDF5 file (truncated or damaged?): {err}") from None
    with f:
        try:
            yield f
        except (OSError, RuntimeError, KeyError) as err:
            raise _damaged(path, err) from None


def _damaged(path, err: Exception, what: str = "HDF5 content") -> PorepipeError:
    """One line for a file whose ``what`` h5py or xarray could not read (damaged, or written by something else)."""
    text = " ".join(str(err).split())[:200]
    return PorepipeError(
        f"{path}: cannot read its {what} ({type(err).__name__}: {text}); is it damaged, or another stage's file?"
    )


@contextlib.contextmanager
def open_volume(path, name: str) -> Iterator[h5py.Dataset]:
    """Open ``/volumes/<name>`` of a result file for chunked reading.

    Parameters
    ----------
    path : path-like
        A result file.
    name : str
        The volume's name (its coordinate scales ``x_um`` … are not volumes). The binary volume (``pore``) comes
        wrapped so that every read refuses values other than 0 and 1 (:func:`check_binary_values`).

    Yields
    ------
    h5py.Dataset
        The open volume; damaged HDF5 content read inside the block is one :class:`PorepipeError` naming the file.
    """
    path = _check_file(path)
    with open_h5(path) as f:
        try:
            group = f.get(VOLUME_GROUP)
            if not isinstance(group, h5py.Group) or name not in group or _is_scale(group[name]):
                have = volume_names(group) if isinstance(group, h5py.Group) else []
                raise PorepipeError(f"{path} has no volume {name!r} (volumes present: {have or 'none'})")
            dset = group[name]
            if not isinstance(dset, h5py.Dataset):
                raise PorepipeError(f"{path}: /{VOLUME_GROUP}/{name} is not a dataset")
        except (OSError, RuntimeError, KeyError, TypeError, ValueError) as err:
            raise _damaged(path, err) from None
        try:
            yield _BinaryDataset(dset, path) if name == BINARY_VOLUME else dset
        except (OSError, RuntimeError) as err:  # h5py's own read errors (a damaged chunk, a bad filter)
            raise _damaged(path, err) from None


def volume_names(group: h5py.Group) -> list[str]:
    """Names of the volumes in an open ``/volumes`` group (its coordinate scales left out), sorted."""
    return sorted(k for k, v in group.items() if isinstance(v, h5py.Dataset) and not v.is_scale)


def read_volume(path, name: str) -> tuple[np.ndarray, dict]:
    """Read a whole volume and its attributes (``voxel_um``, ``origin_um``, ``periodic`` …)."""
    with open_volume(path, name) as dset:
        return dset[...], dataset_attrs(dset)


def read_array(path, name: str) -> np.ndarray:
    """Read ``/arrays/<name>``."""
    path = _check_file(path)
    with open_h5(path) as f:
        try:
            group = f.get(ARRAY_GROUP)
            if not isinstance(group, h5py.Group) or name not in group:
                raise PorepipeError(f"{path} has no array {name!r}")
            return group[name][...]
        except (OSError, RuntimeError, KeyError, TypeError, ValueError) as err:
            raise _damaged(path, err) from None


def open_result(path) -> xr.Dataset:
    """The whole result file as one lazily loaded :class:`xarray.Dataset`, whatever stage wrote it.

    Parameters
    ----------
    path : path-like
        Any porepipe result (``packing.h5``, ``grey_a2.h5``, ``binary_a2.h5``, ``minkowski_a1.h5``, ``sweep.h5`` …).

    Returns
    -------
    xarray.Dataset
        The root table, the volumes (dims ``x_um``, ``y_um``, ``z_um`` with voxel-centre coordinates in µm) and the
        named arrays, merged; the file's provenance and cost (stage, scene, wall_s, cpu_s …) as ``attrs``. Further
        tables of named groups (``history``, ``lpt`` …) stay where they are: ``read_table(path, group)``.
        Volumes are read only when their values are used.

    Raises
    ------
    PorepipeError
        The file is missing or not a porepipe result.
    """
    attrs = read_attrs(path)
    with open_h5(path) as f:
        groups = [None] + [g for g in (VOLUME_GROUP, ARRAY_GROUP) if g in f]
    parts = []
    try:
        for g in groups:
            parts.append(
                xr.open_dataset(path, engine="h5netcdf", group=g, phony_dims="sort", decode_timedelta=False)
            )
        ds = xr.merge(parts, compat="no_conflicts", join="outer", combine_attrs="drop_conflicts")
    except (OSError, RuntimeError, KeyError, TypeError, ValueError) as err:
        for part in parts:
            part.close()
        raise _damaged(path, err, "groups") from None
    ds.attrs = {**ds.attrs, **attrs}
    ds.set_close(lambda: [part.close() for part in parts])  # `with open_result(p) as ds` closes the file
    return ds


def read_table(path, group: str | None = None) -> xr.Dataset:
    """Load the xarray Dataset of the root group (or of ``group``) into memory."""
    path = _check_file(path)
    try:
        with xr.open_dataset(
            path, engine="h5netcdf", group=group, phony_dims="sort", decode_timedelta=False
        ) as ds:
            return ds.load()
    except (OSError, RuntimeError, KeyError, TypeError, ValueError) as err:
        raise _damaged(path, err, f"table{f' {group!r}' if group else ''}") from None


# -- the metadata of a volume, read one way ---------------------------------------------------------------------------
#: attributes every volume carries (written by :meth:`ResultWriter.create_volume`)
VOLUME_META_KEYS = ("voxel_um", "origin_um", "periodic")


@dataclasses.dataclass(frozen=True)
class VolumeMeta:
    """Geometry of a stored volume: voxel edge (µm), origin of voxel (0, 0, 0)'s corner (µm), periodicity per axis.

    ``attrs`` holds every attribute of the dataset (``threshold``, ``method`` …), decoded to Python values.
    """

    voxel_um: float
    origin_um: tuple[float, float, float]
    periodic: tuple[bool, bool, bool]
    attrs: dict = dataclasses.field(default_factory=dict, compare=False)
    #: voxel edges along x, y, z (µm): three equal values unless read with ``anisotropic=True``
    voxel_xyz_um: tuple[float, float, float] = ()


def volume_meta(dset: h5py.Dataset, path, anisotropic: bool = False) -> VolumeMeta:
    """The :class:`VolumeMeta` of an open volume; a missing or malformed attribute is an error naming file and key.

    Parameters
    ----------
    dset : h5py.Dataset
        An open ``/volumes/<name>`` dataset (from :func:`open_volume`).
    path : path-like
        The file it came from (for the message).
    anisotropic : bool
        Accept three different voxel edges (serial sections); ``voxel_xyz_um`` holds them and ``voxel_um`` the x edge.
        Stages that need cubic voxels leave it False and get a clear error instead.

    Returns
    -------
    VolumeMeta
    """
    attrs = dataset_attrs(dset)
    missing = [k for k in VOLUME_META_KEYS if k not in attrs]
    if missing:
        raise PorepipeError(
            f"{path}: volume {dset.name} lacks the attribute(s) {', '.join(missing)}; a porepipe "
            "volume needs voxel_um, origin_um and periodic (rewrite it with a current porepipe)"
        )
    voxel = _numbers(attrs["voxel_um"])
    if voxel.size == 3 and np.allclose(voxel, voxel[0], rtol=1e-9, atol=0):
        voxel = voxel[:1]
    if (
        voxel.size not in ((1, 3) if anisotropic else (1,))
        or not np.all(np.isfinite(voxel))
        or np.any(voxel <= 0)
    ):
        kind = "anisotropic voxels are not supported" if voxel.size == 3 else "not a voxel edge"
        raise PorepipeError(
            f"{path}: volume {dset.name} attribute voxel_um = {attrs['voxel_um']!r}: {kind}; "
            "allowed: one positive number in µm (cubic voxels; resample anisotropic images first)"
        )
    voxel_xyz = tuple(float(v) for v in np.broadcast_to(voxel, (3,)))
    origin = _numbers(attrs["origin_um"])
    periodic = np.asarray(attrs["periodic"]).ravel()
    if origin.size != 3 or not np.all(np.isfinite(origin)):
        raise PorepipeError(
            f"{path}: volume {dset.name} attribute origin_um = {attrs['origin_um']!r}; allowed: "
            "3 finite numbers (µm)"
        )
    if periodic.size != 3 or not np.all(np.isin(periodic, (0, 1))):
        raise PorepipeError(
            f"{path}: volume {dset.name} attribute periodic = {attrs['periodic']!r}; allowed: "
            "3 flags 0/1 (x, y, z)"
        )
    return VolumeMeta(
        float(voxel[0]), tuple(float(o) for o in origin), tuple(bool(p) for p in periodic), attrs, voxel_xyz
    )


def _numbers(value) -> np.ndarray:
    """``value`` as a 1-D float array; NaN where it is not numeric (a string, a date), so the caller's check refuses it."""
    try:
        return np.atleast_1d(np.asarray(value, dtype=np.float64)).ravel()
    except (TypeError, ValueError):
        return np.full(1, np.nan)


def read_binary_volume(path, name: str = "pore", anisotropic: bool = False) -> tuple[np.ndarray, VolumeMeta]:
    """Read a binary volume (``binary_a{a}.h5``: uint8, 1 = pore) and its geometry, refusing incomplete metadata.

    Parameters
    ----------
    path : path-like
        A result file with ``/volumes/<name>``.
    name : str, optional
        The volume's name (default ``pore``).
    anisotropic : bool
        Accept per-axis voxel edges (see :func:`volume_meta`).

    Returns
    -------
    pore : (X, Y, Z) ndarray of uint8
        1 = pore, 0 = matrix.
    meta : VolumeMeta
        ``voxel_um`` (float, µm), ``origin_um`` (3 floats, µm), ``periodic`` (3 bools) and all attributes.

    Raises
    ------
    PorepipeError
        The file or volume is missing, or lacks ``voxel_um``, ``origin_um`` or ``periodic`` (the message names the
        file and the attribute), or the volume is not 3-D uint8.
    """
    with open_volume(path, name) as dset:
        meta = volume_meta(dset, path, anisotropic)
        if dset.ndim != 3 or dset.dtype != np.uint8:
            raise PorepipeError(
                f"{path}: volume {name!r} is {dset.ndim}-D {dset.dtype}; a binary volume is 3-D "
                "uint8 (1 = pore)"
            )
        return check_binary_values(dset[...], path, name), meta
