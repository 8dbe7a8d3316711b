"""Preparation of an image: crop, finite check, optional denoising and resampling, and segmentation into phases.

Segmentation follows the thesis's convention (pore if g <= g_th, §4.7.2) generalised to several phases
(Table 8.1: pore, sedimentation, cementation, grains): class k holds t_{k-1} < g <= t_k with t_{-1} = -inf and
t_{n-1} = +inf. Thresholds come from Otsu's method, multi-level Otsu (scikit-image), or the user, and are kept with
the grey histogram they were chosen on.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import ndimage

from porepipe._shared.budget import machine_bytes
from porepipe._shared.errors import PorepipeError
from porepipe.acquire._io import Image
from porepipe.acquire._settings import SCENE_KEYS, Crop, Denoise, Method, Segmentation, SettingNames


def crop_box(shape, crop: Crop | None, names: SettingNames = SCENE_KEYS) -> tuple[slice, slice, slice]:
    """Slices of ``crop`` in an image of ``shape``; an out-of-range box is an error naming both (and the setting,
    as ``names`` says).
    """
    if crop is None:
        return tuple(slice(0, int(n)) for n in shape)
    size = tuple(int(s) for s in crop.size)
    if any(s > n for s, n in zip(size, shape)):
        raise PorepipeError(f"{names('crop.size')} = {size} exceeds the image shape {tuple(shape)}")
    start = tuple((n - s) // 2 for n, s in zip(shape, size)) if crop.centre else tuple(crop.start)
    if any(b < 0 or b + s > n for b, s, n in zip(start, size, shape)):
        raise PorepipeError(
            f"{names('crop.start')} {start} + size {size} lies outside the image shape {tuple(shape)}"
        )
    return tuple(slice(b, b + s) for b, s in zip(start, size))


def load_region(image: Image, crop: Crop | None, names: SettingNames = SCENE_KEYS) -> np.ndarray:
    """Read the cropped region into memory (only that region is read from a memory map or HDF5 dataset); messages
    name the crop as ``names`` says.
    """
    if 0 in image.shape:  # before: "0 populated grey value(s): otsu cannot split it", or NaN statistics
        raise PorepipeError(f"image {image.source} has shape {image.shape}: no voxels")
    region = np.ascontiguousarray(image.data[crop_box(image.shape, crop, names)])
    if region.dtype.byteorder not in "=|":
        region = region.astype(region.dtype.newbyteorder("="))
    if region.dtype.kind == "b":
        region = region.astype(np.uint8)
    if region.dtype.kind not in "uif":
        raise PorepipeError(
            f"image {image.source} has element type {region.dtype}; expected integers or floats"
        )
    if region.dtype.kind == "f":
        bad = ~np.isfinite(region)
        n_bad = int(np.count_nonzero(bad))
        if n_bad:
            first = tuple(int(i) for i in np.argwhere(bad)[0])
            raise PorepipeError(
                f"image {image.source} has {n_bad} NaN/Inf voxel(s) in the region used (first at "
                f"{first}); crop them away ({names('crop')}) or fill them before acquisition"
            )
    return region


def denoise(grey: np.ndarray, method: Denoise, size: int = 3, names: SettingNames = SCENE_KEYS) -> np.ndarray:
    """Median (cube of ``size`` voxels) or non-local-means filter of an (X, Y, Z) image (a section: Z = 1).

    Parameters
    ----------
    grey : (X, Y, Z) ndarray
        The image; a section has Z = 1, an axis of one voxel is kept as it is.
    method : Denoise
        ``none`` (the input is returned), ``median`` or ``nl_means``.
    size : int
        Edge of the median filter's cube (a square on a section), voxels.
    names : SettingNames
        How a message names the ``denoise`` setting (default: its scene key).
    """
    if np.ndim(grey) != 3:
        raise PorepipeError(
            f"denoise needs an (X, Y, Z) image (a section has Z = 1), got shape {np.shape(grey)}"
        )
    method = Denoise(method)
    if method is Denoise.none:
        return grey
    if method is Denoise.median:
        footprint = (size, size, 1) if grey.shape[2] == 1 else (size, size, size)
        return ndimage.median_filter(grey, size=footprint, mode="reflect")
    from skimage.restoration import denoise_nl_means

    if grey.size < 2:
        raise PorepipeError(
            f"{names('denoise')} nl_means needs an image of 2 voxels or more, got shape {grey.shape}"
        )
    work = grey.astype(np.float32)
    work = work[:, :, 0] if work.shape[2] == 1 else work
    sigma = _noise_sigma(work)
    out = denoise_nl_means(work, h=0.8 * sigma, sigma=sigma, fast_mode=True, patch_size=3, patch_distance=5)
    out = out.reshape(grey.shape)  # scikit-image drops every axis of length 1
    return (
        out.astype(grey.dtype)
        if grey.dtype.kind == "f"
        else np.clip(np.rint(out), *_int_range(grey.dtype)).astype(grey.dtype)
    )


def _noise_sigma(work: np.ndarray) -> float:
    """Robust noise level: MAD of neighbour differences along x (else the first axis of >= 2 voxels), / sqrt(2)
    (differences double the variance).
    """
    axis = next(k for k, n in enumerate(work.shape) if n >= 2)
    d = np.diff(work, axis=axis).ravel()
    mad = np.median(np.abs(d - np.median(d)))
    return max(float(1.4826 * mad / np.sqrt(2.0)), 1e-6)


def _int_range(dtype) -> tuple[int, int]:
    info = np.iinfo(dtype)
    return info.min, info.max


def resample_cubic(grey: np.ndarray, spacing_um) -> tuple[np.ndarray, float]:
    """Linear resampling of an anisotropic stack to cubic voxels of the smallest edge; returns (volume, edge)."""
    spacing = np.asarray(spacing_um, dtype=np.float64)
    edge = float(spacing.min())
    if np.allclose(spacing, edge, rtol=1e-9):
        return grey, edge
    factors = spacing / edge
    wanted = np.maximum(1.0, np.floor(np.asarray(grey.shape) * factors + 1e-9))
    need = float(np.prod(wanted)) * np.dtype(np.float32).itemsize
    if need > machine_bytes():  # before: a negative shape (int overflow) or numpy's raw allocation error
        raise PorepipeError(
            f"voxels of {' x '.join(f'{s:g}' for s in spacing)} µm resampled to cubes of {edge:g} µm make "
            f"{' x '.join(f'{n:.3g}' for n in wanted)} voxels ({need / 2**30:.3g} GiB), more than this machine's "
            "memory; check acquire.voxel_um and acquire.section_um (--voxel-um, --section-um)"
        )
    shape = wanted.astype(int)
    out = ndimage.zoom(
        grey.astype(np.float32), shape / np.asarray(grey.shape), order=1, mode="nearest", grid_mode=True
    )
    if grey.dtype.kind in "ui":
        out = np.clip(np.rint(out), *_int_range(grey.dtype)).astype(grey.dtype)
    return out, edge


@dataclasses.dataclass
class GreyHistogram:
    """Histogram of a grey image: ``counts`` per bin and the grey value of every bin centre."""

    counts: np.ndarray
    centres: np.ndarray


def grey_histogram(grey: np.ndarray, bins: int = 256) -> GreyHistogram:
    """One value per bin for 8-bit images (exact), ``bins`` equal bins between min and max otherwise."""
    if grey.dtype == np.uint8:
        counts = np.bincount(grey.ravel(), minlength=256).astype(np.int64)
        return GreyHistogram(counts, np.arange(256, dtype=np.float64))
    if grey.size == 0 or (grey.dtype.kind == "f" and not np.all(np.isfinite(grey))):
        raise PorepipeError(
            f"grey_histogram needs a non-empty image of finite grey values (no NaN or Inf), got shape {grey.shape}"
        )
    lo, hi = float(grey.min()), float(grey.max())
    widest = float(np.finfo(grey.dtype).max) if grey.dtype.kind == "f" else np.inf
    if not hi - lo <= widest:
        raise PorepipeError(
            f"grey values span {lo:g} to {hi:g}, wider than the largest {grey.dtype} ({widest:g}), so the bins "
            "cannot be computed; rescale the image"
        )
    if lo == hi:
        return GreyHistogram(np.array([grey.size], np.int64), np.array([lo]))
    if grey.dtype.kind in "ui" and hi - lo + 1 <= bins:
        # offsets from the minimum, signed types in int64: in int8, 127 - (-128) wraps round to -1
        wide = np.int64 if grey.dtype.kind == "i" else grey.dtype
        counts = np.bincount(
            np.subtract(grey.ravel(), grey.min(), dtype=wide).astype(np.int64), minlength=int(hi - lo) + 1
        )
        return GreyHistogram(counts.astype(np.int64), lo + np.arange(counts.size, dtype=np.float64))
    try:
        counts, edges = np.histogram(grey, bins=bins, range=(lo, hi))
    except ValueError as err:  # "Too many bins for data range" (a raw ValueError before)
        raise PorepipeError(
            f"grey values span {lo!r} to {hi!r}, too narrow for {bins} bins at {grey.dtype} precision; rescale "
            "the image (subtract its minimum) or lower acquire.segmentation.bins"
        ) from err
    return GreyHistogram(counts.astype(np.int64), 0.5 * (edges[:-1] + edges[1:]))


@dataclasses.dataclass
class Phases:
    """Result of segmentation: labels (uint8 phase index per voxel), thresholds, histogram, names and pore mask."""

    labels: np.ndarray
    thresholds: np.ndarray
    histogram: GreyHistogram
    names: list[str]
    pore_index: list[int]
    method: Method

    def pore(self) -> np.ndarray:
        """uint8 volume, 1 = pore (union of the pore phases)."""
        lut = np.zeros(len(self.names), np.uint8)
        lut[self.pore_index] = 1
        return lut[self.labels]


def choose_thresholds(hist: GreyHistogram, seg: Segmentation, names: SettingNames = SCENE_KEYS) -> np.ndarray:
    """The n_phases - 1 ascending thresholds (grey units) of ``seg`` for this histogram; messages name the
    settings as ``names`` says.

    Raises
    ------
    PorepipeError
        Otsu / multi-Otsu on a histogram with fewer populated grey values than phases (e.g. an image of one grey
        value): the split is undefined; the message says to give thresholds.
    """
    n = len(seg.phases)
    if seg.method is Method.thresholds:
        return np.asarray(seg.thresholds, dtype=np.float64)
    populated = int(np.count_nonzero(hist.counts))
    if populated < n:
        values = hist.centres[hist.counts > 0]
        raise PorepipeError(
            f"the image has {populated} populated grey value(s) {values[:5].tolist()}: "
            f"{seg.method.value} cannot split it into {n} phases; use {names('segmentation.method')} thresholds "
            f"with {names('segmentation.thresholds')} to say which phase it is"
        )
    from skimage.filters import threshold_multiotsu, threshold_otsu

    counts = hist.counts.astype(np.float64)
    if n == 2:
        # Otsu on bin numbers: the bins are equally spaced and Otsu's choice does not change under an affine map of
        # the grey values (multi-Otsu works on bin numbers too); on the grey values themselves, values of 1e150
        # and more overflowed its between-class variance to inf and the first bin won
        index = int(threshold_otsu(hist=(counts, np.arange(counts.size, dtype=np.float64))))
        return np.array([float(hist.centres[index])])
    return np.asarray(threshold_multiotsu(hist=(counts, hist.centres), classes=n), dtype=np.float64)


def segment_phases(grey: np.ndarray, seg: Segmentation, names: SettingNames = SCENE_KEYS) -> Phases:
    """Label every voxel with its phase (index into ``seg.phases``), keeping thresholds and histogram.

    Parameters
    ----------
    grey : ndarray
        The prepared grey image.
    seg : Segmentation
        The ``acquire.segmentation`` settings.
    names : SettingNames
        How messages name the settings: scene keys (the default) or ``porepipe acquire``'s options.

    Returns
    -------
    Phases
        Labels, thresholds and histogram.
    """
    hist = grey_histogram(grey, seg.bins)
    thresholds = choose_thresholds(hist, seg, names)
    n = len(seg.phases)
    labels = np.zeros(grey.shape, np.uint8)
    # class k: t_{k-1} < g <= t_k (pore if g <= g_th)
    if grey.dtype in (np.uint8, np.uint16):  # one lookup table for every possible grey value
        k = np.searchsorted(thresholds, np.arange(np.iinfo(grey.dtype).max + 1), side="left").astype(np.uint8)
        np.take((n - 1 - k) if seg.invert else k, grey, out=labels)
        return Phases(
            labels,
            thresholds,
            hist,
            list(seg.phases),
            [seg.phases.index(p) for p in seg.pore_phases],
            seg.method,
        )
    for i in range(grey.shape[0]):  # slab-wise so no int64 copy of the volume is made
        k = np.searchsorted(thresholds, grey[i], side="left").astype(np.uint8)
        labels[i] = (n - 1 - k) if seg.invert else k
    pore_index = [seg.phases.index(p) for p in seg.pore_phases]
    return Phases(labels, thresholds, hist, list(seg.phases), pore_index, seg.method)
