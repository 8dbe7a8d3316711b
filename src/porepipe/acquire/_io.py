"""Image readers: TIFF (multi-page, 3-D, or a stack of 2-D sections), RAW, HDF5 and NumPy, all as (x, y, z) arrays.

Large RAW, NumPy and HDF5 images are opened lazily (memory map or h5py dataset) so that a crop reads only what it
keeps. TIFF pages are (rows, columns) = (y, x); a page stack is z, so a TIFF volume (z, y, x) is returned transposed
to (x, y, z) as a view. The voxel size comes from the file's metadata (TIFF resolution tags / ImageJ ``spacing``,
HDF5 attribute ``voxel_um`` or ``element_size_um``) or from the caller; a missing voxel size is an error.
"""

from __future__ import annotations

import dataclasses
import glob
import logging
import math
import struct
import sys
from collections.abc import Sequence
from pathlib import Path

import h5py
import numpy as np
import psutil

from porepipe._shared.errors import PorepipeError
from porepipe.acquire._settings import SCENE_KEYS, ByteOrder, ImageFormat, MemoryOrder, Raw, SettingNames

#: µm per unit of the TIFF ResolutionUnit tag (2 = inch, 3 = centimetre) and of ImageJ's `unit` strings
_TIFF_UNIT_UM = {2: 25400.0, 3: 10000.0}
_IMAGEJ_UNIT_UM = {"micron": 1.0, "um": 1.0, "µm": 1.0, "\\u00B5m": 1.0, "mm": 1000.0, "nm": 1e-3, "cm": 1e4}
_SUFFIX_FORMAT = {
    ".tif": ImageFormat.tiff,
    ".tiff": ImageFormat.tiff,
    ".raw": ImageFormat.raw,
    ".bin": ImageFormat.raw,
    ".vol": ImageFormat.raw,
    ".h5": ImageFormat.hdf5,
    ".hdf5": ImageFormat.hdf5,
    ".hdf": ImageFormat.hdf5,
    ".npy": ImageFormat.npy,
}


@dataclasses.dataclass
class Image:
    """An image as read: ``data`` (x, y, z) (possibly a lazy memory map), voxel edges in µm, where it came from.

    ``is_2d`` marks a single section (nz = 1 from a 2-D file); ``spacing_um`` is None when the file had no voxel
    size and none was given (the caller must then refuse to go on, see :func:`require_spacing`).
    """

    data: np.ndarray | h5py.Dataset
    spacing_um: tuple[float, float, float] | None
    source: str
    is_2d: bool = False

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(int(s) for s in self.data.shape)


def detect_format(
    path: Path, fmt: ImageFormat = ImageFormat.auto, names: SettingNames = SCENE_KEYS
) -> ImageFormat:
    """The format of ``path``: ``fmt`` unless auto, else a directory/glob is a TIFF stack, else by suffix (an unknown
    suffix is an error naming the setting as ``names`` says).
    """
    fmt = ImageFormat(fmt)
    if fmt is not ImageFormat.auto:
        return fmt
    if Path(path).is_dir() or any(c in str(path) for c in "*?["):
        return ImageFormat.tiff
    suffix = Path(path).suffix.lower()
    if suffix not in _SUFFIX_FORMAT:
        raise PorepipeError(
            f"image {path}: cannot tell the format from suffix {suffix!r}; give it with {names('format')} (one "
            f"of {[f.value for f in ImageFormat if f is not ImageFormat.auto]})"
        )
    return _SUFFIX_FORMAT[suffix]


# -- RAW -----------------------------------------------------------------------------------------------------------
def read_raw(path, raw: Raw, names: SettingNames = SCENE_KEYS) -> np.ndarray:
    """Memory-map a RAW file as an (x, y, z) array of ``raw.dtype`` in native interpretation of ``raw.byte_order``.

    Messages name the settings as ``names`` says (scene keys, or the options of ``porepipe acquire``).

    Raises
    ------
    PorepipeError
        Unknown dtype, or a file whose size is not ``header_bytes + prod(shape) * itemsize``.
    """
    path = Path(path)
    try:
        base = np.dtype(raw.dtype)
    except TypeError as err:
        raise PorepipeError(f"{names('raw.dtype')} = {raw.dtype!r} is not a NumPy dtype: {err}") from None
    if base.kind not in "uif" or base.byteorder not in "=|":
        raise PorepipeError(
            f"{names('raw.dtype')} = {raw.dtype!r}: give a plain integer or float type without byte "
            f"order (set the order with {names('raw.byte_order')})"
        )
    dtype = base.newbyteorder("<" if raw.byte_order is ByteOrder.little else ">")
    expected = (
        raw.header_bytes + math.prod(int(n) for n in raw.shape) * dtype.itemsize
    )  # Python ints: no overflow
    size = path.stat().st_size
    if size != expected:
        raise PorepipeError(
            f"RAW file {path} has {size} bytes, but header {raw.header_bytes} + shape {tuple(raw.shape)} x "
            f"{dtype.itemsize} bytes ({raw.dtype}) = {expected} bytes; check "
            f"{', '.join(names(f'raw.{k}') for k in ('shape', 'dtype', 'header_bytes'))}"
        )
    return np.memmap(
        path,
        dtype=dtype,
        mode="r",
        offset=raw.header_bytes,
        shape=tuple(raw.shape),
        order="F" if raw.order is MemoryOrder.F else "C",
    )


# -- NumPy, HDF5 ---------------------------------------------------------------------------------------------------
def read_npy(path) -> np.ndarray:
    """Memory-map a ``.npy`` file (axes taken as x, y[, z])."""
    try:
        with open(path, "rb") as f:
            magic = f.read(len(np.lib.format.MAGIC_PREFIX))
    except OSError as err:
        raise PorepipeError(f"{path} is not a readable .npy file: {err}") from err
    if magic != np.lib.format.MAGIC_PREFIX:  # numpy took it for a pickle and advised allow_pickle
        raise PorepipeError(
            f"{path} is not a .npy file (no NumPy header); if it is an image of another format, set that format "
            "(acquire.format, --format)"
        )
    try:
        return np.load(path, mmap_mode="r", allow_pickle=False)
    except (ValueError, OSError, EOFError) as err:  # EOFError: an empty file
        raise PorepipeError(f"{path} is not a readable .npy file: {err}") from err


def _spacing_from_attr(value) -> tuple[float, ...] | None:
    arr = np.atleast_1d(np.asarray(value, dtype=np.float64))
    return tuple(float(v) for v in arr) if arr.size in (1, 2, 3) else None


def read_hdf5(
    path, dataset: str | None, names: SettingNames = SCENE_KEYS
) -> tuple[h5py.Dataset, tuple[float, ...] | None]:
    """Open ``dataset`` of an HDF5 file lazily; the spacing from its ``voxel_um`` / ``element_size_um`` attribute.

    The file stays open as long as the returned dataset is referenced (h5py closes it with the last reference).
    """
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise PorepipeError(f"{path} is not a readable HDF5 file: {err}") from err
    try:
        return _hdf5_image(f, path, dataset, names)
    except (KeyError, RuntimeError, OSError, TypeError, ValueError) as err:  # damaged metadata
        raise PorepipeError(f"HDF5 file {path} is damaged: {type(err).__name__}: {err}") from None


def _hdf5_image(
    f: h5py.File, path, dataset: str | None, names: SettingNames
) -> tuple[h5py.Dataset, tuple[float, ...] | None]:
    if dataset is None:
        found = []
        f.visititems(
            lambda name, obj: found.append(name) if isinstance(obj, h5py.Dataset) and obj.ndim >= 2 else None
        )
        if len(found) != 1:
            raise PorepipeError(
                f"HDF5 file {path}: give the image's dataset with {names('dataset')} (one of its image datasets "
                f"{found})"
            )
        dataset = found[0]
    if dataset not in f or not isinstance(f[dataset], h5py.Dataset):
        raise PorepipeError(f"HDF5 file {path} has no dataset {dataset!r}")
    dset = f[dataset]
    spacing = None
    for key in ("voxel_um", "element_size_um"):
        if key in dset.attrs:
            spacing = _spacing_from_attr(dset.attrs[key])
    return dset, spacing


# -- TIFF ----------------------------------------------------------------------------------------------------------
def _tiff_spacing(tif) -> tuple[float, float, float | None] | None:
    """(x, y, z) µm per voxel from resolution tags and ImageJ metadata; None without a usable resolution."""
    page = tif.pages.first
    tags = page.tags
    if "XResolution" not in tags or "YResolution" not in tags:
        return None
    ij = tif.imagej_metadata or {}
    unit_tag = int(tags["ResolutionUnit"].value) if "ResolutionUnit" in tags else 1
    if ij.get("unit") is not None:
        unit_um = _IMAGEJ_UNIT_UM.get(str(ij["unit"]))
    else:
        unit_um = _TIFF_UNIT_UM.get(unit_tag)
    if unit_um is None:
        return None

    def per_pixel(tag):
        num, den = tags[tag].value
        return unit_um * den / num if num > 0 else None

    sx, sy = per_pixel("XResolution"), per_pixel("YResolution")
    if sx is None or sy is None:
        return None
    sz = float(ij["spacing"]) * unit_um if "spacing" in ij else None
    return sx, sy, sz


def _section_files(path: Path) -> list[str]:
    pattern = str(path / "*") if path.is_dir() else str(path)
    files = sorted(f for f in glob.glob(pattern) if Path(f).suffix.lower() in (".tif", ".tiff"))
    if not files:
        raise PorepipeError(f"no TIFF sections found at {pattern}")
    return files


#: what tifffile raises on damaged or unusual files besides its own error (a bad offset, a short tag, a bad code)
_TIFF_ERRORS = (OSError, ValueError, IndexError, KeyError, TypeError, struct.error)


def _check_tiff_page(tif, name: str) -> None:
    """Refuse a file without image data, with colour samples, or too large for this machine's free memory."""
    if not len(tif.pages) or not tif.series:
        raise PorepipeError(f"TIFF {name} holds no image page (damaged or not a TIFF)")
    page, series = tif.pages[0], tif.series[0]
    samples = int(getattr(page, "samplesperpixel", 1) or 1)
    if samples > 1 or "S" in series.axes:
        raise PorepipeError(
            f"TIFF {name} has {samples} samples per pixel (axes {series.axes!r}, e.g. RGB); expected one "
            "grey channel: convert it to grey values first"
        )
    need = int(np.prod(series.shape, dtype=object)) * np.dtype(series.dtype).itemsize
    free = psutil.virtual_memory().available
    if need > free:
        raise PorepipeError(
            f"TIFF {name} claims shape {tuple(series.shape)} ({need / 2**30:.1f} GiB), more than the "
            f"{free / 2**30:.1f} GiB of free memory"
        )


class _LoggedErrors(logging.Handler):
    """Collects what tifffile logs at ERROR level: it reports a broken page chain there and reads on with fewer
    pages (a 97 % truncated stack came back with fewer sections and no exception).
    """

    def __init__(self):
        super().__init__(logging.ERROR)
        self.messages: list[str] = []

    def emit(self, record):
        self.messages.append(record.getMessage())


def _read_tiff_file(name: str, tifffile) -> tuple[np.ndarray, tuple | None]:
    logger, errors = logging.getLogger("tifffile"), _LoggedErrors()
    logger.addHandler(errors)
    try:
        with tifffile.TiffFile(name) as tif:
            _check_tiff_page(tif, name)
            data, spacing = tif.series[0].asarray(), _tiff_spacing(tif)
            size = tif.filehandle.size
            for page in tif.pages:
                ends = [o + c for o, c in zip(page.dataoffsets, page.databytecounts, strict=False)]
                if ends and max(ends) > size:
                    errors.messages.append(
                        f"page data end at byte {max(ends)} beyond the file's {size} bytes"
                    )
    finally:
        logger.removeHandler(errors)
    if errors.messages:
        raise PorepipeError(
            f"TIFF {name} is damaged or truncated: {' '.join(errors.messages[0].split())[:200]}"
        )
    return data, spacing


def read_tiff(path) -> tuple[np.ndarray, tuple | None, bool]:
    """Read a TIFF file (2-D, multi-page or 3-D) or a directory/glob of 2-D sections stacked along z.

    Returns
    -------
    data : (x, y, z) ndarray
    spacing : (sx, sy, sz or None) in µm, or None
    is_2d : bool

    Raises
    ------
    PorepipeError
        A damaged file, colour samples, a shape larger than the free memory, or sections of unequal shape.
    """
    import tifffile

    path = Path(path)
    files = [str(path)] if path.is_file() else _section_files(path)
    current = files[0]
    try:
        arr, spacing = _read_tiff_file(current, tifffile)
        if len(files) > 1:
            sections = [arr]
            for current in files[1:]:
                section = _read_tiff_file(current, tifffile)[0]
                if section.shape != arr.shape:
                    raise PorepipeError(
                        f"TIFF section {current} has shape {section.shape}, the first section "
                        f"{files[0]} has {arr.shape}; all sections must have one shape"
                    )
                sections.append(section)
            arr = np.stack(sections)
    except (tifffile.TiffFileError, *_TIFF_ERRORS) as err:
        raise PorepipeError(f"cannot read TIFF {current}: {err}") from err
    if arr.ndim == 2:
        return arr.T[:, :, None], spacing, len(files) == 1
    if arr.ndim != 3:
        raise PorepipeError(
            f"TIFF {path} has shape {arr.shape}; expected one grey channel (2-D or 3-D, no colour)"
        )
    return arr.transpose(2, 1, 0), spacing, False


# -- public reader -------------------------------------------------------------------------------------------------
def _as_volume(arr, source: str) -> tuple[np.ndarray, bool]:
    if arr.ndim == 2:
        return arr[:, :, None], True
    if arr.ndim != 3:
        raise PorepipeError(f"image {source} has {arr.ndim} dimensions (shape {arr.shape}); expected 2 or 3")
    return arr, False


def read_image(
    path,
    fmt: ImageFormat = ImageFormat.auto,
    *,
    raw: Raw | None = None,
    dataset: str | None = None,
    voxel_um: float | None = None,
    section_um: float | None = None,
    names: SettingNames = SCENE_KEYS,
) -> Image:
    """Open an image of any supported format as (x, y, z) with its voxel edges.

    Parameters
    ----------
    path : path-like
        File, directory of 2-D TIFF sections, or a glob of them.
    fmt : ImageFormat
        Format; auto picks by suffix.
    raw : Raw, optional
        Needed for RAW files: dtype, shape (x, y, z), byte order, header bytes, memory order.
    dataset : str, optional
        Dataset inside an HDF5 file (optional when the file has exactly one image dataset).
    voxel_um : float, optional
        Voxel edge in µm; overrides the file's metadata for x and y (and z unless ``section_um`` is given).
    section_um : float, optional
        Spacing of serial sections along z in µm.
    names : SettingNames
        How messages name the settings (default: the scene keys; ``porepipe acquire``: its options).

    Returns
    -------
    Image
        ``spacing_um`` is None if neither the file nor the caller gave a voxel size.
    """
    path = Path(path)
    source = str(path)
    fmt = detect_format(path, fmt, names)
    if fmt is not ImageFormat.tiff and not path.is_file():
        raise PorepipeError(f"image file {path} does not exist")
    file_spacing = None
    if fmt is ImageFormat.raw:
        if raw is None:
            layout = (
                f"{names('raw.shape')} NX NY NZ (and {names('raw.dtype')}, {names('raw.byte_order')}, "
                f"{names('raw.header_bytes')} unless uint8, little-endian, no header)"
                if names.by_option("raw.shape")
                else "acquire.raw (dtype, shape, byte_order, header_bytes)"
            )
            raise PorepipeError(f"RAW image {path}: give {layout}")
        data, is_2d = read_raw(path, raw, names), False
    elif fmt is ImageFormat.npy:
        data, is_2d = _as_volume(read_npy(path), source)
    elif fmt is ImageFormat.hdf5:
        dset, file_spacing = read_hdf5(path, dataset, names)
        data, is_2d = (dset[...], True) if dset.ndim == 2 else (dset, False)
        data, is_2d = _as_volume(data, source)
        source = f"{path}:{dset.name}"
    else:
        data, file_spacing, is_2d = read_tiff(path)
    # one voxel along z is a section whatever the file (a RAW of shape NX NY 1 was refused as a volume too thin for
    # the 3-D statistics, with the advice to stack sections, where the same section as a 2-D TIFF was measured)
    is_2d = is_2d or data.shape[2] == 1
    _warn_if_overridden(source, file_spacing, voxel_um)
    return Image(data, _spacing(file_spacing, voxel_um, section_um), source, is_2d)


def _warn_if_overridden(source: str, file_spacing: Sequence | None, voxel_um: float | None) -> None:
    """One line on stderr when the caller's voxel size replaces a different one the file states."""
    stated = [float(s) for s in (file_spacing or []) if s is not None]
    if voxel_um is None or not stated:
        return
    if any(not math.isclose(s, float(voxel_um), rel_tol=1e-6) for s in stated):
        print(
            f"porepipe acquire: warning: {source} states a voxel size of "
            f"{' × '.join(f'{s:g}' for s in stated)} µm; using the given {float(voxel_um):g} µm instead",
            file=sys.stderr,
        )


def _spacing(file_spacing: Sequence | None, voxel_um: float | None, section_um: float | None):
    sx = sy = sz = None
    if file_spacing is not None:
        vals = list(file_spacing) + [None] * (3 - len(file_spacing))
        if len(file_spacing) == 1:
            vals = [file_spacing[0]] * 3
        sx, sy, sz = vals[:3]
        sz = sz if sz is not None else sx
    if voxel_um is not None:
        sx = sy = sz = float(voxel_um)
    if section_um is not None:
        sz = float(section_um)
    if sx is None or sy is None or sz is None:
        return None
    return float(sx), float(sy), float(sz)


def require_spacing(image: Image) -> tuple[float, float, float]:
    """The image's voxel edges; a missing voxel size is an error (never a silent 1)."""
    if image.spacing_um is None:
        raise PorepipeError(
            f"image {image.source} has no voxel size in its metadata; give it (acquire.voxel_um in "
            "the scene, --voxel-um on the command line)"
        )
    bad = [s for s in image.spacing_um if not np.isfinite(s) or s <= 0]
    if bad:
        raise PorepipeError(
            f"image {image.source}: voxel size {image.spacing_um} µm is not positive and finite"
        )
    return image.spacing_um
