"""Statistics of a segmented image (Zauner 2020 §4.7 item 1, Tables 8.1 and 8.2).

Each function takes a (x, y, z) volume and returns an xarray Dataset (or a dict of numbers) with units in the
variable names or ``units`` attributes. Lengths are µm, densities per mm³ (the thesis's Table 8.2 units).
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from scipy import fft as sfft
from scipy import ndimage

from porepipe._shared.errors import PorepipeError
from porepipe.acquire import _kernels

AXES = ("x", "y", "z")
UM_PER_MM = 1000.0


def _require_3d(pore: np.ndarray, what: str) -> None:
    if pore.ndim != 3 or min(pore.shape) < 2:
        raise PorepipeError(
            f"{what} needs a 3-D image with at least 2 voxels per axis, got shape {pore.shape} "
            "(a 2-D section: stack serial sections into a volume first)"
        )


def _axes_of(pore: np.ndarray) -> list[int]:
    """Axes along which lines have more than one voxel (a 2-D section has no z lines)."""
    return [ax for ax in range(3) if pore.shape[ax] > 1]


# -- phase fractions ------------------------------------------------------------------------------------------------
def volume_fractions(labels: np.ndarray, names: list[str]) -> xr.DataArray:
    """Volume fraction of every phase (Table 8.1), from the label volume."""
    counts = np.bincount(labels.ravel(), minlength=len(names))[: len(names)].astype(np.float64)
    return xr.DataArray(
        counts / labels.size,
        dims="phase",
        coords={"phase": names},
        attrs={"units": "1", "long_name": "volume fraction of the phase (Table 8.1)"},
    )


# -- Minkowski (via the minkowski stage) ---------------------------------------------------------------------------
def minkowski_numbers(pore: np.ndarray, voxel_um: float, periodic: bool) -> dict[str, float]:
    """φ, S_V [mm^-1], K_V [mm^-2], T_V [mm^-3] and χ of the pore space (Table 8.2), by ``porepipe.minkowski``."""
    _require_3d(pore, "S_V, K_V, T_V")
    from porepipe.minkowski import minkowski_functionals

    ds = minkowski_functionals(pore, voxel_um, periodic=periodic).sel(phase="pore")
    numbers = {
        "phi_minkowski": float(ds.phi),
        "S_V_per_mm": float(ds.S_V) * UM_PER_MM,
        "K_V_per_mm2": float(ds.K_V) * UM_PER_MM**2,
        "T_V_per_mm3": float(ds.T_V) * UM_PER_MM**3,
        "chi": float(ds.chi),
    }
    beyond = [name for name, value in numbers.items() if not np.isfinite(value)]
    if beyond:  # representable per µm³ (minkowski checks that), not per mm³: e.g. T_V at voxel_um 1e-100
        raise PorepipeError(
            f"voxel_um = {voxel_um!r} µm: {beyond[0]} is beyond the float64 range; allowed: a voxel size at which "
            "the Minkowski densities per mm are representable"
        )
    return numbers


# -- percolation ----------------------------------------------------------------------------------------------------
def percolation(pore: np.ndarray) -> xr.Dataset:
    """Connected porosity along each axis and the largest cluster (6-connected pore voxels).

    A cluster percolates along an axis if it touches both faces normal to it. ``connected_porosity`` is the volume
    fraction of the pore clusters that percolate along the axis; ``largest_percolating`` the volume fraction of the
    largest cluster that percolates along any axis (0 if none does).
    """
    _require_3d(pore, "percolation")
    lab, n = ndimage.label(pore, structure=ndimage.generate_binary_structure(3, 1))
    sizes = np.bincount(lab.ravel(), minlength=n + 1).astype(np.int64)
    total = float(pore.size)
    connected, spans_any = np.zeros(3), np.zeros(n + 1, bool)
    for ax in range(3):
        lo = np.unique(np.take(lab, 0, axis=ax))
        hi = np.unique(np.take(lab, -1, axis=ax))
        spanning = np.intersect1d(lo, hi)
        spanning = spanning[spanning > 0]
        spans_any[spanning] = True
        connected[ax] = sizes[spanning].sum() / total
    del lab
    largest = float(sizes[1:].max() / total) if n else 0.0
    largest_perc = float(sizes[spans_any].max() / total) if spans_any.any() else 0.0
    return xr.Dataset(
        {
            "connected_porosity": (
                "axis",
                connected,
                {
                    "units": "1",
                    "long_name": "volume fraction of pore clusters "
                    "touching both faces normal to the axis (6-connected)",
                },
            ),
            "percolates": (
                "axis",
                (connected > 0).astype(np.int8),
                {"long_name": "1 if a pore cluster spans the axis"},
            ),
            "largest_cluster": (
                (),
                largest,
                {"units": "1", "long_name": "volume fraction of the largest pore cluster"},
            ),
            "largest_percolating_cluster": (
                (),
                largest_perc,
                {"units": "1", "long_name": "volume fraction of the largest cluster spanning any axis"},
            ),
            "n_pore_clusters": ((), int(n), {"long_name": "number of 6-connected pore clusters"}),
        },
        coords={"axis": list(AXES)},
    )


# -- two-point correlation ------------------------------------------------------------------------------------------
def _autocorrelation_counts(pore: np.ndarray, axis: int, max_lag: int, slab: int = 16) -> np.ndarray:
    """Σ over lines along ``axis`` of Σ_i p(i) p(i + r), r = 0..max_lag (non-periodic), by zero-padded FFT slabs."""
    moved = np.moveaxis(pore, axis, -1)
    n = moved.shape[-1]
    nfft = sfft.next_fast_len(n + max_lag + 1, real=True)
    acc = np.zeros(max_lag + 1)
    for i0 in range(0, moved.shape[0], slab):
        block = moved[i0 : i0 + slab].astype(np.float32)
        spec = sfft.rfft(block, n=nfft, axis=-1)
        power = (spec * spec.conj()).real
        acc += sfft.irfft(power, n=nfft, axis=-1)[..., : max_lag + 1].sum(axis=(0, 1), dtype=np.float64)
    return np.rint(acc)


def two_point_correlation(pore: np.ndarray, voxel_um: float, max_lag: int) -> xr.DataArray:
    """S_2(r) = P(x and x + r e_axis both pore) along each axis, r = 0..max_lag voxels, pairs inside the image.

    S_2(0) = φ; S_2(r) -> φ² for large r; the slope at 0 is -S_V/4 for an isotropic medium (Debye et al. 1957),
    which tests check. Axes with one voxel (2-D sections) are NaN.
    """
    max_lag = int(max_lag)
    out = np.full((3, max_lag + 1), np.nan)
    for ax in _axes_of(pore):
        n = pore.shape[ax]
        lags = min(max_lag, n - 1)
        lines = pore.size // n
        counts = _autocorrelation_counts(pore, ax, lags)
        out[ax, : lags + 1] = counts / (lines * (n - np.arange(lags + 1)))
    return xr.DataArray(
        out,
        dims=("axis", "lag"),
        coords={
            "axis": list(AXES),
            "lag": np.arange(max_lag + 1),
            "lag_um": ("lag", np.arange(max_lag + 1) * voxel_um),
        },
        attrs={"units": "1", "long_name": "two-point correlation of the pore phase S_2(r)"},
    )


# -- chord lengths --------------------------------------------------------------------------------------------------
def chord_lengths(pore: np.ndarray, voxel_um: float) -> xr.Dataset:
    """Chord-length histograms of pore and matrix along each axis (complete chords only, i.e. not cut by the box).

    Also gives the stereological S_V = 2 P_L (P_L = phase changes per unit line length; Underwood 1970), which holds
    for isotropic media and is a 2-D-section estimate of S_V.
    """
    n_max = max(pore.shape)
    counts = np.zeros((2, 3, n_max + 1), np.int64)
    changes = np.full(3, np.nan)
    for ax in _axes_of(pore):
        view = np.moveaxis(pore, ax, -1)
        buf = np.zeros((view.shape[0], 2, view.shape[-1] + 1), np.int64)
        _kernels._chords(view, buf)
        counts[:, ax, : view.shape[-1] + 1] = buf.sum(axis=0)
        diff = np.count_nonzero(np.diff(view, axis=-1))
        changes[ax] = diff / (view.size // view.shape[-1] * (view.shape[-1] - 1) * voxel_um)
    length = np.arange(n_max + 1)
    total = counts.sum(axis=2)
    mean = np.where(total > 0, (counts * length).sum(axis=2) / np.maximum(total, 1), np.nan) * voxel_um
    return xr.Dataset(
        {
            "chord_count": (
                ("chord_phase", "axis", "chord"),
                counts,
                {"long_name": "number of complete chords of the phase by length"},
            ),
            "mean_chord_um": (
                ("chord_phase", "axis"),
                mean,
                {"units": "µm", "long_name": "mean complete chord length"},
            ),
            "S_V_chord_per_mm": (
                "axis",
                2.0 * changes * UM_PER_MM,
                {"units": "mm^-1", "long_name": "S_V = 2 P_L from phase changes along the axis"},
            ),
        },
        coords={
            "chord_phase": ["matrix", "pore"],
            "axis": list(AXES),
            "chord": length,
            "chord_um": ("chord", length * voxel_um),
        },
    )


# -- grains ---------------------------------------------------------------------------------------------------------
def _trim_peaks(peaks: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Keep the highest distance peaks; drop a peak inside the inscribed sphere of a higher kept one, or a peak whose
    inscribed sphere overlaps that of a kept one at least twice as large (a bump on a grain, not a grain).
    """
    from scipy.spatial import cKDTree

    order = np.argsort(-radius, kind="stable")
    tree = cKDTree(peaks)
    alive = np.ones(len(peaks), bool)
    for p in order:
        if alive[p]:
            near = np.asarray(
                tree.query_ball_point(peaks[p], r=max(2.0 * float(radius[p]), 1.0)), dtype=np.int64
            )
            d = np.linalg.norm(peaks[near] - peaks[p], axis=1)
            drop = (d < max(float(radius[p]), 1.0)) | (
                (d < radius[p] + radius[near]) & (radius[near] < 0.5 * radius[p])
            )
            alive[near[drop]] = False
            alive[p] = True
    return peaks[alive]


def grain_labels(
    solid: np.ndarray, min_distance: int = 2, periodic: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Watershed grain segmentation of a solid mask: distance transform, trimmed peaks, watershed (scikit-image).

    Returns the label volume (int32, 0 = not grain), the distance transform value at each grain's marker (voxel
    units; the radius of the largest ball centred there that avoids the pore, minus about half a voxel) and the
    markers (n, 3) voxel indices, grain i + 1 grown from marker i.
    """
    from skimage.feature import peak_local_max
    from skimage.segmentation import watershed

    if not solid.any():
        return np.zeros(solid.shape, np.int32), np.zeros(0), np.zeros((0, 3), np.int64)
    dist = ndimage.distance_transform_edt(solid).astype(np.float32)
    peaks = peak_local_max(
        dist, min_distance=max(1, int(min_distance)), threshold_abs=1.0, exclude_border=False
    )
    if len(peaks) == 0:
        peaks = np.argwhere(dist == dist.max())[:1]
    peaks = _trim_peaks(peaks, dist[tuple(peaks.T)])
    markers = np.zeros(solid.shape, np.int32)
    markers[tuple(peaks.T)] = np.arange(1, len(peaks) + 1, dtype=np.int32)
    labels = watershed(-dist, markers, mask=solid)
    return labels.astype(np.int32, copy=False), dist[tuple(peaks.T)].astype(np.float64), peaks


def grain_shapes(labels: np.ndarray, n_labels: int) -> dict[str, np.ndarray]:
    """Volume, centroid and the principal second moments / axes of every label 1..n (voxel units)."""
    mom = np.zeros((n_labels + 1, 10))
    _kernels._label_moments(labels, n_labels, mom)
    mom = mom[1:]
    n = np.maximum(mom[:, 0], 1.0)
    c = mom[:, 1:4] / n[:, None]
    cov = np.empty((n_labels, 3, 3))
    cov[:, 0, 0] = mom[:, 4] / n - c[:, 0] ** 2
    cov[:, 1, 1] = mom[:, 5] / n - c[:, 1] ** 2
    cov[:, 2, 2] = mom[:, 6] / n - c[:, 2] ** 2
    cov[:, 0, 1] = cov[:, 1, 0] = mom[:, 7] / n - c[:, 0] * c[:, 1]
    cov[:, 0, 2] = cov[:, 2, 0] = mom[:, 8] / n - c[:, 0] * c[:, 2]
    cov[:, 1, 2] = cov[:, 2, 1] = mom[:, 9] / n - c[:, 1] * c[:, 2]
    cov += np.eye(3) / 12.0  # each voxel is a unit cube, not a point: its own second moment is 1/12 per axis
    evals, evecs = np.linalg.eigh(cov)
    return {"volume_vox": mom[:, 0], "centroid_vox": c, "moments": np.clip(evals, 0.0, None), "axes": evecs}


def _touching_boundary(labels: np.ndarray, n_labels: int) -> np.ndarray:
    touch = np.zeros(n_labels + 1, bool)
    for ax in range(3):
        if labels.shape[ax] > 1:
            for idx in (0, -1):
                touch[np.unique(np.take(labels, idx, axis=ax))] = True
    return touch[1:]


def _on_boundary(points: np.ndarray, shape) -> np.ndarray:
    """Markers on a face of the box (axes with more than one voxel)."""
    shape = np.asarray(shape)
    live = shape > 1
    return ((points[:, live] == 0) | (points[:, live] == shape[live] - 1)).any(axis=1)


def grain_statistics(
    solid: np.ndarray, voxel_um: float, min_distance: int = 2, periodic: bool = False
) -> xr.Dataset:
    """Grain count per mm³, equivalent and inscribed radii, elongation and orientation of watershed grains.

    Elongation = 1 - sqrt(λ_min / λ_max) of the inertia (second-moment) tensor (0 for a ball); orientation = unit
    vector of the long axis (x, y, z). Grains cut by the image boundary are flagged (``cut``: their shapes are
    truncated, and the calibration's elongation classes leave them out); grains whose marker lies on the boundary (a
    piece of a sphere centred outside) are not ``counted``: left out of the number density and, by the calibration,
    of the radius distribution.
    """
    _require_3d(solid, "grain segmentation")
    labels, peak_dist, peaks = grain_labels(solid, min_distance, periodic)
    n = int(labels.max())
    shapes = grain_shapes(labels, n)
    cut = np.zeros(n, bool) if periodic else _touching_boundary(labels, n)
    counted = np.ones(n, bool) if periodic else ~_on_boundary(peaks, solid.shape)
    del labels
    vol_um3 = shapes["volume_vox"] * voxel_um**3
    ev = shapes["moments"]
    with np.errstate(divide="ignore", invalid="ignore"):
        elong = np.where(ev[:, 2] > 0, 1.0 - np.sqrt(ev[:, 0] / np.where(ev[:, 2] > 0, ev[:, 2], 1.0)), 0.0)
    box_mm3 = solid.size * (voxel_um / UM_PER_MM) ** 3
    return xr.Dataset(
        {
            "grain_volume_um3": ("grain", vol_um3, {"units": "µm^3"}),
            "equivalent_radius_um": (
                "grain",
                np.cbrt(3.0 * vol_um3 / (4.0 * np.pi)),
                {"units": "µm", "long_name": "radius of the ball of the grain's volume"},
            ),
            "inscribed_radius_um": (
                "grain",
                (peak_dist + 0.5) * voxel_um,
                {
                    "units": "µm",
                    "long_name": "distance transform at the grain's marker + half a voxel "
                    "(the marker voxel centre lies on average 0.48 voxel from the sphere centre): "
                    "radius of the sphere the grain grew from (overlapping-sphere model)",
                },
            ),
            "elongation": ("grain", elong, {"units": "1", "long_name": "1 - sqrt(lambda_min / lambda_max)"}),
            "orientation": (
                ("grain", "xyz"),
                shapes["axes"][:, :, 2],
                {"long_name": "unit vector of the long axis"},
            ),
            "centroid_um": (("grain", "xyz"), shapes["centroid_vox"] * voxel_um, {"units": "µm"}),
            "cut": ("grain", cut.astype(np.int8), {"long_name": "1 if the grain touches the image boundary"}),
            "counted": (
                "grain",
                counted.astype(np.int8),
                {
                    "long_name": "1 if the grain counts for the number density "
                    "(its marker, the distance-transform peak, is not on the box "
                    "boundary: the sphere centre lies inside the box; a piece of a "
                    "sphere centred outside peaks on the face)"
                },
            ),
            "grains_per_mm3": (
                (),
                counted.sum() / box_mm3,
                {"units": "mm^-3", "long_name": "grain number density"},
            ),
        },
        coords={"grain": np.arange(1, n + 1), "xyz": list(AXES)},
    )
