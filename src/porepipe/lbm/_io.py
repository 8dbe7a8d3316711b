"""Result files ``perm_a{a}_{axis}.h5`` and a VTK ImageData (.vti) export of the flow fields for ParaView."""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np

from porepipe._shared.atomic import write_text_atomic
from porepipe._shared.store import ResultWriter
from porepipe.lbm._api import PermeabilityResult


def write_result(
    path,
    result: PermeabilityResult,
    *,
    scene: str = "",
    scene_hash: str = "",
    threads: int | None = None,
    origin_um=(0.0, 0.0, 0.0),
) -> Path:
    """Write one axis's result atomically (tables at the root, fields under ``/volumes`` if present)."""
    path = Path(path)
    with ResultWriter(path, stage="permeability", scene=scene, scene_hash=scene_hash, threads=threads) as w:
        w.write_table(result.to_dataset())
        w.attrs.update(result.attrs())
        w.attrs.update(
            kappa_lu=result.kappa_lu,
            kappa_m2=result.kappa_m2,
            kappa_mD=result.kappa_mD,
            kappa_D=result.kappa_D,
        )
        if result.velocity is not None:
            common = {"voxel_um": result.voxel_um, "origin_um": origin_um, "periodic": (False, False, False)}
            for k, name in enumerate("xyz"):
                w.write_volume(
                    f"velocity_{name}",
                    result.velocity[k],
                    **common,
                    attrs={"units": "lattice (voxel per step)", "meaning": "fluid velocity, 0 in solid"},
                )
            w.write_volume(
                "pressure",
                result.pressure,
                **common,
                attrs={"units": "lattice (rho/3)", "meaning": "pressure, NaN in solid"},
            )
    if result.settings.write_vti and result.velocity is not None:
        write_vti(
            path.with_suffix(".vti"),
            {"velocity": result.velocity, "pressure": result.pressure},
            spacing=result.voxel_um,
            origin=origin_um,
        )
    return path


def _encode(array: np.ndarray) -> str:
    raw = np.ascontiguousarray(array).astype("<f8").tobytes()
    return base64.b64encode(np.array([len(raw)], dtype="<u8").tobytes() + raw).decode("ascii")


def write_vti(path, fields: dict[str, np.ndarray], *, spacing: float, origin=(0.0, 0.0, 0.0)) -> Path:
    """Write cell data on a regular grid as VTK XML ImageData (base64 binary, UInt64 headers), atomically.

    Parameters
    ----------
    fields : dict of name -> (X, Y, Z) or (3, X, Y, Z) ndarray
        Scalars or 3-vectors per voxel (cell). NaN is written as NaN.
    spacing : float
        Voxel edge (µm).
    """
    path = Path(path)
    shape = None
    arrays = []
    for name, data in fields.items():
        vector = data.ndim == 4
        grid = data.shape[1:] if vector else data.shape
        shape = shape or grid
        # VTK order: x fastest, then y, then z; vector components interleaved per cell
        values = np.stack(list(data), axis=-1).transpose(2, 1, 0, 3) if vector else data.transpose(2, 1, 0)
        ncomp = 3 if vector else 1
        arrays.append(
            f'        <DataArray type="Float64" Name="{name}" NumberOfComponents="{ncomp}" '
            f'format="binary">\n{_encode(values)}\n        </DataArray>'
        )
    extent = f"0 {shape[0]} 0 {shape[1]} 0 {shape[2]}"
    text = "\n".join(
        [
            '<?xml version="1.0"?>',
            '<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
            (
                f'  <ImageData WholeExtent="{extent}" Origin="{origin[0]} {origin[1]} {origin[2]}" '
                f'Spacing="{spacing} {spacing} {spacing}">'
            ),
            f'    <Piece Extent="{extent}">',
            "      <CellData>",
            *arrays,
            "      </CellData>",
            "    </Piece>",
            "  </ImageData>",
            "</VTKFile>",
            "",
        ]
    )
    return write_text_atomic(path, text)
