"""Files of the packing stage: ``packing.h5`` (the result), ``xyzr`` export, checkpoints.

``packing.h5`` root datasets: ``centres_um`` (N, 3) float64, ``radii_um`` (N,) float64, ``types`` (N,) int32,
``max_overlap`` (N,) float64, ``converged`` (N,) uint8, over the named dimensions ``sphere`` and ``xyz`` (HDF5
dimension scales, so ``xarray.open_dataset(path, engine="h5netcdf")`` or :func:`porepipe.open_result` gives a
Dataset over sphere × xyz), each with ``units``; root attributes ``box_um`` (3,), ``periodic`` (3,) int8,
``type_names``, ``converged`` (all spheres converged), ``stage_converged``, ``stage_steps``. The per-step history
is an xarray Dataset in group ``history`` (``xarray.open_dataset(path, engine="h5netcdf", group="history")``);
each stage's final spheres are kept under ``stages/<index>_<name>/``.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import xarray as xr

from porepipe._shared.atomic import atomic_path
from porepipe._shared.cost import SpentClock, carried_by
from porepipe._shared.errors import PorepipeError
from porepipe._shared.spheres import write_xyzr
from porepipe._shared.store import label_dims
from porepipe._shared.units import DIMENSIONLESS, MICROMETRE
from porepipe.packing._types import EFFECT_BITS, HISTORY_KEYS, Packing, State

_SPHERE_KEYS = ("centres_um", "radii_um", "types", "max_overlap", "converged")
#: axes and units of the sphere datasets (max_overlap is relative to the smaller radius: dimensionless)
_SPHERE_DIMS = {
    "centres_um": ("sphere", "xyz"),
    "radii_um": ("sphere",),
    "types": ("sphere",),
    "max_overlap": ("sphere",),
    "converged": ("sphere",),
}
_SPHERE_UNITS = {
    "centres_um": MICROMETRE,
    "radii_um": MICROMETRE,
    "types": DIMENSIONLESS,
    "max_overlap": DIMENSIONLESS,
    "converged": DIMENSIONLESS,
}
_STATE_ARRAYS = ("x", "v", "f", "r", "types", "frozen", "x_build", "r_build", "ids")
_STATE_INTS = ("since_build", "stage", "step", "nconv_prev", "next_id")


def history_dataset(packing: Packing) -> xr.Dataset:
    """The per-step history as an xarray Dataset along dimension ``row`` (one row per step of every stage)."""
    return xr.Dataset(
        {k: ("row", np.asarray(v)) for k, v in packing.history.items()},
        attrs={"effects_bits": json.dumps({e.value: b for e, b in EFFECT_BITS.items()})},
    )


def write_packing(writer, packing: Packing) -> None:
    """Write a packing into an open :class:`porepipe._shared.store.ResultWriter`."""
    h5 = writer.h5
    h5.create_dataset("centres_um", data=packing.centres_um.astype(np.float64))
    h5.create_dataset("radii_um", data=packing.radii_um.astype(np.float64))
    h5.create_dataset("types", data=packing.types.astype(np.int32))
    h5.create_dataset("max_overlap", data=packing.max_overlap.astype(np.float64))
    h5.create_dataset("converged", data=packing.converged.astype(np.uint8))
    for i, snap in enumerate(packing.snapshots):
        g = h5.create_group(f"stages/{i}_{snap['name']}")
        for key in _SPHERE_KEYS:
            g.create_dataset(key, data=snap[key])
        _describe_spheres(g)
    _describe_spheres(h5)
    writer.attrs.update(
        {
            "box_um": np.asarray(packing.box_um, dtype=np.float64),
            "periodic": np.asarray(packing.periodic, dtype=np.int8),
            "type_names": json.dumps(packing.type_names),
            "converged": int(packing.all_converged),
            "stage_converged": np.asarray(packing.stage_converged, dtype=np.int8),
            "stage_steps": np.asarray(packing.stage_steps, dtype=np.int64),
            "n_spheres": int(packing.radii_um.size),
        }
    )
    writer.write_table(history_dataset(packing), group="history")


def _describe_spheres(group) -> None:
    """Units and named dimensions (sphere, xyz) on the sphere datasets of ``group``."""
    for key, units in _SPHERE_UNITS.items():
        group[key].attrs["units"] = units
    label_dims(group, _SPHERE_DIMS, coords={"xyz": ["x", "y", "z"]})


def read_packing(path) -> dict:
    """Read the spheres and attributes of a ``packing.h5`` into a dict of arrays."""
    path = Path(path)
    if not path.is_file():
        raise PorepipeError(f"packing file {path} does not exist")
    with h5py.File(path, "r") as f:
        missing = [k for k in _SPHERE_KEYS if k not in f]
        if missing:
            raise PorepipeError(f"{path} is not a packing file: missing dataset(s) {missing}")
        out = {k: f[k][...] for k in _SPHERE_KEYS}
        out["box_um"] = f.attrs["box_um"][...]
        out["periodic"] = f.attrs["periodic"][...].astype(bool)
        out["type_names"] = json.loads(f.attrs["type_names"])
        out["all_converged"] = bool(f.attrs["converged"])
    return out


def write_xyzr_file(path, packing: Packing) -> None:
    """PackDEM ``xyzr`` export: one sphere per line, ``x y z r`` in µm."""
    write_xyzr(path, packing.centres_um, packing.radii_um)


def save_checkpoint(path, state: State, key: str = "", clock: SpentClock | None = None) -> None:
    """Write the full engine state atomically (temporary name, then rename), tagged with ``key``.

    ``key`` is the hash of everything that determines the packing (:func:`porepipe.packing._api.checkpoint_key`);
    a resume refuses a checkpoint whose key differs. ``clock``: what the run has spent so far, recorded so that a
    resumed run's cost includes it. Every part of the file is checksummed (the datasets by HDF5's Fletcher-32
    filter, the metadata and attributes by the newest file format), so :func:`load_checkpoint` refuses a damaged
    file instead of resuming from garbage.
    """
    with atomic_path(path) as tmp, h5py.File(tmp, "w", libver="latest") as f:
        f.attrs["key"] = key
        if clock is not None:
            clock.record(f.attrs)
        for key in _STATE_ARRAYS:
            f.create_dataset(key, data=getattr(state, key), fletcher32=True)
        for key in _STATE_INTS:
            f.attrs[key] = int(getattr(state, key))
        f.attrs["need_rebuild"] = int(state.need_rebuild)
        f.attrs["stage_converged"] = np.asarray(state.stage_converged, dtype=np.int8)
        f.attrs["stage_steps"] = np.asarray(state.stage_steps, dtype=np.int64)
        h = f.create_group("history")
        for key in HISTORY_KEYS:
            h.create_dataset(key, data=np.asarray(state.history[key]), fletcher32=True)
        for i, snap in enumerate(state.snapshots):
            g = f.create_group(f"snapshots/{i}")
            g.attrs["name"] = snap["name"]
            for key in _SPHERE_KEYS:
                g.create_dataset(key, data=snap[key], fletcher32=True)


#: what h5py raises on a damaged file (a checksum that fails, a broken structure, a missing or malformed part)
_DAMAGED = (OSError, RuntimeError, KeyError, ValueError, TypeError)


def read_checkpoint_key(path) -> str:
    """The key a checkpoint was written with ('' for a checkpoint written before keys existed).

    Raises
    ------
    PorepipeError
        ``path`` cannot be read as an HDF5 file (damaged, truncated, not HDF5).
    """
    try:
        with h5py.File(path, "r") as f:
            value = f.attrs.get("key", "")
    except _DAMAGED as err:
        raise PorepipeError(f"checkpoint {path} cannot be read ({type(err).__name__}: {err})") from None
    return value.decode() if isinstance(value, bytes) else str(value)


def load_checkpoint(path) -> State:
    """Read a checkpoint written by :func:`save_checkpoint`.

    Raises
    ------
    PorepipeError
        ``path`` is not a packing checkpoint, or a part of it cannot be read (damaged, truncated: its checksums).
    """
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            missing = [k for k in _STATE_ARRAYS if k not in f]
            if missing:
                raise PorepipeError(f"checkpoint {path} lacks {missing}; was it written by porepipe pack?")
            return _read_state(f)
    except _DAMAGED as err:
        raise PorepipeError(f"checkpoint {path} cannot be read ({type(err).__name__}: {err})") from None


def _read_state(f) -> State:
    """The :class:`State` stored in the open checkpoint ``f``."""
    arrays = {k: f[k][...] for k in _STATE_ARRAYS}
    ints = {k: int(f.attrs[k]) for k in _STATE_INTS}
    history = {k: f["history"][k][...].tolist() for k in HISTORY_KEYS}
    snaps = []
    for i in range(len(f["snapshots"]) if "snapshots" in f else 0):
        g = f[f"snapshots/{i}"]
        snaps.append({"name": str(g.attrs["name"]), **{k: g[k][...] for k in _SPHERE_KEYS}})
    return State(
        **arrays,
        **ints,
        need_rebuild=bool(f.attrs["need_rebuild"]),
        history=history,
        stage_converged=[bool(b) for b in f.attrs["stage_converged"]],
        stage_steps=[int(s) for s in f.attrs["stage_steps"]],
        snapshots=snaps,
        carried=carried_by(f.attrs),
    )
