"""Reading sphere sets (the matrix) from the scene's sources: inline lists, xyzr text files, packing HDF5 files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from porepipe._shared.atomic import atomic_path
from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import open_h5


def check_spheres(
    centres_um: np.ndarray, radii_um: np.ndarray, source: str = "spheres"
) -> tuple[np.ndarray, np.ndarray]:
    """Return float64 copies of (centres (N, 3), radii (N,)) after checking shapes and values."""
    centres = np.ascontiguousarray(centres_um, dtype=np.float64)
    radii = np.ascontiguousarray(radii_um, dtype=np.float64)
    if centres.ndim != 2 or centres.shape[1] != 3:
        raise PorepipeError(f"{source}: centres need shape (N, 3), got {centres.shape}")
    if radii.shape != (centres.shape[0],):
        raise PorepipeError(f"{source}: radii need shape ({centres.shape[0]},), got {radii.shape}")
    if not (np.isfinite(centres).all() and np.isfinite(radii).all()):
        raise PorepipeError(f"{source}: centres and radii must be finite (found NaN or Inf)")
    bad = np.flatnonzero(radii <= 0)
    if bad.size:
        raise PorepipeError(f"{source}: sphere {bad[0]} has radius {radii[bad[0]]}; allowed: r > 0")
    return centres, radii


def read_xyzr(path) -> tuple[np.ndarray, np.ndarray]:
    """Read a PackDEM ``xyzr`` file: one sphere per line, ``x y z r`` in µm; ``#`` starts a comment."""
    path = Path(path)
    if not path.is_file():
        raise PorepipeError(f"xyzr file {path} does not exist")
    rows = []
    for lineno, line in enumerate(path.read_text().splitlines(), start=1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        parts = text.replace(",", " ").split()
        if len(parts) != 4:
            raise PorepipeError(f"{path}:{lineno}: expected 4 numbers 'x y z r', got {len(parts)}: {line!r}")
        try:
            rows.append([float(p) for p in parts])
        except ValueError as err:
            raise PorepipeError(f"{path}:{lineno}: not a number in {line!r}") from err
    data = np.array(rows, dtype=np.float64).reshape(-1, 4)
    return check_spheres(data[:, :3], data[:, 3], str(path))


def write_xyzr(path, centres_um: np.ndarray, radii_um: np.ndarray) -> None:
    """Write spheres as ``x y z r`` lines (µm, full float64 precision)."""
    data = np.column_stack([centres_um, radii_um])
    with atomic_path(path) as tmp:  # a kill mid-write must not leave a short file that looks finished
        np.savetxt(tmp, data, fmt="%.17g", header="x_um y_um z_um r_um")


def read_packing_h5(path) -> tuple[np.ndarray, np.ndarray]:
    """Read centres and radii from a ``packing.h5`` (datasets ``centres_um`` (N, 3) and ``radii_um`` (N,))."""
    path = Path(path)
    if not path.is_file():
        raise PorepipeError(f"packing file {path} does not exist")
    with open_h5(path) as f:
        missing = [k for k in ("centres_um", "radii_um") if k not in f]
        if missing:
            raise PorepipeError(f"{path} is not a packing file: missing dataset(s) {missing}")
        return check_spheres(f["centres_um"][...], f["radii_um"][...], str(path))


def spheres_from_scene(scene, packing_path=None) -> tuple[np.ndarray, np.ndarray]:
    """The scene's spheres; ``packing_path`` is the packing stage's output when ``spheres.pack`` is set."""
    src = scene.spheres
    if src.inline is not None:
        data = np.array(src.inline, dtype=np.float64).reshape(-1, 4)
        return check_spheres(data[:, :3], data[:, 3], "spheres.inline")
    if src.xyzr is not None:
        return read_xyzr(src.xyzr)
    path = src.hdf5 if src.hdf5 is not None else packing_path
    if path is None:
        raise PorepipeError("spheres.pack is set but no packing file was given (run the pack stage first)")
    return read_packing_h5(path)
