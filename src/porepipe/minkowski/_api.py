"""Minkowski functionals of binary and grey voxel volumes from the 2x2x2 configuration histogram.

Public functions check their input and convert units; the counting is done by the kernels in ``_kernels`` and the
weights come from ``_weights``. Lengths are in µm; densities are per unit volume of the observation window
(the union of the counted cells): S_V in µm⁻¹, K_V (integral of mean curvature per volume) in µm⁻², T_V = 4π χ_V
in µm⁻³ (Zauner 2020, §4.5, Eqs. 4.5.1-4.5.3).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

import numba
import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.units import from_voxel_units
from porepipe.minkowski import _kernels, _weights
from porepipe.minkowski._settings import Adjacency

PHASES = ("pore", "matrix")
#: largest ratio of voxel edges: beyond ~8e5 two of the 13 lattice directions are closer than the spherical Voronoi
#: tessellation of their weights can tell apart (scipy: 'Duplicate generators present')
MAX_ANISOTROPY = 1e5
UNITS = {"phi": "1", "S_V": "µm^-1", "K_V": "µm^-2", "T_V": "µm^-3", "chi": "1"}
_DESCRIPTIONS = {
    "phi": "volume fraction of the phase (φ for the pore phase)",
    "S_V": "surface area per volume (Crofton, 13 line directions)",
    "K_V": "integral of mean curvature per volume (Crofton, 13 plane families); K_V(pore) = -K_V(matrix)",
    "T_V": "4π χ_V: integral of Gaussian curvature per volume",
    "chi": "Euler number of the phase in the window (exact for a periodic volume or a body inside the window)",
}


# -- input checks ------------------------------------------------------------------------------------------------------
def _periodic3(periodic) -> tuple[bool, bool, bool]:
    if isinstance(periodic, (bool, np.bool_, int, np.integer)):
        return (bool(periodic),) * 3
    flags = tuple(bool(p) for p in periodic)
    if len(flags) != 3:
        raise PorepipeError(f"periodic needs one flag or 3 flags (x, y, z), got {periodic!r}")
    return flags


def voxel3(voxel_um) -> tuple[float, float, float]:
    """Voxel edge lengths (x, y, z) in µm from one number or three; raises on non-positive or non-finite values."""
    sizes = (
        np.broadcast_to(np.asarray(voxel_um, dtype=np.float64), (3,))
        if np.ndim(voxel_um) == 0
        else np.asarray(voxel_um, dtype=np.float64)
    )
    if sizes.shape != (3,) or not np.all(np.isfinite(sizes)) or np.any(sizes <= 0):
        raise PorepipeError(f"voxel_um must be one positive number or 3 (x, y, z), got {voxel_um!r}")
    if sizes.max() / sizes.min() > MAX_ANISOTROPY:
        raise PorepipeError(
            f"voxel_um = {voxel_um!r}: the longest edge is {sizes.max() / sizes.min():.3g} times the shortest; "
            f"allowed: up to {MAX_ANISOTROPY:g} (beyond, lattice directions coincide and have no Crofton weights)"
        )
    return tuple(float(s) for s in sizes)


def _check_plane_shape(shape: Sequence[int], periodic: tuple[bool, bool, bool], what: str) -> None:
    for axis, (n, wrap) in enumerate(zip(shape, periodic)):
        if n < 1 or (n < 2 and not wrap):
            raise PorepipeError(
                f"{what} has shape {tuple(shape)}: axis {'xyz'[axis]} has {n} voxel(s), but a non-periodic axis "
                f"needs at least 2 (a 2x2x2 cell must fit); mark the axis periodic or give a thicker volume"
            )


def _as_volume(volume, what: str = "volume") -> np.ndarray:
    arr = np.asarray(volume)
    if arr.ndim != 3:
        raise PorepipeError(f"{what} must be 3-D (x, y, z), got shape {arr.shape}")
    if arr.dtype == np.bool_:
        arr = arr.view(np.uint8)
    if arr.dtype != np.uint8:
        raise PorepipeError(f"{what} must be uint8 or bool, got dtype {arr.dtype}")
    return np.ascontiguousarray(arr)


def n_cells(shape: Sequence[int], periodic=True) -> int:
    """Number of 2x2x2 cells counted in a volume of ``shape``: n along periodic axes, n - 1 along the others."""
    flags = _periodic3(periodic)
    return int(np.prod([n if wrap else n - 1 for n, wrap in zip(shape, flags)], dtype=np.int64))


# -- histograms --------------------------------------------------------------------------------------------------------
def _blocks(n_pairs: int) -> int:
    return max(1, min(n_pairs, numba.get_num_threads()))


def configuration_histogram(volume, periodic=True) -> np.ndarray:
    """2x2x2 configuration histogram of a binary volume.

    Parameters
    ----------
    volume : (nx, ny, nz) uint8 or bool ndarray
        Non-zero = foreground (pore in a porepipe binary volume).
    periodic : bool or 3 bools
        Periodic axes wrap (n cells along them); along the others only complete cells are counted (n - 1),
        i.e. minus sampling.

    Returns
    -------
    (256,) int64 ndarray
        Count of each cell code; bit ``dx + 2 dy + 4 dz`` is the voxel at that offset.
    """
    flags = _periodic3(periodic)
    vol = _as_volume(volume)
    _check_plane_shape(vol.shape, flags, "volume")
    hist = np.zeros(_weights.N_CODES, dtype=np.int64)
    n_pairs = vol.shape[0] - 1 + int(flags[0])
    _kernels._configuration_histogram(vol, flags[0], flags[1], flags[2], _blocks(n_pairs), hist)
    return hist


def _stream(slabs: Iterable, periodic, count, table_shape, kind: str):
    """Run ``count(vol, wrap_x, wrap_y, wrap_z, blocks, out)`` over x-slabs; returns (table, shape)."""
    flags = _periodic3(periodic)
    out = np.zeros(table_shape, dtype=np.int64)
    first = last = None
    nx = 0
    plane_shape = None
    for index, slab in enumerate(slabs):
        slab = _as_volume(slab, f"slab {index}") if kind == "binary" else _as_grey(slab, f"slab {index}")
        if plane_shape is None:
            plane_shape = slab.shape[1:]
            _check_plane_shape((2,) + plane_shape, flags, f"slab {index}")
            first = slab[:1].copy()
        elif slab.shape[1:] != plane_shape:
            raise PorepipeError(
                f"slab {index} has shape {slab.shape}; every slab needs (nx, {plane_shape[0]}, "
                f"{plane_shape[1]}) like slab 0"
            )
        if last is not None:
            count(np.concatenate([last, slab[:1]]), False, flags[1], flags[2], 1, out)
        count(slab, False, flags[1], flags[2], _blocks(slab.shape[0] - 1), out)
        last = slab[-1:].copy()
        nx += slab.shape[0]
    if plane_shape is None:
        raise PorepipeError("no slabs given: a volume needs at least one x-slab")
    shape = (nx,) + plane_shape
    _check_plane_shape(shape, flags, "volume assembled from slabs")
    if flags[0]:
        count(np.concatenate([last, first]), False, flags[1], flags[2], 1, out)
    return out, shape


def configuration_histogram_slabs(slabs: Iterable, periodic=True) -> tuple[np.ndarray, tuple[int, int, int]]:
    """Configuration histogram of a volume given as consecutive x-slabs, holding two slabs at most in memory.

    The cells between slabs are counted from the last plane of one slab and the first of the next, so the result
    equals :func:`configuration_histogram` of the concatenated volume exactly.

    Parameters
    ----------
    slabs : iterable of (n_i, ny, nz) uint8/bool ndarrays
        Disjoint consecutive blocks along x (e.g. read chunk by chunk from HDF5, or generated).
    periodic : bool or 3 bools
        As for :func:`configuration_histogram`; a periodic x axis joins the last plane to the first.

    Returns
    -------
    histogram : (256,) int64 ndarray
    shape : (nx, ny, nz) of the whole volume
    """
    return _stream(slabs, periodic, _kernels._configuration_histogram, (_weights.N_CODES,), "binary")


def iter_slabs(dataset, thickness: int = 64) -> Iterator[np.ndarray]:
    """Yield consecutive x-slabs of ``thickness`` planes from an array-like (h5py dataset or ndarray)."""
    if thickness < 1:
        raise PorepipeError(f"slab thickness must be >= 1 plane, got {thickness}")
    for start in range(0, dataset.shape[0], thickness):
        yield np.asarray(dataset[start : start + thickness])


# -- functionals ---------------------------------------------------------------------------------------------------
def _check_histogram(histogram) -> np.ndarray:
    hist = np.asarray(histogram)
    if hist.shape[-1:] != (_weights.N_CODES,) or not np.issubdtype(hist.dtype, np.integer):
        raise PorepipeError(
            f"a configuration histogram is an integer array (..., 256), got {hist.dtype} {hist.shape}"
        )
    if np.any(hist < 0) or np.any(hist.sum(axis=-1) <= 0):
        raise PorepipeError("a configuration histogram needs non-negative counts and at least one cell")
    return hist.astype(np.int64, copy=False)


def _voxel_text(geom: _weights.Geometry) -> str:
    sizes = set(geom.voxel_um)
    return f"{geom.voxel_um[0]!r}" if len(sizes) == 1 else f"{geom.voxel_um!r}"


def _in_um(name: str, value, geom: _weights.Geometry, power: int) -> np.ndarray:
    """``value`` (unit_um^power) in µm^power; a non-zero value that over- or underflows float64 there is refused."""
    return from_voxel_units(value, geom.unit_um, power, name, _voxel_text(geom))


def _surface_density(hist: np.ndarray, geom: _weights.Geometry) -> np.ndarray:
    """S_V of histogram(s) ``hist`` (..., 256) in units of ``geom.unit_um``⁻¹."""
    transitions = hist @ _weights.transition_table().T  # (..., 13) int64, exact
    cells = hist.sum(axis=-1)[..., None]
    line_density = transitions / (_weights.TRANSITION_DENOMINATOR * cells * geom.line_length)
    return 2.0 * line_density @ geom.line_weight


def specific_surface_from_histogram(histogram, voxel_um) -> np.ndarray | float:
    """Surface area per volume S_V (µm⁻¹) from configuration histogram(s); the same for both phases.

    Parameters
    ----------
    histogram : (..., 256) integer ndarray
        Configuration histogram(s), e.g. of every sub-cube of a local analysis.
    voxel_um : float or (3,) floats
        Voxel edge lengths in µm.

    Returns
    -------
    float or (...) ndarray
        ``S_V = 2 Σ_i γ_i P_L(i)``, P_L(i) = transitions per unit length along lattice direction i.

    Notes
    -----
    Crofton formula over the 13 directions of the 2x2x2 cell with spherical-Voronoi weights (Ohser & Mücklich
    2000; Schladitz, Ohser & Nagel 2006). Unbiased for isotropic structures as the resolution increases; for flat
    faces normal to an axis the 13-direction estimate is 7.4 % low (a property of every 13-direction Crofton sum).
    Computed in voxel units and scaled by 1/a afterwards, so any voxel size whose S_V is representable works.
    """
    hist = _check_histogram(histogram)
    geom = _weights.geometry(voxel3(voxel_um))
    result = _in_um("S_V", _surface_density(hist, geom), geom, -1)
    return float(result) if np.ndim(result) == 0 else result


def _phase_values(hist: np.ndarray, geom: _weights.Geometry, adjacency: int) -> dict[str, np.ndarray]:
    """φ, S_V, K_V, T_V and χ of the foreground of histogram(s) ``hist`` (..., 256).

    The densities are computed in units of the voxel edge and scaled by its powers afterwards (S_V ~ a⁻¹,
    K_V ~ a⁻², T_V ~ a⁻³), so an extreme voxel size gives correct values wherever they are representable.
    """
    cells = hist.sum(axis=-1)
    volume = hist @ _weights.volume_table()
    section = hist @ _weights.section_euler_table(adjacency).T  # (..., 13) int64, exact
    euler = hist @ _weights.euler_table(adjacency)
    window = cells * geom.cell_volume
    chi_area = section * geom.plane_spacing / (_weights.SECTION_DENOMINATOR * window[..., None])
    chi = euler / _weights.EULER_DENOMINATOR
    return {
        "phi": volume / (_weights.VOLUME_DENOMINATOR * cells),
        "S_V": _in_um("S_V", _surface_density(hist, geom), geom, -1),
        "K_V": _in_um("K_V", 2.0 * np.pi * chi_area @ geom.plane_weight, geom, -2),
        "T_V": _in_um("T_V", 4.0 * np.pi * chi / window, geom, -3),
        "chi": chi,
    }


def matrix_histogram(histogram) -> np.ndarray:
    """Histogram of the complementary phase: code c of the matrix is code 255 - c of the pore."""
    return np.asarray(histogram)[..., ::-1]


def minkowski_from_histogram(
    histogram, voxel_um, adjacency: Adjacency | str = Adjacency.pore6_matrix26, periodic=True
) -> xr.Dataset:
    """φ, S_V, K_V, T_V and χ of pore and matrix from the pore phase's configuration histogram.

    Parameters
    ----------
    histogram : (256,) integer ndarray
        Configuration histogram of the pore phase (foreground = pore), from :func:`configuration_histogram`.
    voxel_um : float or (3,) floats
        Voxel edge lengths in µm.
    adjacency : Adjacency
        Complementary adjacency pair; χ and K_V depend on it, φ and S_V do not.
    periodic : bool or 3 bools
        Boundary treatment the histogram was counted with (stored in the attributes).

    Returns
    -------
    xarray.Dataset
        Variables ``phi``, ``S_V``, ``K_V``, ``T_V``, ``chi`` (dim ``phase`` = pore, matrix), ``adjacency``
        (phase) and ``histogram`` (phase, code); units in each variable's ``units`` attribute.
    """
    hist = _check_histogram(histogram)
    if hist.ndim != 1:
        raise PorepipeError(f"minkowski_from_histogram takes one histogram (256,), got shape {hist.shape}")
    adjacency = _adjacency(adjacency)
    geom = _weights.geometry(voxel3(voxel_um))
    flags = _periodic3(periodic)
    per_phase = [
        _phase_values(h, geom, adjacency.of(p)) for p, h in zip(PHASES, (hist, matrix_histogram(hist)))
    ]
    data = {
        name: (
            "phase",
            np.array([float(v[name]) for v in per_phase]),
            {"units": UNITS[name], "long_name": _DESCRIPTIONS[name]},
        )
        for name in UNITS
    }
    data["adjacency"] = (
        "phase",
        np.array([adjacency.of(p) for p in PHASES], dtype=np.int64),
        {"long_name": "voxel adjacency used for the phase's Euler numbers"},
    )
    data["histogram"] = (
        ("phase", "code"),
        np.stack([hist, matrix_histogram(hist)]),
        {"long_name": "2x2x2 configuration histogram; bit dx + 2 dy + 4 dz = voxel is in the phase"},
    )
    return xr.Dataset(
        data,
        coords={"phase": list(PHASES), "code": np.arange(_weights.N_CODES)},
        attrs=_boundary_attrs(geom, flags, adjacency, int(hist.sum())),
    )


def _boundary_attrs(geom: _weights.Geometry, flags, adjacency: Adjacency, cells: int) -> dict:
    boundary = "periodic" if all(flags) else ("minus_sampling" if not any(flags) else "mixed")
    return {
        "voxel_um": np.asarray(geom.voxel_um),
        "periodic": np.asarray(flags, dtype=np.int8),
        "boundary": boundary,
        "boundary_rule": "periodic axes wrap; along non-periodic axes only complete 2x2x2 cells (minus sampling)",
        "adjacency_pair": adjacency.value,
        "n_cells": cells,
        "window_um3": float(_in_um("the window volume", cells * geom.cell_volume, geom, 3)),
        "method": "2x2x2 configuration histogram; Crofton over 13 lattice directions with spherical-Voronoi weights "
        "(Ohser & Mücklich 2000; Schladitz, Ohser & Nagel 2006); Euler number of the cubical complex of "
        "the 6-adjacent phase and its dual for the 26-adjacent phase (Ohser, Nagel & Schladitz 2003)",
    }


def _adjacency(adjacency) -> Adjacency:
    try:
        return Adjacency(adjacency)
    except ValueError:
        allowed = ", ".join(a.value for a in Adjacency)
        raise PorepipeError(f"adjacency {adjacency!r} is not one of: {allowed}") from None


def minkowski_functionals(
    volume, voxel_um, periodic=True, adjacency: Adjacency | str = Adjacency.pore6_matrix26
) -> xr.Dataset:
    """Minkowski functionals of pore (non-zero) and matrix (zero) of a binary volume.

    Parameters
    ----------
    volume : (nx, ny, nz) uint8 or bool ndarray
        Binary volume, non-zero = pore.
    voxel_um : float or (3,) floats
        Voxel edge lengths in µm (anisotropic voxels allowed).
    periodic : bool or 3 bools
        Periodic axes wrap; along the others only complete cells count (minus sampling).
    adjacency : Adjacency
        Complementary adjacency pair for χ and K_V.

    Returns
    -------
    xarray.Dataset
        See :func:`minkowski_from_histogram`.

    Examples
    --------
    >>> import numpy as np
    >>> ball = np.zeros((9, 9, 9), np.uint8); ball[3:6, 3:6, 3:6] = 1
    >>> float(minkowski_functionals(ball, 1.0, periodic=False).chi.sel(phase="pore"))
    1.0
    """
    flags = _periodic3(periodic)
    return minkowski_from_histogram(configuration_histogram(volume, flags), voxel_um, adjacency, flags)


# -- grey volumes: Minkowski functions of the threshold --------------------------------------------------------------
def _as_grey(volume, what: str = "grey volume") -> np.ndarray:
    arr = np.asarray(volume)
    if arr.ndim != 3 or arr.dtype != np.uint8:
        raise PorepipeError(f"{what} must be a 3-D uint8 array (x, y, z), got {arr.dtype} {arr.shape}")
    return np.ascontiguousarray(arr)


def threshold_histograms(grey, periodic=True, n_levels: int = 256) -> np.ndarray:
    """Configuration histograms of ``grey <= t`` for every threshold t = 0 .. n_levels-1 in one pass.

    Parameters
    ----------
    grey : (nx, ny, nz) uint8 ndarray
        Grey volume; in porepipe the count of the 216 sample points in the matrix, so ``grey <= t`` is the pore
        phase of the segmentation with threshold g_th = t (Zauner 2020, §4.7.2).
    periodic : bool or 3 bools
        As for :func:`configuration_histogram`.
    n_levels : int
        Number of thresholds (rows).

    Returns
    -------
    (n_levels, 256) int64 ndarray
    """
    flags = _periodic3(periodic)
    vol = _as_grey(grey)
    _check_plane_shape(vol.shape, flags, "grey volume")
    diff = np.zeros((n_levels, _weights.N_CODES), dtype=np.int64)
    _kernels._threshold_histograms(
        vol, flags[0], flags[1], flags[2], _blocks(vol.shape[0] - 1 + int(flags[0])), diff
    )
    return _accumulate(diff, n_cells(vol.shape, flags))


def _accumulate(diff: np.ndarray, cells: int) -> np.ndarray:
    hist = np.cumsum(diff, axis=0)
    hist[:, 0] += cells
    return hist


def threshold_histograms_slabs(slabs: Iterable, periodic=True, n_levels: int = 256):
    """:func:`threshold_histograms` of a grey volume given as consecutive x-slabs; returns (histograms, shape)."""
    diff, shape = _stream(
        slabs, periodic, _kernels._threshold_histograms, (n_levels, _weights.N_CODES), "grey"
    )
    return _accumulate(diff, n_cells(shape, periodic)), shape


def threshold_dataset(
    histograms,
    voxel_um,
    periodic=True,
    adjacency: Adjacency | str = Adjacency.pore6_matrix26,
    thresholds: Sequence[int] | None = None,
) -> xr.Dataset:
    """Dataset of :func:`minkowski_from_histogram` over a leading dimension ``g_th`` from (n_levels, 256) histograms."""
    hists = _check_histogram(histograms)
    chosen = np.arange(len(hists)) if thresholds is None else np.asarray(thresholds, dtype=np.int64)
    if np.any(chosen < 0) or np.any(chosen >= len(hists)):
        raise PorepipeError(f"thresholds must lie in 0..{len(hists) - 1}, got {list(chosen)}")
    frames = [minkowski_from_histogram(hists[t], voxel_um, adjacency, periodic) for t in chosen]
    ds = xr.concat(
        frames,
        dim=xr.DataArray(chosen, dims="g_th", name="g_th"),
        data_vars="all",
        coords="minimal",
        compat="override",
        combine_attrs="override",
    )
    ds["g_th"].attrs["long_name"] = "threshold: pore = grey <= g_th"
    return ds


def minkowski_functions_of_threshold(
    grey,
    voxel_um,
    periodic=True,
    adjacency: Adjacency | str = Adjacency.pore6_matrix26,
    thresholds: Sequence[int] | None = None,
) -> xr.Dataset:
    """φ, S_V, K_V, T_V, χ of the pore phase ``grey <= g_th`` for every threshold g_th (one pass over the volume).

    Parameters
    ----------
    grey : (nx, ny, nz) uint8 ndarray
        Grey volume (0..216 = sample points in the matrix).
    voxel_um, periodic, adjacency
        As for :func:`minkowski_functionals`.
    thresholds : sequence of int, optional
        Thresholds to report; default 0 .. max(grey).

    Returns
    -------
    xarray.Dataset
        The variables of :func:`minkowski_from_histogram` with a leading dimension ``g_th``.
    """
    vol = _as_grey(grey)
    levels = int(vol.max()) + 1 if thresholds is None else int(max(thresholds)) + 1
    if levels > 256 or (thresholds is not None and min(thresholds) < 0):
        raise PorepipeError(f"thresholds must lie in 0..255 for a uint8 grey volume, got {list(thresholds)}")
    return threshold_dataset(
        threshold_histograms(vol, periodic, n_levels=levels), voxel_um, periodic, adjacency, thresholds
    )
