"""``grains.h5``: the decoration (type, rotation, scale per grain) and its grain-type library.

Layout (root xarray Dataset, readable with ``xarray.open_dataset(path, engine="h5netcdf")``):

- dims ``grain``: ``centre_um (grain, xyz)``, ``radius_um`` (sphere radius), ``type``, ``scale``,
  ``rotation (grain, row, col)`` (type frame -> world frame: x_world = c + scale · rotation @ x_type);
- dims ``type``: ``type_name``, ``kind`` (0 sphere, 1 polyhedron), ``family``, ``plane_start``/``plane_count`` into
  the ``plane`` arrays, and the exact measures ``volume``, ``area``, ``mean_curvature``, ``inradius``,
  ``centre_inradius``, ``circumradius`` at unit scale;
- dims ``plane``: ``normal (plane, xyz)``, ``offset`` (type planes n·x <= d at unit scale, type centroid at 0).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import read_table
from porepipe.decorate._api import Decoration
from porepipe.decorate._library import Kind, polyhedron, sphere_type

_MEASURES = ("volume", "area", "mean_curvature", "inradius", "centre_inradius", "circumradius")


def decoration_dataset(deco: Decoration, radii_um) -> xr.Dataset:
    """The decoration as an xarray Dataset (the root table of ``grains.h5``)."""
    lib = deco.library
    counts = np.array([t.n_faces for t in lib], dtype=np.int64)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    normals = np.concatenate([t.normals for t in lib]) if counts.sum() else np.zeros((0, 3))
    offsets = np.concatenate([t.offsets for t in lib]) if counts.sum() else np.zeros(0)
    data = {
        "centre_um": (("grain", "xyz"), deco.centres_um, {"units": "um"}),
        "radius_um": ("grain", np.asarray(radii_um, dtype=np.float64), {"long_name": "radius of the sphere"}),
        "type": ("grain", deco.types.astype(np.int64)),
        "scale": ("grain", deco.scales, {"long_name": "length scale, um per type unit"}),
        "rotation": (("grain", "row", "col"), deco.rotations, {"long_name": "type frame -> world frame"}),
        "type_name": ("type", np.array([t.name for t in lib], dtype=object)),
        "kind": (
            "type",
            np.array([int(t.kind) for t in lib], dtype=np.int64),
            {"meaning": "0 sphere, 1 polyhedron"},
        ),
        "family": ("type", deco.families.astype(np.int64)),
        "plane_start": ("type", start),
        "plane_count": ("type", counts),
        "normal": (("plane", "xyz"), normals),
        "offset": ("plane", offsets),
    }
    for m in _MEASURES:
        data[m] = ("type", np.array([getattr(t, m) for t in lib]), {"long_name": f"exact {m} at unit scale"})
    return xr.Dataset(data, attrs={"n_grains": len(deco), "n_types": len(lib)})


def read_grains(path) -> tuple[Decoration, np.ndarray]:
    """(Decoration, sphere radii) from a ``grains.h5``; library types are rebuilt (and re-measured) from the planes."""
    ds = read_table(path)
    missing = [
        k for k in ("centre_um", "type", "scale", "rotation", "normal", "offset", "kind") if k not in ds
    ]
    if missing:
        raise PorepipeError(f"{path} is not a grains file: missing {missing}")
    lib = []
    for t in range(ds.sizes["type"]):
        name = str(ds["type_name"].values[t])
        if int(ds["kind"].values[t]) == int(Kind.SPHERE):
            lib.append(sphere_type(name))
            continue
        s, n = int(ds["plane_start"].values[t]), int(ds["plane_count"].values[t])
        lib.append(
            polyhedron(
                name, ds["normal"].values[s : s + n], ds["offset"].values[s : s + n], centre=False, unit=True
            )
        )
    deco = Decoration(
        np.ascontiguousarray(ds["centre_um"].values),
        ds["type"].values.astype(np.int64),
        np.ascontiguousarray(ds["rotation"].values),
        ds["scale"].values.astype(np.float64),
        lib,
        ds["family"].values.astype(np.int64),
    )
    return deco, ds["radius_um"].values
