"""Result files ``perm_a{a}_{axis}.h5`` and a VTK ImageData (.vti) export of the flow fields for ParaView."""

from __future__ import annotations

from pathlib import Path

import numpy as np

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
        w.carried = result.carried  # a resumed run's cost includes the processes before it
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


def write_vti(path, fields: dict[str, np.ndarray], *, spacing: float, origin=(0.0, 0.0, 0.0)) -> Path:
    """Write cell data on a regular grid as VTK XML ImageData through the VTK library (zlib, appended binary).

    Parameters
    ----------
    fields : dict of name -> (X, Y, Z) or (3, X, Y, Z) ndarray
        Scalars or 3-vectors per voxel (cell). NaN is written as NaN.
    spacing : float
        Voxel edge (µm).
    origin : sequence of 3 float
        Corner of voxel (0, 0, 0), µm.
    """
    from porepipe.export import write_image

    cells = {name: np.moveaxis(data, 0, -1) if data.ndim == 4 else data for name, data in fields.items()}
    return write_image(path, cells, voxel_um=spacing, origin_um=origin)
