"""File in -> compute -> file out: ``run`` reads a binary volume, runs one axis and writes ``diffusion_a{a}_{axis}.h5``.

The result's root group is an xarray Dataset (``xarray.open_dataset(path, engine="h5netcdf")``): the scalars
(W, D in voxel²/jiffie and m²/s, errors, Ψ, χ, τ, porosities, counts) as 0-d variables, the profiles, wall-hit maps,
orientation histogram and msd curve as arrays, the definitions and the settings as attributes, and the cost
(wall/CPU s, peak MB, threads) in the root attributes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_attrs, read_binary_volume, result_hash
from porepipe.diffusion import _api, _edmd
from porepipe.diffusion._length_series import series_runs
from porepipe.diffusion._reaction_study import study_result
from porepipe.diffusion._settings import Axis, Settings, Setup
from porepipe.diffusion._surface import surface_result

#: units of the scalars written to the result (others are counts or dimensionless)
UNITS = {
    "D": "voxel^2/jiffie",
    "D_err": "voxel^2/jiffie",
    "D_eff": "voxel^2/jiffie",
    "D_ref": "voxel^2/jiffie",
    "D_eff_err": "voxel^2/jiffie",
    "mean_free_flight": "voxel",
    "four_v_over_s": "voxel",
    "length": "voxel",
    "open_area": "voxel^2",
    "pore_volume": "voxel^3",
    "wall_area": "voxel^2",
    "hit_rate": "1/jiffie",
    "jiffie_s": "s",
    "mean_speed_m_s": "m/s",
    "wk_time_jiffies": "jiffie",
    "t_end": "jiffie",
}


def _dataset(result: _api.DiffusionResult, settings: Settings) -> xr.Dataset:
    data = {}
    for key, value in result.values.items():
        attrs = {"units": "m^2/s"} if key.endswith("_m2_s") else {"units": UNITS.get(key, "1")}
        data[key] = xr.Variable((), float(value), attrs)
    arr = result.arrays
    if "profile" in arr:
        data["profile_time"] = xr.Variable(
            ("axial_bin",), arr["profile"], {"units": "jiffie", "meaning": "time spent per axial bin"}
        )
        data["concentration"] = xr.Variable(
            ("axial_bin",),
            arr["concentration"],
            {"units": "voxel^-3", "meaning": "time-averaged particles per voxel³ per simulated particle"},
        )
    if "hit_map" in arr:
        data["hit_map"] = xr.Variable(
            ("face", "map_a", "map_b"),
            arr["hit_map"],
            {
                "units": "1",
                "meaning": "wall hits per face (-x,+x,-y,+y,-z,+z: the direction of flight) "
                "binned over the face's two tangent axes in increasing order",
            },
        )
    if "orientation" in arr:
        data["orientation"] = xr.Variable(
            ("cos_axis_bin", "azimuth_bin"),
            arr["orientation"],
            {
                "units": "1",
                "meaning": "flights by cos(angle to the transport axis) in [-1, 1] and "
                "azimuth about it in [-pi, pi)",
            },
        )
    for key in sorted(arr.keys() - {"profile", "concentration", "hit_map", "orientation", "msd", "msd_time"}):
        value = np.asarray(arr[key])  # setups edmd / reaction: arrays named with their unit
        data[key] = xr.Variable(tuple(f"{key}_{k}" for k in range(value.ndim)), value)
    if "msd" in arr:
        data["msd"] = xr.Variable(("time", "xyz"), arr["msd"], {"units": "voxel^2"})
        data["time"] = xr.Variable(("time",), arr["msd_time"], {"units": "jiffie"})
    if "history" in arr:  # statistical error against cost, one row per round (see _api.HISTORY_FIELDS)
        for k, name in enumerate(_api.HISTORY_FIELDS):
            meaning = "this round's kernel CPU s" if name == "round_cpu_s" else "cumulative after the round"
            data[f"history_{name}"] = xr.Variable(("round",), arr["history"][:, k], {"meaning": meaning})
    ds = xr.Dataset(data)
    ds.attrs["definitions"] = _api.__doc__.split("Definitions (also written into every result)")[1].strip()
    ds.attrs["settings"] = json.dumps(settings.model_dump(mode="json"), sort_keys=True)
    return ds


def run(
    settings: Settings,
    binary,
    out,
    axis: Axis | str = Axis.z,
    *,
    seed: int = 0,
    scene: str = "",
    threads: int | None = None,
    checkpoint=None,
    resume: bool = False,
) -> Path:
    """Run the ``diffusion`` stage on one binary volume along one axis and write the result atomically.

    Parameters
    ----------
    settings : Settings
        The scene's ``diffusion`` section.
    binary : path
        ``binary_a{a}.h5`` with volume ``pore`` (uint8, 1 = pore) and attrs ``voxel_um``, ``origin_um``, ``periodic``.
    out : path
        Result file.
    axis : Axis
        Transport axis (for ``msd``: the axis whose D is the headline ``D``; the tensor is always written).
    seed : int
        Scene seed.
    checkpoint : path, optional
        Checkpoint file (default ``.{out}.checkpoint.npz`` beside ``out``); deleted on success.
    resume : bool
        Continue from a matching checkpoint (a mismatching one is discarded); without it, start afresh.
    """
    axis = Axis(axis)
    binary, out = Path(binary), Path(out)
    src = read_attrs(binary)
    pore, meta = read_binary_volume(binary, anisotropic=True)  # serial sections: per-axis voxel edges
    voxel_um = np.asarray(meta.voxel_xyz_um, dtype=float)
    periodic = np.asarray(meta.periodic, dtype=bool)
    checkpoint = Path(checkpoint) if checkpoint else out.with_name(f".{out.name}.checkpoint.npz")
    if not resume:
        checkpoint.unlink(missing_ok=True)
    if settings.setup is Setup.msd and not periodic.any():
        raise PorepipeError(
            f"{binary}: setup msd needs a periodic volume (attribute periodic = "
            f"{periodic.astype(int).tolist()}); use setup transmission for a closed sample"
        )
    # the writer is opened first, so the recorded wall/CPU time and peak memory include the computation
    with ResultWriter(
        out,
        stage="diffusion",
        scene=scene or src.get("scene", ""),
        scene_hash=result_hash("diffusion", settings=settings, inputs=[binary], axis=axis.value, seed=seed),
        threads=threads,
    ) as w:
        if settings.setup is Setup.edmd:
            result = _edmd.edmd_result(pore, settings, voxel_um, periodic, seed=seed, axis=axis.index)
        elif settings.setup is Setup.surface:
            result = surface_result(pore, settings, voxel_um, periodic, seed=seed)
        elif settings.setup is Setup.reaction and settings.reactions.series:
            result = study_result(pore, settings, axis.index, voxel_um, periodic, seed=seed)
        elif settings.setup is Setup.reaction:
            result = _edmd.reaction_result(pore, settings, axis.index, voxel_um, periodic, seed=seed)
        elif settings.setup is Setup.msd:
            result = _api.equilibrium(pore, settings, voxel_um, periodic, seed=seed, checkpoint=checkpoint)
            name = axis.value * 2
            if f"D_{name}" in result.values:
                result.values["D"] = result.values[f"D_{name}"]
                result.values["D_err"] = result.values[f"D_{name}_err"]
        elif settings.lengths:  # a length series (setup transmission; checked by Settings)
            series, runs = series_runs(
                pore, axis.index, settings.lengths, settings, voxel_um, periodic, seed=seed
            )
            arrays = {k: series.pop(k) for k in list(series) if k.startswith("series_")}
            stop = _api.stop_attrs(runs)
            result = _api.DiffusionResult("length_series", axis.value, series, arrays, attrs=stop)
        else:
            # the volume read here is ours: it becomes the distance codes in place (1 byte per voxel in all)
            pore = _api.prepare(
                np.ascontiguousarray(pore, np.uint8), voxel_um, periodic, axis.index, in_place=True
            )
            result = _api.transport(
                pore, axis.index, settings, voxel_um, periodic, seed=seed, checkpoint=checkpoint
            )
        if result.tallies is not None:
            w.carried = result.tallies.carried  # a resumed run's cost includes the processes before it
        w.write_table(_dataset(result, settings))
        w.attrs.update(
            setup=settings.setup.value,
            axis=axis.value,
            voxel_um=voxel_um,
            origin_um=np.asarray(meta.origin_um, dtype=float),
            wall_law=settings.wall_law.value,
            species=settings.species,
            temperature_K=settings.temperature_K,
            source=str(binary),
            **result.attrs,
        )
    checkpoint.unlink(missing_ok=True)
    return out
