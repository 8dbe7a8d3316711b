"""Initial state of a packing stage: radius sampling (§5.1), placement by count or density, sub-regions (gfile),
spheres read from a file (PackDEM ``init = file``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.spheres import check_spheres, read_xyzr
from porepipe.packing._io import read_packing
from porepipe.packing._settings import RadiusDist, RadiusSpec, Settings, SphereFile, SphereFormat, SphereType


def _discrete_table(spec: RadiusSpec, base_dir: Path) -> tuple[np.ndarray, np.ndarray]:
    """(radii, probabilities) of a discrete distribution, inline or from a `radii_prob` file."""
    if spec.values_um is not None:
        return np.asarray(spec.values_um, dtype=np.float64), np.asarray(spec.probabilities, dtype=np.float64)
    path = Path(spec.file)
    path = path if path.is_absolute() else Path(base_dir) / path
    if not path.is_file():
        raise PorepipeError(f"packing radius file (radius_um.file) {path} does not exist")
    try:
        data = np.loadtxt(path, ndmin=2, comments="#")
    except ValueError as err:
        raise PorepipeError(f"{path}: expected 'radius probability' per line: {err}") from err
    if data.shape[1] != 2 or data.shape[0] == 0:
        raise PorepipeError(f"{path}: expected two columns 'radius probability', got shape {data.shape}")
    values, probs = data[:, 0], data[:, 1]
    if (values <= 0).any() or (probs < 0).any() or abs(probs.sum() - 1.0) > 1e-6:
        raise PorepipeError(
            f"{path}: radii must be > 0 and probabilities >= 0 summing to 1 (sum {probs.sum()!r})"
        )
    return values, probs


def radius_bounds(spec: RadiusSpec, base_dir: Path | str = ".") -> tuple[float, float]:
    """(r_min, r_max) of a type in µm: the bounds of its distribution (or of its discrete radii)."""
    if spec.dist is RadiusDist.discrete:
        values, _ = _discrete_table(spec, Path(base_dir))
        lo, hi = float(values.min()), float(values.max())
        return (spec.min_um or lo, spec.max_um or hi)
    return float(spec.min_um), float(spec.max_um)


def sample_radii(
    spec: RadiusSpec, n: int, rng: np.random.Generator, base_dir: Path | str = "."
) -> np.ndarray:
    """Draw ``n`` initial radii in µm from the distribution of §5.1 (or ``initial_um`` for all).

    The truncated exponential P(r) = alpha exp(-alpha r) / (exp(-alpha r_min) - exp(-alpha r_max)) is sampled by
    inverting its CDF; alpha = 0 gives the uniform distribution, as in PackDEM.
    """
    if spec.initial_um is not None:
        return np.full(n, float(spec.initial_um))
    if spec.dist is RadiusDist.discrete:
        values, probs = _discrete_table(spec, Path(base_dir))
        return values[rng.choice(values.size, size=n, p=probs / probs.sum())]
    lo, hi = float(spec.min_um), float(spec.max_um)
    u = rng.random(n)
    if spec.dist is RadiusDist.uniform or spec.alpha_per_um == 0.0 or lo == hi:
        return lo + (hi - lo) * u
    a = spec.alpha_per_um
    # r = r_min - ln(1 - u (1 - exp(-a (r_max - r_min)))) / a, written to stay accurate for large a (r_max - r_min)
    return np.minimum(lo - np.log1p(-u * (-np.expm1(-a * (hi - lo)))) / a, hi)


def region_table(
    settings: Settings, box_um: np.ndarray, base_dir: Path | str = "."
) -> tuple[np.ndarray, np.ndarray]:
    """Region cubes of `regions` (gfile/gres): (cubes per axis (3,), type index per cube, x fastest)."""
    reg = settings.regions
    names = [t.name for t in settings.types]
    ncube = box_um / reg.cube_um
    if np.any(np.abs(ncube - np.round(ncube)) > 1e-9 * np.maximum(1.0, ncube)):
        raise PorepipeError(
            f"packing.regions.cube_um = {reg.cube_um} does not divide the box {box_um.tolist()} µm"
        )
    ncube = np.round(ncube).astype(np.int64)
    if reg.types is not None:
        table = np.array([names.index(t) for t in reg.types], dtype=np.int64)
    else:
        path = Path(reg.file)
        path = path if path.is_absolute() else Path(base_dir) / path
        if not path.is_file():
            raise PorepipeError(f"packing.regions.file {path} does not exist")
        try:
            table = np.array(path.read_text().split(), dtype=np.int64) - 1
        except ValueError as err:
            raise PorepipeError(
                f"{path}: expected whitespace-separated type numbers 1..{len(names)}"
            ) from err
        if table.size and (table.min() < 0 or table.max() >= len(names)):
            raise PorepipeError(f"{path}: type numbers must lie in 1..{len(names)}")
    if table.size != int(np.prod(ncube)):
        raise PorepipeError(
            f"packing.regions lists {table.size} cubes, the box holds {int(np.prod(ncube))} "
            f"({ncube.tolist()} cubes of {reg.cube_um} µm)"
        )
    return ncube, table


def place_type(
    t: int,
    stype: SphereType,
    settings: Settings,
    box_um: np.ndarray,
    rng: np.random.Generator,
    base_dir: Path | str = ".",
) -> tuple[np.ndarray, np.ndarray]:
    """Random centres (N, 3) and radii (N,) of type ``t``: uniform in the type's regions (the whole box if none).

    The count is ``count``, or ``round(rho * V)`` with V the volume of the type's regions.
    """
    cubes = None
    volume = float(np.prod(box_um))
    if settings.regions is not None:
        ncube, table = region_table(settings, box_um, base_dir)
        mine = np.flatnonzero(table == t)
        if mine.size:
            cubes = (ncube, mine)
            volume *= mine.size / table.size
    n = stype.count if stype.count is not None else int(round(stype.number_density_per_um3 * volume))
    if cubes is None:
        centres = rng.random((n, 3)) * box_um
    else:
        ncube, mine = cubes
        pick = mine[rng.integers(0, mine.size, size=n)]
        idx = np.stack(
            [pick % ncube[0], (pick // ncube[0]) % ncube[1], pick // (ncube[0] * ncube[1])], axis=1
        )
        centres = (idx + rng.random((n, 3))) * (box_um / ncube)
    return centres, sample_radii(stype.radius_um, n, rng, base_dir)


def _read_dat(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """PackDEM ``dat``: 'index type x y z r' per line; returns centres, radii, 1-based type numbers."""
    try:
        data = np.loadtxt(path, ndmin=2, comments="#")
    except ValueError as err:
        raise PorepipeError(f"{path}: expected 'index type x y z r' per line: {err}") from err
    if data.size == 0:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64)
    if data.shape[1] != 6:
        raise PorepipeError(f"{path}: expected 6 columns 'index type x y z r', got {data.shape[1]}")
    numbers = data[:, 1]
    if np.any(numbers != np.round(numbers)):
        raise PorepipeError(f"{path}: the type column (2nd) must hold whole numbers 1..N_types")
    return data[:, 2:5], data[:, 5], numbers.astype(np.int64)


def _file_format(spec: SphereFile) -> SphereFormat:
    if spec.format is not SphereFormat.auto:
        return spec.format
    suffix = spec.path.suffix.lower()
    return (
        SphereFormat.packing
        if suffix in (".h5", ".hdf5")
        else SphereFormat.dat
        if suffix == ".dat"
        else SphereFormat.xyzr
    )


def _file_types(spec: SphereFile, fmt: SphereFormat, path: Path, raw, n: int, names: list[str]) -> np.ndarray:
    """Type index of every sphere of the file: the override ``type``, or the file's own numbers / names."""
    if spec.type is not None:
        return np.full(n, names.index(spec.type), dtype=np.int64)
    if fmt is SphereFormat.xyzr:
        raise PorepipeError(f"packing insert_file {path}: an xyzr file has no types; set insert_file.type")
    if fmt is SphereFormat.dat:
        bad = np.flatnonzero((raw < 1) | (raw > len(names)))
        if bad.size:
            raise PorepipeError(
                f"{path}: line {bad[0] + 1} has type number {raw[bad[0]]}; the scene's types are "
                f"1..{len(names)} ({names})"
            )
        return raw - 1
    file_names, numbers = raw
    unknown = sorted({file_names[k] for k in np.unique(numbers)} - set(names))
    if unknown:
        raise PorepipeError(
            f"{path}: sphere type(s) {unknown} are not types of this scene ({names}); set "
            "insert_file.type to map every sphere to one type"
        )
    lookup = np.array([names.index(t) if t in names else -1 for t in file_names], dtype=np.int64)
    return lookup[numbers]


def read_sphere_file(
    spec: SphereFile, settings: Settings, box_um: np.ndarray, periodic: np.ndarray, base_dir: Path | str = "."
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres (N, 3), radii (N,) and type indices (N,) of the spheres of ``spec`` (PackDEM ``init = file``).

    Periodic coordinates are wrapped into [0, L); a centre outside a closed axis, or a radius outside the
    bounds of its type (which the radius protocol keeps), is an error naming the sphere.
    """
    path = spec.path if spec.path.is_absolute() else Path(base_dir) / spec.path
    if not path.is_file():
        raise PorepipeError(f"packing insert_file.path {path} does not exist")
    names = [t.name for t in settings.types]
    fmt = _file_format(spec)
    if fmt is SphereFormat.packing:
        data = read_packing(path)
        centres, radii = check_spheres(data["centres_um"], data["radii_um"], str(path))
        raw = (data["type_names"], data["types"].astype(np.int64))
    elif fmt is SphereFormat.dat:
        centres, radii, raw = _read_dat(path)
        centres, radii = check_spheres(centres, radii, str(path))
    else:
        (centres, radii), raw = read_xyzr(path), None
    types = _file_types(spec, fmt, path, raw, radii.size, names)
    per = np.asarray(periodic, dtype=bool)
    centres[:, per] = np.mod(centres[:, per], box_um[per])
    outside = np.flatnonzero(((centres < 0) | (centres > box_um)).any(axis=1))
    if outside.size:
        i = outside[0]
        raise PorepipeError(
            f"{path}: sphere {i} at {centres[i].tolist()} µm lies outside the box {box_um.tolist()} "
            "µm along a closed (non-periodic) axis"
        )
    bounds = np.array([radius_bounds(t.radius_um, base_dir) for t in settings.types])
    lo, hi = bounds[types, 0], bounds[types, 1]
    bad = np.flatnonzero((radii < lo * (1 - 1e-12)) | (radii > hi * (1 + 1e-12)))
    if bad.size:
        i = bad[0]
        raise PorepipeError(
            f"{path}: sphere {i} has r = {radii[i]} µm outside [{lo[i]}, {hi[i]}] µm of its type "
            f"{names[types[i]]!r}; widen that type's radius_um min_um/max_um"
        )
    return centres, radii, types
