"""Scene key ``diffusion.geometry``: the thesis's synthetic capillaries built from the scene instead of a packing.

A scene whose ``diffusion`` section has a ``geometry`` gets its binary volumes from the generators of
:mod:`porepipe.diffusion._geometry` (rule ``capillary``, CLI ``porepipe diffusion-capillary``), one per resolution.
Each size is given either in voxels (``radius: 5``) or in µm (``radius_um: 2.5``, divided by the resolution a); µm
sizes make the resolutions a refinement series of one continuum shape (a cylinder converging to Clausing's W).
"""

from __future__ import annotations

import enum
import math

from pydantic import BaseModel, ConfigDict, Field, model_validator

from porepipe._shared.budget import machine_bytes
from porepipe._shared.errors import PorepipeError

#: relative slack when a µm size must be a whole number of voxels
_WHOLE_RTOL = 1e-6


class CapillaryKind(str, enum.Enum):
    """Synthetic pore spaces of the thesis (§3.6, §4.2.3)."""

    square = "square"  # a x a x length channel (§3.6.3: 30 x 30 x 300)
    cylinder = "cylinder"  # voxelised circular tube of radius R (Clausing's W)
    slit = "slit"  # two plates, periodic across y
    constricted = "constricted"  # §4.2.3 A: a tube with two constrictions
    pocketed = "pocketed"  # §4.2.3 B: square channel with deep side pockets
    rough = "rough"  # §4.2.3 C: square channel with a randomly roughened wall layer


#: kind -> size keys it needs (each given in voxels or with the suffix _um in µm), in the generator's order
SIZES: dict[CapillaryKind, tuple[str, ...]] = {
    CapillaryKind.square: ("a", "length"),
    CapillaryKind.cylinder: ("radius", "length"),
    CapillaryKind.slit: ("width", "length", "depth"),
    CapillaryKind.constricted: ("radius", "length", "throat_radius", "throat_length"),
    CapillaryKind.pocketed: ("a", "length", "pocket_depth", "pocket_width"),
    CapillaryKind.rough: ("a", "length"),
}
#: size keys that may stay unset (their generator default is used)
_OPTIONAL = {"depth"}
#: kind -> sizes that need not be a whole number of voxels (the tube generators voxelise a continuum shape)
_REAL = {CapillaryKind.cylinder: {"radius", "length"}, CapillaryKind.constricted: {"radius", "length"}}
_ALL_SIZES = sorted({k for keys in SIZES.values() for k in keys})

_Size = float | None
_SIZE_FIELD = {"default": None, "gt": 0, "allow_inf_nan": False}


class CapillaryGeometry(BaseModel):
    """A synthetic capillary along z; sizes in voxels (``a``) or µm (``a_um``), exactly one of the two per size."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: CapillaryKind = Field(description="square, cylinder, slit, constricted, pocketed or rough")
    a: _Size = Field(**_SIZE_FIELD, description="channel side (square, pocketed, rough), voxels")
    a_um: _Size = Field(**_SIZE_FIELD, description="channel side in µm")
    radius: _Size = Field(**_SIZE_FIELD, description="tube radius (cylinder, constricted), voxels")
    radius_um: _Size = Field(**_SIZE_FIELD, description="tube radius in µm")
    length: _Size = Field(**_SIZE_FIELD, description="length along z, voxels")
    length_um: _Size = Field(**_SIZE_FIELD, description="length along z in µm")
    width: _Size = Field(**_SIZE_FIELD, description="slit width between the plates, voxels")
    width_um: _Size = Field(**_SIZE_FIELD, description="slit width in µm")
    depth: _Size = Field(
        **_SIZE_FIELD, description="slit extent across its periodic axis y, voxels (default 4)"
    )
    depth_um: _Size = Field(**_SIZE_FIELD, description="slit extent across y in µm")
    throat_radius: _Size = Field(**_SIZE_FIELD, description="constriction radius, voxels")
    throat_radius_um: _Size = Field(**_SIZE_FIELD, description="constriction radius in µm")
    throat_length: _Size = Field(**_SIZE_FIELD, description="constriction length, voxels")
    throat_length_um: _Size = Field(**_SIZE_FIELD, description="constriction length in µm")
    pocket_depth: _Size = Field(**_SIZE_FIELD, description="pocket depth into the wall, voxels")
    pocket_depth_um: _Size = Field(**_SIZE_FIELD, description="pocket depth in µm")
    pocket_width: _Size = Field(**_SIZE_FIELD, description="pocket width, voxels")
    pocket_width_um: _Size = Field(**_SIZE_FIELD, description="pocket width in µm")
    n_pockets: int = Field(3, ge=1, description="pockets (pocketed), alternating over the four walls")
    roughness: float = Field(
        0.3, ge=0.0, lt=1.0, description="probability that a wall-layer voxel is solid (rough)"
    )

    @model_validator(mode="after")
    def _sizes_of_kind(self):
        needed = SIZES[self.kind]
        problems = []
        for key in _ALL_SIZES:
            given = [k for k in (key, f"{key}_um") if getattr(self, k) is not None]
            if key not in needed and given:
                problems.append(
                    f"{given[0]} is not a size of kind {self.kind.value} (its sizes: {', '.join(needed)})"
                )
            elif key in needed and len(given) == 2:
                problems.append(f"give {key} (voxels) or {key}_um (µm), not both")
            elif key in needed and not given and key not in _OPTIONAL:
                problems.append(f"kind {self.kind.value} needs {key} (voxels) or {key}_um (µm)")
        if problems:
            raise ValueError("; ".join(problems))
        return self

    def voxel_sizes(self, a_um: float) -> dict[str, float]:
        """The sizes in voxels at resolution ``a_um``; a size that must be whole but is not is an error naming it."""
        out = {}
        for key in SIZES[self.kind]:
            vox, um = getattr(self, key), getattr(self, f"{key}_um")
            if vox is None and um is None:
                continue
            value, name = (vox, key) if vox is not None else (um / a_um, f"{key}_um")
            given = vox if vox is not None else um
            if key not in _REAL.get(self.kind, ()):
                whole = round(value)
                if whole < 1 or abs(value - whole) > _WHOLE_RTOL * max(1.0, value):
                    raise PorepipeError(
                        f"diffusion.geometry.{name} = {given!r} is {value:.6g} voxels at a = {a_um!r} µm; "
                        "allowed: a whole number of voxels >= 1"
                    )
                value = whole
            elif key == "length" and round(value) < 1:
                raise PorepipeError(
                    f"diffusion.geometry.{name} = {given!r} is {value:.6g} voxels at a = {a_um!r} µm; "
                    "allowed: at least one voxel"
                )
            out[key] = value
        return out


def check_capillary_resolutions(geometry: CapillaryGeometry, resolutions_um) -> None:
    """Raise a :class:`PorepipeError` naming the key if a size is not a whole number of voxels at some resolution."""
    for a in resolutions_um:
        geometry.voxel_sizes(float(a))


#: bytes per voxel of the bounding box while a capillary is built (the 1-byte volume, float64 cross-section grids)
_BUILD_BYTES_PER_VOXEL = 9


def _check_fits(size: dict, a_um: float) -> None:
    """Refuse a capillary whose bounding box (widest cross-section squared times length) cannot fit in memory."""
    across = max(
        size.get("a", 0.0) + 2.0 * size.get("pocket_depth", 0.0),
        2.0 * size.get("radius", 0.0),
        max(size.get("width", 0.0), size.get("depth", 4.0)),
    )
    need = _BUILD_BYTES_PER_VOXEL * (math.ceil(across) + 1) ** 2 * math.ceil(size["length"])
    if need > machine_bytes():
        raise PorepipeError(
            f"the capillary at a = {a_um!r} µm is ~{math.ceil(across)} x {math.ceil(across)} x "
            f"{math.ceil(size['length'])} voxels, {need / 1e9:.3g} GB to build, more than this machine's "
            f"{machine_bytes() / 1e9:.3g} GB; use a coarser resolution"
        )


def build_capillary(geometry: CapillaryGeometry, a_um: float, seed: int = 0):
    """The capillary at resolution ``a_um`` as a :class:`~porepipe.diffusion._geometry.PoreVolume` (voxels 1 x 1 x 1).

    Returns
    -------
    PoreVolume
        ``pore`` (uint8, 1 = pore), voxel edges in voxels (multiply by ``a_um`` for µm) and the periodic flags.
    """
    from porepipe.diffusion import _geometry as G

    if not 0.0 < float(a_um) < math.inf:
        raise PorepipeError(f"capillary resolution a = {a_um!r} µm: allowed a positive, finite voxel size")
    size = geometry.voxel_sizes(float(a_um))
    _check_fits(size, a_um)
    kind = geometry.kind
    if kind is CapillaryKind.square:
        return G.square_capillary(size["a"], size["length"])
    if kind is CapillaryKind.cylinder:
        return G.cylinder(size["radius"], size["length"])
    if kind is CapillaryKind.slit:
        return G.slit(size["width"], size["length"], size.get("depth", 4))
    if kind is CapillaryKind.constricted:
        if size["throat_radius"] >= size["radius"]:
            raise PorepipeError(
                f"diffusion.geometry.throat_radius ({size['throat_radius']} voxels) must be smaller than radius "
                f"({size['radius']:.6g} voxels)"
            )
        return G.constricted_capillary(
            size["radius"], size["length"], size["throat_radius"], size["throat_length"]
        )
    if kind is CapillaryKind.pocketed:
        return G.pocketed_capillary(
            size["a"], size["length"], size["pocket_depth"], size["pocket_width"], geometry.n_pockets
        )
    return G.rough_capillary(size["a"], size["length"], geometry.roughness, seed)


def write_capillary(geometry: CapillaryGeometry, a_um: float, out, *, seed: int = 0, scene: str = ""):
    """Write the capillary at resolution ``a_um`` as ``binary_a{a}.h5`` (volume ``pore``, 1 = pore), atomically.

    The file has what a segmented volume has (voxel_um, origin_um, periodic, a porosity table), so every stage that
    reads binary volumes reads it.
    """
    from pathlib import Path

    import numpy as np
    import xarray as xr

    from porepipe._shared.store import ResultWriter, result_hash

    vol = build_capillary(geometry, a_um, seed)
    porosity = float(np.count_nonzero(vol.pore)) / vol.pore.size
    digest = result_hash(
        "diffusion-capillary", geometry=geometry.model_dump(mode="json"), a_um=float(a_um), seed=seed
    )
    with ResultWriter(Path(out), stage="diffusion-capillary", scene=scene, scene_hash=digest) as w:
        w.write_volume(
            "pore",
            vol.pore,
            voxel_um=float(a_um),
            periodic=tuple(bool(p) for p in vol.periodic),
            attrs={"meaning": f"1 = pore of the synthetic {geometry.kind.value} capillary, 0 = solid"},
        )
        w.write_table(xr.Dataset({"porosity": ((), porosity)}))
        w.attrs.update(kind=geometry.kind.value, voxel_um=float(a_um), porosity=porosity)
    return Path(out)
