"""Local porosity theory (thesis §4.6): local porosity and S_V distributions, local percolation probabilities.

Conventions
-----------
- ``pore`` is a (nx, ny, nz) uint8 volume, 1 = pore, axes (x, y, z); voxels are cubes of edge ``voxel_um``.
- A measurement cell of edge L voxels has its origin (lowest corner) at a grid position; along an axis on which
  cells wrap, every voxel is an origin and the cell continues on the opposite side, otherwise only origins with
  the cell fully inside are used (m = n - L + 1). Strides pick every s-th origin on every axis.
- Local porosities are k/L³ with k pore voxels in the cell; histograms over k are exact while there are few enough
  values, else binned (φ = 0 and φ = 1 always have their own bins, so L* of eq. 4.6.4 is exact).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numba
import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe.lpt import _kernels as K
from porepipe.lpt._settings import Connectivity, Direction, Placement, Settings

#: cell origins along x per parallel batch (more = fewer parallel launches, more ring memory)
_BATCH = 16
#: largest histogram kept per thread without binning (2^24 bins = 128 MiB of int64 counts and as much for sums)
_MAX_EXACT_BINS = 1 << 24
_DIRECTION_BITS = {
    Direction.x: K.BIT_X,
    Direction.y: K.BIT_Y,
    Direction.z: K.BIT_Z,
    Direction.all3: K.BIT_ALL,
    Direction.any: K.BIT_ANY,
}
SURFACE_METHOD = (
    "face counting: F = number of voxel faces between a pore and a matrix voxel with both voxels in the cell; "
    "S_V = (2/3) F / (L^3 a), the stereological intercept estimator averaged over x, y, z (exact on average "
    "for isotropic interfaces; an axis-aligned plane gives 2/3 of its true area)"
)


# -- cell grids -----------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class CellGrid:
    """Origins of the cells of edge ``size`` voxels in a sample of ``shape`` voxels.

    Attributes
    ----------
    size : int
        Cell edge L in voxels.
    shape : tuple of 3 int
        Sample shape.
    wrap : tuple of 3 bool
        Whether cells wrap around along each axis.
    npos : tuple of 3 int
        Origins per axis at stride 1: n if wrapping, else n - L + 1.
    """

    size: int
    shape: tuple[int, int, int]
    wrap: tuple[bool, bool, bool]

    @property
    def npos(self) -> tuple[int, int, int]:
        return tuple(n if w else n - self.size + 1 for n, w in zip(self.shape, self.wrap))

    def count(self, stride: int) -> int:
        """Number of cells with origins on the grid of the given stride."""
        return int(np.prod([-(-m // stride) for m in self.npos], dtype=np.int64))

    def origins(self, stride: int) -> np.ndarray:
        """(n, 3) int64 origins at the stride, in C order (x slowest)."""
        axes = [np.arange(0, m, stride, dtype=np.int64) for m in self.npos]
        grid = np.meshgrid(*axes, indexing="ij")
        return np.stack([g.ravel() for g in grid], axis=1)

    def describe(self, stride: int) -> str:
        parts = []
        for name, w, m in zip("xyz", self.wrap, self.npos):
            kind = "periodic wrap, all n origins" if w else "fully inside, n - L + 1 origins"
            parts.append(f"{name}: {kind} ({m} at stride 1)")
        return f"cubes of L = {self.size} voxels, origins every {stride} voxel(s); " + "; ".join(parts)


def cell_grid(shape: Sequence[int], size: int, wrap: Sequence[bool] = (False, False, False)) -> CellGrid:
    """Validated :class:`CellGrid`; a cell larger than the sample on any axis is refused."""
    shape = tuple(int(n) for n in shape)
    size = int(size)
    if len(shape) != 3 or min(shape) < 1:
        raise PorepipeError(f"lpt needs a 3-D volume with positive edges, got shape {shape}")
    if size < 1:
        raise PorepipeError(f"cell edge L must be at least 1 voxel, got {size}")
    if size > min(shape):
        raise PorepipeError(
            f"cell edge L = {size} voxels exceeds the sample (shape {shape}); allowed: 1 <= L <= {min(shape)}"
        )
    return CellGrid(size, shape, tuple(bool(w) for w in wrap))


def auto_stride(grid: CellGrid, max_cells: int) -> int:
    """Smallest stride whose grid has at most ``max_cells`` cells."""
    stride = 1
    while grid.count(stride) > max_cells:
        stride += 1
    return stride


# -- histograms of box sums ---------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class BoxHistogram:
    """Histogram of box sums k (pore voxels, or interface faces) over cells.

    Attributes
    ----------
    counts : (n_bins,) int64 ndarray
        Cells per bin.
    k_sum : (n_bins,) int64 ndarray
        Sum of k over the cells of each bin (so means are exact even when bins hold several k).
    k_sq_sum : float
        Sum of k² over all cells.
    k_lo, k_hi : (n_bins,) int64 ndarray
        Smallest and largest k of each bin.
    k_max : int
        Largest possible k.
    exact : bool
        Every bin holds exactly one k (k_lo == k_hi).
    records : ndarray or None
        Box sums at the origins of the record stride (C order), if asked for.
    """

    counts: np.ndarray
    k_sum: np.ndarray
    k_sq_sum: float
    k_lo: np.ndarray
    k_hi: np.ndarray
    k_max: int
    exact: bool
    records: np.ndarray | None

    @property
    def n_cells(self) -> int:
        return int(self.counts.sum())


def bin_ranges(k_max: int, n_bins: int) -> tuple[np.ndarray, np.ndarray]:
    """k_lo, k_hi of every bin of the binning in :func:`porepipe.lpt._kernels._bin_of`."""
    if n_bins == k_max + 1:
        k = np.arange(k_max + 1, dtype=np.int64)
        return k, k.copy()
    j = np.arange(1, n_bins - 1, dtype=np.int64)
    lo = 1 + -(-((j - 1) * (k_max - 1)) // (n_bins - 2))  # smallest k with bin >= j
    hi = np.append(lo[1:] - 1, k_max - 1)
    return np.concatenate([[0], lo, [k_max]]), np.concatenate([[0], hi, [k_max]])


def bins_of(k: np.ndarray, k_max: int, n_bins: int) -> np.ndarray:
    """Bin index of each box sum k (same binning as the kernels)."""
    k = np.asarray(k, dtype=np.int64)
    if n_bins == k_max + 1:
        return k.copy()
    inner = 1 + ((np.clip(k, 1, k_max - 1) - 1) * (n_bins - 2)) // (k_max - 1)
    return np.where(k <= 0, 0, np.where(k >= k_max, n_bins - 1, inner))


def _box_histogram(
    fields: np.ndarray,
    wins: np.ndarray,
    grid: CellGrid,
    stride: int,
    max_bins: int | None,
    record_stride: int = 0,
) -> BoxHistogram:
    """Run :func:`_box_sum_histogram` on C-contiguous uint8 ``fields`` (nf, nx, ny, nz) with windows ``wins``."""
    k_max = int(sum(int(np.prod(w)) for w in wins))
    if max_bins is None and k_max + 1 > _MAX_EXACT_BINS:
        raise PorepipeError(
            f"an exact histogram would need {k_max + 1} bins (cell of {k_max} voxels or faces); "
            f"give max_bins (at most {_MAX_EXACT_BINS}) to bin it"
        )
    n_bins = k_max + 1 if max_bins is None or k_max + 1 <= max_bins else int(max_bins)
    if n_bins < 3 and n_bins != k_max + 1:
        raise PorepipeError(f"max_bins must be at least 3, got {max_bins}")
    _, my, mz = grid.npos
    ring_dtype = np.uint16 if max(int(w[1] * w[2]) for w in wins) <= np.iinfo(np.uint16).max else np.uint32
    ring = np.empty((fields.shape[0], int(wins[:, 0].max()) + _BATCH + 1, my, mz), ring_dtype)
    nt = numba.get_num_threads()
    hist = np.zeros((nt, n_bins), np.int64)
    ksum = np.zeros((nt, n_bins), np.int64)
    ksq = np.zeros((nt, 2), np.int64)  # exact Σk² in two 32-bit words per thread block
    if record_stride > 0:
        rec = np.zeros(tuple(-(-m // record_stride) for m in grid.npos), np.int64)
    else:
        rec = np.zeros((1, 1, 1), np.int64)
    K._box_sum_histogram(
        fields,
        np.ascontiguousarray(wins, dtype=np.int64),
        np.asarray(grid.npos, np.int64),
        ring,
        int(stride),
        k_max,
        hist,
        ksum,
        ksq,
        int(record_stride),
        rec,
    )
    k_lo, k_hi = bin_ranges(k_max, n_bins)
    return BoxHistogram(
        hist.sum(axis=0),
        ksum.sum(axis=0),
        float(sum((int(high) << 32) + int(low) for high, low in ksq)),  # exact integer, then one rounding
        k_lo,
        k_hi,
        k_max,
        n_bins == k_max + 1,
        rec.ravel() if record_stride > 0 else None,
    )


def _as_pore(pore) -> np.ndarray:
    pore = np.asarray(pore)
    if pore.ndim != 3 or min(pore.shape) < 1:
        raise PorepipeError(f"lpt needs a 3-D pore volume, got shape {pore.shape}")
    if pore.dtype == np.bool_:
        pore = pore.view(np.uint8)
    if pore.dtype != np.uint8:
        raise PorepipeError(f"pore volume must be uint8 (1 = pore, 0 = matrix) or bool, got {pore.dtype}")
    if pore.size and pore.max() > 1:
        raise PorepipeError(f"pore volume must hold only 0 and 1, found {int(pore.max())}")
    return np.ascontiguousarray(pore)


def local_porosity_histogram(
    pore,
    size: int,
    *,
    wrap: Sequence[bool] = (False, False, False),
    stride: int = 1,
    max_bins: int | None = None,
    record_stride: int = 0,
) -> BoxHistogram:
    """Histogram of the pore-voxel count k of every cell of edge ``size`` (local porosity φ = k / size³).

    Parameters
    ----------
    pore : (nx, ny, nz) uint8 or bool ndarray
        1 = pore.
    size : int
        Cell edge L in voxels, 1 <= L <= min(shape).
    wrap : 3 bools
        Cells wrap around along these axes (use for periodic samples).
    stride : int
        Origins every ``stride`` voxels on every axis.
    max_bins : int, optional
        None: exact, one bin per k = 0..L³. Else at most this many bins (exact if L³ + 1 <= max_bins).
    record_stride : int
        Also return k at the origins of this stride (0 = no).

    Returns
    -------
    BoxHistogram

    Notes
    -----
    Thesis eq. 4.6.1 with a single Minkowski density, φ. Summed-volume idea made incremental: cost O(N) per L
    whatever L is (see :mod:`porepipe.lpt._kernels`).
    """
    pore = _as_pore(pore)
    grid = cell_grid(pore.shape, size, wrap)
    if stride < 1:
        raise PorepipeError(f"stride must be >= 1, got {stride}")
    wins = np.array([[size, size, size]], np.int64)
    return _box_histogram(pore[None], wins, grid, stride, max_bins, record_stride)


def interface_fields(pore, wrap: Sequence[bool]) -> np.ndarray:
    """(3, nx, ny, nz) uint8: 1 where voxel v and v + e_axis differ (the face between them is pore/matrix).

    Along a non-wrapping axis the last plane has no neighbour and is 0.
    """
    pore = _as_pore(pore)
    faces = np.empty((3,) + pore.shape, np.uint8)
    for axis in range(3):
        np.not_equal(pore, np.roll(pore, -1, axis=axis), out=faces[axis].view(bool))
        if not wrap[axis]:
            index = [slice(None)] * 3
            index[axis] = -1
            faces[axis][tuple(index)] = 0
    return faces


def local_surface_histogram(
    pore,
    size: int,
    *,
    wrap: Sequence[bool] = (False, False, False),
    stride: int = 1,
    max_bins: int | None = None,
) -> BoxHistogram:
    """Histogram of the interface-face count F of every cell (local S_V = (2/3) F / (L³ a); see SURFACE_METHOD).

    Parameters as for :func:`local_porosity_histogram`; k here is F, 0 <= F <= 3 L² (L - 1).
    """
    pore = _as_pore(pore)
    grid = cell_grid(pore.shape, size, wrap)
    if size == 1:  # a single voxel has no inner face
        counts = np.array([grid.count(stride)], np.int64)
        return BoxHistogram(
            counts, np.zeros(1, np.int64), 0.0, np.zeros(1, np.int64), np.zeros(1, np.int64), 0, True, None
        )
    wins = np.array([[size - 1, size, size], [size, size - 1, size], [size, size, size - 1]], np.int64)
    return _box_histogram(interface_fields(pore, grid.wrap), wins, grid, stride, max_bins)


# -- percolation --------------------------------------------------------------------------------------------------
def neighbour_steps(connectivity: Connectivity) -> np.ndarray:
    """(3, n_nb, 3) int64 neighbour steps per search axis, ordered so the straight step to the far face is last."""
    connectivity = Connectivity(connectivity)
    steps = np.array(
        [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) != (0, 0, 0)],
        np.int64,
    )
    if connectivity is Connectivity.face:
        steps = steps[np.abs(steps).sum(axis=1) == 1]
    out = []
    for axis in range(3):
        sideways = np.abs(np.delete(steps, axis, axis=1)).sum(axis=1)
        order = np.lexsort((-sideways, steps[:, axis]))  # by step along axis, then straighter last
        out.append(steps[order])
    return np.ascontiguousarray(np.stack(out))


def _search_plan(directions: Sequence[Direction]) -> tuple[int, int]:
    """Axes to search and the early exit that still decides every requested Λ_α."""
    directions = {Direction(d) for d in directions}
    if directions <= {Direction.all3}:
        return 7, K.STOP_ON_FAIL
    if directions <= {Direction.any}:
        return 7, K.STOP_ON_SUCCESS
    if directions & {Direction.all3, Direction.any}:
        return 7, K.STOP_NEVER
    return sum(_DIRECTION_BITS[d] for d in directions), K.STOP_NEVER


def percolation_bits(
    pore,
    size: int,
    origins: np.ndarray,
    counts: np.ndarray | None = None,
    *,
    connectivity: Connectivity = Connectivity.face,
    directions: Sequence[Direction] = tuple(Direction),
) -> np.ndarray:
    """Local percolation indicators Λ_α of cells of edge ``size`` at ``origins`` (thesis §4.6, Table 4.1).

    Parameters
    ----------
    pore : (nx, ny, nz) uint8 or bool ndarray
        1 = pore.
    size : int
        Cell edge L in voxels.
    origins : (n, 3) int ndarray
        Cell origins; cells wrap (mod shape) where they pass the sample edge.
    counts : (n,) int ndarray, optional
        Pore voxels per cell, if known (from :func:`local_porosity_histogram` records); else counted here.
    connectivity : Connectivity
        6 or 26-connected pore paths.
    directions : sequence of Direction
        Which Λ_α are needed; only those bits of the result are meaningful.

    Returns
    -------
    bits : (n,) uint8 ndarray
        Bit masks: 1 = x, 2 = y, 4 = z, 8 = all three, 16 = at least one (see ``porepipe.lpt._kernels``).

    Notes
    -----
    A cell percolates in direction e_i when its two faces perpendicular to e_i are joined by a path of pore
    voxels inside the cell. Each search is a depth-first walk from the pore voxels of one face that steps
    towards the other face first and stops as soon as it arrives.
    """
    pore = _as_pore(pore)
    cell_grid(pore.shape, size)
    if size > K.MAX_PERCOLATION_SIZE:
        raise PorepipeError(
            f"percolation cells are limited to L <= {K.MAX_PERCOLATION_SIZE} voxels, got {size}"
        )
    origins = np.ascontiguousarray(np.asarray(origins, dtype=np.int64).reshape(-1, 3))
    if origins.size and ((origins < 0).any() or (origins >= np.array(pore.shape)).any()):
        raise PorepipeError(
            f"cell origins must lie in the volume of shape {pore.shape} (0 <= origin < edge); "
            f"got values from {origins.min(axis=0).tolist()} to {origins.max(axis=0).tolist()}"
        )
    if counts is None:
        counts = np.array([_cell(pore, o, size).sum(dtype=np.int64) for o in origins], np.int64)
    counts = np.ascontiguousarray(np.asarray(counts, dtype=np.int64))
    if counts.shape != (origins.shape[0],):
        raise PorepipeError(
            f"counts needs one entry per origin: {counts.shape} vs {origins.shape[0]} origins"
        )
    want, stop = _search_plan(directions)
    out = np.zeros(origins.shape[0], np.uint8)
    if origins.shape[0]:
        n_chunks = min(origins.shape[0], 16 * numba.get_num_threads())
        steps = neighbour_steps(connectivity)
        padded = int(size) + 2
        lin = np.ascontiguousarray((steps[..., 0] * padded + steps[..., 1]) * padded + steps[..., 2])
        K._percolation_cells(pore, origins, counts, int(size), steps, lin, want, stop, n_chunks, out)
    return out


def _cell(pore: np.ndarray, origin: Sequence[int], size: int) -> np.ndarray:
    """The cell at ``origin`` as an array (wrapping); for small checks only."""
    idx = [(int(o) + np.arange(size)) % n for o, n in zip(origin, pore.shape)]
    return pore[np.ix_(*idx)]


# -- the whole analysis ---------------------------------------------------------------------------------------------
def cell_sizes(settings: Settings, voxel_um: float, shape: Sequence[int]) -> tuple[list[int], dict[str, int]]:
    """Cell edges in voxels (sorted, distinct) and, for cell_um, which voxel edge each µm value became.

    cell_um values are rounded to the nearest whole voxel count (half up); values that land on the same count are
    merged. With neither cell_um nor cell_voxels: 1, 2, 4, ... up to the smallest sample edge.
    """
    if settings.cell_voxels:
        return sorted(set(settings.cell_voxels)), {}
    if settings.cell_um:
        mapping = {}
        for um in settings.cell_um:
            size = int(np.floor(um / voxel_um + 0.5))
            if size < 1:
                raise PorepipeError(
                    f"lpt.cell_um {um} is less than half a voxel (voxel_um = {voxel_um}); "
                    f"allowed: cell_um >= {voxel_um / 2}"
                )
            mapping[f"{um:g}"] = size
        return sorted(set(mapping.values())), mapping
    sizes = [1]
    while sizes[-1] * 2 <= min(shape):
        sizes.append(sizes[-1] * 2)
    return sizes, {}


@dataclasses.dataclass
class _PerSize:
    """What one cell size contributes to the Dataset (1-D arrays over its own bins)."""

    size: int
    mu: BoxHistogram
    lam_cells: np.ndarray
    lam_perc: np.ndarray  # (n_bins, n_alpha)
    lam_stride: int
    lam_total: int
    surface: BoxHistogram | None
    placement: str


def _one_size(pore: np.ndarray, size: int, wrap: Sequence[bool], settings: Settings) -> _PerSize:
    grid = cell_grid(pore.shape, size, wrap)
    lam_stride = settings.lambda_stride or auto_stride(grid, settings.lambda_max_cells)
    mu = local_porosity_histogram(
        pore, size, wrap=wrap, stride=settings.mu_stride, max_bins=settings.max_bins, record_stride=lam_stride
    )
    bits = percolation_bits(
        pore,
        size,
        grid.origins(lam_stride),
        mu.records,
        connectivity=settings.connectivity,
        directions=settings.directions,
    )
    n_bins = mu.counts.size
    bins = bins_of(mu.records, mu.k_max, n_bins)
    lam_cells = np.bincount(bins, minlength=n_bins).astype(np.int64)
    lam_perc = np.stack(
        [
            np.bincount(bins, weights=(bits & _DIRECTION_BITS[d]) > 0, minlength=n_bins)
            for d in settings.directions
        ],
        axis=1,
    ).astype(np.int64)
    surface = None
    if settings.surface:
        surface = local_surface_histogram(
            pore, size, wrap=wrap, stride=settings.mu_stride, max_bins=settings.surface_bins
        )
    return _PerSize(
        size, mu, lam_cells, lam_perc, lam_stride, int(bins.size), surface, grid.describe(settings.mu_stride)
    )


def _pad(rows: list[np.ndarray], fill) -> np.ndarray:
    width = max(r.shape[0] for r in rows)
    out = np.full(
        (len(rows), width) + rows[0].shape[1:], fill, dtype=np.result_type(rows[0].dtype, type(fill))
    )
    for i, r in enumerate(rows):
        out[i, : r.shape[0]] = r
    return out


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """num/den, NaN where den == 0 (an empty bin has no fraction)."""
    num = np.asarray(num, np.float64)
    den = np.broadcast_to(np.asarray(den, np.float64), num.shape)
    return np.divide(num, den, out=np.full(num.shape, np.nan), where=den > 0)


def characteristic_length(sizes: Sequence[int], n_phi0: Sequence[int], n_phi1: Sequence[int]) -> int:
    """L* of thesis eq. 4.6.4: the smallest L with μ(0, L) = μ(1, L) = 0; 0 if no given L qualifies."""
    for size, a, b in sorted(zip(sizes, n_phi0, n_phi1)):
        if a == 0 and b == 0:
            return int(size)
    return 0


def local_porosity_analysis(
    pore,
    *,
    voxel_um: float = 1.0,
    periodic: Sequence[bool] = (False, False, False),
    settings: Settings | None = None,
    skip_too_large: bool = False,
    progress=None,
) -> xr.Dataset:
    """μ(φ, L), μ(S_V, L), λ_α(φ, L) and p_α(L) of a binary volume for every cell size of ``settings``.

    Parameters
    ----------
    pore : (nx, ny, nz) uint8 or bool ndarray
        1 = pore.
    voxel_um : float
        Edge of the (cubic) voxels in µm.
    periodic : 3 bools
        Whether the sample is periodic along x, y, z (cells wrap there with placement auto).
    settings : Settings, optional
        The ``lpt:`` scene section; defaults apply when omitted.
    skip_too_large : bool
        Leave out cell sizes larger than the sample (stated in the attrs) instead of refusing them.
    progress : Progress, optional
        Receives one update per cell size.

    Returns
    -------
    xarray.Dataset
        Dimensions ``L`` (cell sizes), ``bin`` (porosity bins of each L; ``phi`` is NaN past a size's own bins),
        ``alpha`` (percolation directions) and ``sv_bin``; every fraction comes with the cell counts behind it.
        See the variables' ``description`` attributes.
    """
    settings = settings or Settings()
    pore = _as_pore(pore)
    return analysis_of(
        pore.shape,
        int(pore.sum(dtype=np.int64)),
        lambda size, wrap: _one_size(pore, size, wrap, settings),
        voxel_um=voxel_um,
        periodic=periodic,
        settings=settings,
        skip_too_large=skip_too_large,
        progress=progress,
    )


def analysis_of(
    shape: Sequence[int],
    n_pore: int,
    one_size,
    *,
    voxel_um: float,
    periodic: Sequence[bool],
    settings: Settings,
    skip_too_large: bool = False,
    progress=None,
) -> xr.Dataset:
    """The Dataset of :func:`local_porosity_analysis` from ``one_size(size, wrap)`` -> the parts of one cell size.

    One driver for the in-memory volume and the chunked one (:mod:`porepipe.lpt._chunked`): the cell sizes, the
    cells' wrap and the assembly are the same; only how one size is measured differs.
    """
    if not np.isfinite(voxel_um) or voxel_um <= 0:
        raise PorepipeError(f"voxel_um must be a positive number, got {voxel_um}")
    wrap = tuple(bool(p) and settings.placement is Placement.auto for p in periodic)
    sizes, mapping = cell_sizes(settings, voxel_um, shape)
    skipped = [s for s in sizes if s > min(shape)]
    if skipped and skip_too_large:
        sizes = [s for s in sizes if s <= min(shape)]
    if not sizes:
        raise PorepipeError(
            f"no lpt cell size fits the sample of shape {tuple(shape)} (sizes {skipped} voxels)"
        )
    per = []
    for i, size in enumerate(sizes):
        per.append(one_size(size, wrap))
        if progress is not None:
            progress.update(i + 1, f"L = {size}")
    volume = (tuple(int(n) for n in shape), int(n_pore))
    return _dataset(
        per, volume, voxel_um, periodic, wrap, settings, mapping, skipped if skip_too_large else []
    )


def _dataset(
    per: list[_PerSize],
    volume: tuple[tuple[int, int, int], int],
    voxel_um: float,
    periodic,
    wrap,
    settings: Settings,
    mapping: dict,
    skipped: list[int],
) -> xr.Dataset:
    shape, n_pore = volume
    sizes = np.array([p.size for p in per], np.int64)
    vol = sizes.astype(np.float64) ** 3
    alphas = [d.value for d in settings.directions]
    cells = _pad([p.mu.counts for p in per], 0)
    n_cells = cells.sum(axis=1)
    k_lo = _pad([p.mu.k_lo.astype(np.float64) for p in per], np.nan)
    k_hi = _pad([p.mu.k_hi.astype(np.float64) for p in per], np.nan)
    k_sum = _pad([p.mu.k_sum for p in per], 0)
    phi_mean = k_sum.sum(axis=1) / (n_cells * vol)
    phi_var = np.array([p.mu.k_sq_sum for p in per]) / (n_cells * vol**2) - phi_mean**2
    lam_cells = _pad([p.lam_cells for p in per], 0)
    lam_perc = _pad([p.lam_perc for p in per], 0)
    lam_total = np.array([p.lam_total for p in per], np.int64)
    perc_total = lam_perc.sum(axis=1)
    n_phi0 = np.array([p.mu.counts[0] for p in per], np.int64)
    n_phi1 = np.array([p.mu.counts[-1] for p in per], np.int64)
    L_star = characteristic_length(sizes, n_phi0, n_phi1)
    dims_b, dims_ba = ("L", "bin"), ("L", "bin", "alpha")
    ds = xr.Dataset(
        {
            "phi": (
                dims_b,
                0.5 * (k_lo + k_hi) / vol[:, None],
                {
                    "description": "local porosity of the bin (centre; exact k/L^3 for exact bins); NaN = no bin"
                },
            ),
            "phi_lo": (dims_b, k_lo / vol[:, None], {"description": "smallest porosity k/L^3 in the bin"}),
            "phi_hi": (dims_b, k_hi / vol[:, None], {"description": "largest porosity k/L^3 in the bin"}),
            "cells": (dims_b, cells, {"description": "cells (placement for mu) with porosity in the bin"}),
            "pore_voxels": (dims_b, k_sum, {"description": "pore voxels summed over the cells of the bin"}),
            "mu": (
                dims_b,
                cells / n_cells[:, None],
                {"description": "local porosity distribution mu(phi, L) as probability per bin (sums to 1)"},
            ),
            "mu_density": (
                dims_b,
                _ratio(cells / n_cells[:, None], (k_hi - k_lo + 1) / vol[:, None]),
                {
                    "description": "mu as a density in phi: probability / bin width (bin width = number of "
                    "porosity values in the bin / L^3); NaN = no bin"
                },
            ),
            "cells_total": ("L", n_cells, {"description": "cells behind mu"}),
            "cells_phi0": (
                "L",
                n_phi0,
                {"description": "cells with phi = 0 (all matrix): mu(0, L) * cells_total"},
            ),
            "cells_phi1": (
                "L",
                n_phi1,
                {"description": "cells with phi = 1 (all pore): mu(1, L) * cells_total"},
            ),
            "phi_mean": (
                "L",
                phi_mean,
                {"description": "mean local porosity sum_phi phi mu(phi, L) (exact)"},
            ),
            "phi_var": ("L", phi_var, {"description": "variance of the local porosity"}),
            "exact": (
                "L",
                np.array([p.mu.exact for p in per], np.int8),
                {"description": "1 = one bin per porosity k/L^3; 0 = k = 1..L^3-1 binned"},
            ),
            "lambda_cells": (dims_b, lam_cells, {"description": "cells (percolation placement) in the bin"}),
            "percolating": (
                dims_ba,
                lam_perc,
                {"description": "of lambda_cells, those percolating in alpha"},
            ),
            "lambda": (
                dims_ba,
                _ratio(lam_perc, lam_cells[:, :, None]),
                {
                    "description": "local percolation probability lambda_alpha(phi, L) = percolating / "
                    "lambda_cells; NaN where the bin has no cell"
                },
            ),
            "lambda_cells_total": ("L", lam_total, {"description": "cells behind lambda and p"}),
            "percolating_total": (
                ("L", "alpha"),
                perc_total,
                {"description": "percolating cells per direction"},
            ),
            "p": (
                ("L", "alpha"),
                perc_total / lam_total[:, None],
                {
                    "description": "fraction of percolating cells p_alpha(L) = sum_phi lambda_alpha mu over the "
                    "percolation cells (eq. 4.6.6)"
                },
            ),
            "lambda_stride": (
                "L",
                np.array([p.lam_stride for p in per], np.int64),
                {"description": "voxels between percolation-cell origins"},
            ),
            "placement": (
                "L",
                np.array([p.placement for p in per], dtype=object),
                {"description": "where the mu cells were placed"},
            ),
        },
        coords={
            "L": ("L", sizes, {"units": "voxels", "description": "cell edge"}),
            "L_um": ("L", sizes * float(voxel_um), {"units": "um", "description": "cell edge"}),
            "bin": ("bin", np.arange(cells.shape[1], dtype=np.int64)),
            "alpha": (
                "alpha",
                np.array(alphas, dtype=object),
                {"description": "x, y, z; 3 = all three; c = at least one (thesis Table 4.1)"},
            ),
        },
        attrs={
            "voxel_um": float(voxel_um),
            "shape": np.array(shape, np.int64),
            "periodic": np.array([int(bool(p)) for p in periodic], np.int8),
            "wrap": np.array([int(w) for w in wrap], np.int8),
            "placement_mode": settings.placement.value,
            "mu_stride": int(settings.mu_stride),
            "connectivity": int(settings.connectivity.value),
            "phi_bar": float(n_pore / np.prod(shape, dtype=np.float64)),
            "pore_voxels": int(n_pore),
            "L_star": int(L_star),
            "L_star_um": float(L_star * voxel_um) if L_star else float("nan"),
            "L_star_note": "smallest computed L with mu(0,L) = mu(1,L) = 0 (eq. 4.6.4); L_star = 0 and L_star_um = "
            "NaN: none of the computed L qualifies",
            "cell_um_to_voxels": str(mapping) if mapping else "",
            "skipped_cell_voxels": np.array(skipped, np.int64),
            "settings": settings.model_dump_json(),
        },
    )
    ds = ds.set_coords(["phi", "phi_lo", "phi_hi"])  # so that e.g. ds.mu.sel(L=8).plot(x="phi") works
    if settings.surface:
        ds = ds.merge(
            _surface_dataset(per, sizes, voxel_um).set_coords(["sv_per_um", "sv_lo_per_um", "sv_hi_per_um"])
        )
        ds.attrs["surface_method"] = SURFACE_METHOD
    return ds


def _surface_dataset(per: list[_PerSize], sizes: np.ndarray, voxel_um: float) -> xr.Dataset:
    scale = (2.0 / 3.0) / (sizes.astype(np.float64) ** 3 * voxel_um)  # S_V per face, 1/µm
    cells = _pad([p.surface.counts for p in per], 0)
    k_lo = _pad([p.surface.k_lo.astype(np.float64) for p in per], np.nan)
    k_hi = _pad([p.surface.k_hi.astype(np.float64) for p in per], np.nan)
    k_sum = _pad([p.surface.k_sum for p in per], 0)
    n = cells.sum(axis=1)
    dims = ("L", "sv_bin")
    return xr.Dataset(
        {
            "sv_per_um": (
                dims,
                0.5 * (k_lo + k_hi) * scale[:, None],
                {"units": "1/um", "description": "local S_V of the bin (centre); NaN = no bin"},
            ),
            "sv_lo_per_um": (dims, k_lo * scale[:, None], {"units": "1/um"}),
            "sv_hi_per_um": (dims, k_hi * scale[:, None], {"units": "1/um"}),
            "sv_cells": (dims, cells, {"description": "cells with local S_V in the bin"}),
            "mu_sv": (
                dims,
                cells / n[:, None],
                {"description": "local S_V distribution mu(S_V, L), per bin"},
            ),
            "sv_mean_per_um": (
                "L",
                k_sum.sum(axis=1) * scale / n,
                {"units": "1/um", "description": "mean local S_V"},
            ),
        },
        coords={"sv_bin": ("sv_bin", np.arange(cells.shape[1], dtype=np.int64))},
    )
