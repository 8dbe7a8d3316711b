"""Gather the result files of a scene into one Dataset: quantity × resolution × sample size, with each run's cost.

Quantities are read generically from each file's root xarray table, so a new engine joins without code changes:
- a file with an ``a_um`` dimension (e.g. ``estimate.h5``): every float variable over ``a_um`` alone;
- a per-resolution file (``*_a{a}[_L{L}[_k{i}]|_s{s}][_tag].h5``): every 0-d float variable, every float variable over
  one short labelled dimension (e.g. ``phase``: ``minkowski.S_V[pore]``), and the known scalar attributes below.
  Sub-samples ``_k{i}`` of one edge (sweep.subsamples = 8 or 64) are replicas: ``value`` is their mean and
  ``rev_spread`` their standard deviation (the REV error bar of Zauner 2020 Fig. 7.8).
- a variable ``X_err`` beside ``X`` in a per-resolution file is X's 1-σ statistical error (``stat_err``), not a
  quantity of its own (the diffusion stage's W, D_eff, Ψ, τ carry one).
Integer variables (counts, flags) and long curves are not quantities.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import h5py
import numpy as np
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import VOLUME_GROUP, read_attrs, read_table, volume_names
from porepipe._shared.units import DIMENSIONLESS, MEBIBYTE, SECOND, units_of

#: scalar Dataset attributes that are measured quantities (not settings), with their units
KNOWN_ATTRS = ("phi_bar", "L_star_um")
_ATTR_UNITS = {"phi_bar": DIMENSIONLESS, "L_star_um": "µm"}
#: a labelled dimension at most this long is unrolled into one quantity per label
MAX_LABELS = 8
#: sample_um of a run on the whole volume
FULL = np.inf
COST_KEYS = ("wall_s", "cpu_s", "startup_s", "peak_mb", "threads")
BENCH_KEYS = {"s": "bench_s", "cpu_time": "bench_cpu_s", "max_rss": "bench_max_rss_mb"}

_NAME = re.compile(r"^(?P<prefix>.+?)_a(?P<a>[0-9]+(?:\.[0-9]+)?)(?:_(?P<rest>.+))?$")
_SAMPLE = re.compile(r"^(?:L|s)(?P<edge>[0-9]+(?:\.[0-9]+)?)$")
_REPLICA = re.compile(r"^k[0-9]+$")


def parse_name(stem: str) -> tuple[str, float | None, float, str]:
    """Split a result/benchmark file stem into (prefix, a, sample_um, tag).

    >>> parse_name("perm_a0.5_x")
    ('perm', 0.5, inf, 'x')
    >>> parse_name("lpt_a2_s50")
    ('lpt', 2.0, 50.0, '')
    """
    m = _NAME.match(stem)
    if m is None:
        return stem, None, FULL, ""
    sample, tags = FULL, []
    for token in (m["rest"] or "").split("_"):
        s = _SAMPLE.match(token)
        if s is not None and sample == FULL:
            sample = float(s["edge"])
        elif sample != FULL and _REPLICA.match(token):
            continue  # sub-sample k of this edge: a replica, gathered into mean and spread
        elif token:
            tags.append(token)
    return m["prefix"], float(m["a"]), sample, "_".join(tags)


def _is_float(var: xr.DataArray) -> bool:
    return np.issubdtype(var.dtype, np.floating)


def _labelled(ds: xr.Dataset, dim: str) -> list[str] | None:
    if dim not in ds.coords or ds.sizes[dim] > MAX_LABELS or ds[dim].dtype.kind not in "OUS":
        return None
    return [str(v) for v in ds[dim].values]


def file_quantities(ds: xr.Dataset, group: str) -> dict[str, float]:
    """Scalar quantities of one per-resolution result table, named ``group.var`` or ``group.var[label]``."""
    out = {}
    for name, var in ds.data_vars.items():
        if not _is_float(var):
            continue
        if var.ndim == 0:
            out[f"{group}.{name}"] = float(var)
        elif var.ndim == 1 and (labels := _labelled(ds, var.dims[0])) is not None:
            out.update({f"{group}.{name}[{lab}]": float(v) for lab, v in zip(labels, var.values)})
    for key in KNOWN_ATTRS:
        value = ds.attrs.get(key)
        if isinstance(value, (int, float, np.number)) and not isinstance(value, bool):
            out[f"{group}.{key}"] = float(value)
    return out


def _var_units(name: str, var: xr.DataArray) -> str:
    units, _ = units_of(name, var.dtype, var.attrs.get("units"))
    return units or ""


def quantity_units(ds: xr.Dataset, group: str) -> dict[str, str]:
    """Units of the quantities :func:`file_quantities` and :func:`per_a_quantities` find ('' where unstated)."""
    out = {}
    for name, var in ds.data_vars.items():
        if not _is_float(var):
            continue
        units = _var_units(str(name), var)
        if var.ndim == 0 or var.dims == ("a_um",):
            out[f"{group}.{name}"] = units
        elif var.ndim == 1 and (labels := _labelled(ds, var.dims[0])) is not None:
            out.update({f"{group}.{name}[{lab}]": units for lab in labels})
    out.update({f"{group}.{key}": _ATTR_UNITS[key] for key in KNOWN_ATTRS if key in ds.attrs})
    return out


def per_a_quantities(ds: xr.Dataset, group: str) -> dict[str, dict[float, float]]:
    """Quantities of a table over all resolutions (dimension ``a_um``): name -> {a: value}."""
    a = ds["a_um"].values.astype(np.float64)
    return {
        f"{group}.{name}": dict(zip(a.tolist(), var.values.astype(np.float64).tolist()))
        for name, var in ds.data_vars.items()
        if var.dims == ("a_um",) and _is_float(var)
    }


def read_benchmarks(cost_dir) -> dict[tuple, dict[str, float]]:
    """Snakemake benchmark TSVs of a scene: (rule, a, sample_um, tag) -> {bench_s, bench_cpu_s, bench_max_rss_mb}."""
    out = {}
    if cost_dir is None or not Path(cost_dir).is_dir():
        return out
    for path in sorted(Path(cost_dir).glob("*.tsv")):
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh, delimiter="\t"))
        if not rows:
            continue
        rec = {new: _float(rows[-1].get(old)) for old, new in BENCH_KEYS.items()}
        out[parse_name(path.stem)] = rec
    return out


def _float(text) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        return float("nan")


def _cost(attrs: dict) -> dict[str, float]:
    return {k: _float(attrs.get(k)) for k in COST_KEYS}


def _volume_record(path) -> tuple[float, float, dict, int]:
    """(a, sample_um, cost, voxels) of a grey/binary volume file."""
    attrs = read_attrs(path)
    _, a, sample, _ = parse_name(Path(path).stem)
    with h5py.File(path, "r") as f:
        group = f.get(VOLUME_GROUP)
        names = volume_names(group) if group is not None else []
        if not names:
            raise PorepipeError(
                f"{path} holds no volume; pass grey_a{{a}}.h5 / binary_a{{a}}.h5 files as volumes"
            )
        dset = group[names[0]]
        voxels = int(np.prod(dset.shape, dtype=np.int64))
        a = float(dset.attrs.get("voxel_um", a if a is not None else np.nan))
    return a, sample, _cost(attrs), voxels


def split_errors(quantities: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """Separate statistical error bars from values: ``g.X_err`` (``g.X_err[lab]``, ``g.X_err_m2_s``) is the 1-σ
    error of ``g.X`` (``g.X[lab]``, ``g.X_m2_s``) when that exists (e.g. the diffusion stage's W_err, D_eff_err_m2_s).

    Returns
    -------
    values : dict
        The quantities without their error bars.
    errors : dict
        Quantity -> its statistical error.
    """
    values, errors = {}, {}
    for name, value in quantities.items():
        base = re.sub(r"_err(_m2_s)?(\[[^\]]*\])?$", r"\1\2", name)
        if base != name and base in quantities:
            errors[base] = value
        else:
            values[name] = value
    return values, errors


class _Table:
    """Accumulates records (quantity, a, sample) -> value, statistical error and cost, then builds the Dataset."""

    def __init__(self):
        self.values: dict[tuple, list[float]] = {}
        self.errors: dict[tuple, list[float]] = {}
        self.cost: dict[tuple, dict] = {}
        self.source: dict[str, str] = {}
        self.units: dict[str, str] = {}

    def add(self, quantity, a, sample, value, cost, source, units="", stat_err=float("nan")):
        """One value; sub-sample replicas of the same (quantity, a, sample) accumulate."""
        self.values.setdefault((quantity, a, sample), []).append(value)
        self.errors.setdefault((quantity, a, sample), []).append(stat_err)
        self.cost.setdefault((quantity, a, sample), cost)
        self.source.setdefault(quantity, source)
        self.units.setdefault(quantity, units)


def _add_result(table: _Table, path: Path, bench: dict) -> None:
    attrs = read_attrs(path)
    stage = str(attrs.get("stage", path.parent.name))
    try:
        ds = read_table(path)
    except (OSError, ValueError) as err:
        raise PorepipeError(f"{path}: no readable root table ({err})") from err
    _, a, sample, tag = parse_name(path.stem)
    group = stage + (f"_{tag}" if tag else "")
    sample_key = "" if sample == FULL else f"s{sample:g}"
    rec = bench.get((stage, a, sample, tag)) or bench.get(
        (stage, a, FULL, "_".join(filter(None, [sample_key, tag])))
    )
    cost = {**_cost(attrs), **(rec or dict.fromkeys(BENCH_KEYS.values(), np.nan))}
    units = quantity_units(ds, group)
    if "a_um" in ds.dims:
        for name, by_a in per_a_quantities(ds, group).items():
            for a_i, value in by_a.items():
                table.add(name, a_i, sample, value, cost, path.name, units.get(name, ""))
        return
    if a is None:
        a = _float(attrs.get("voxel_um"))
        if not np.isfinite(a):
            raise PorepipeError(
                f"{path}: resolution unknown (no _a{{a}} in the name and no voxel_um attribute)"
            )
    values, errors = split_errors(file_quantities(ds, group))
    for name, value in values.items():
        table.add(
            name, a, sample, value, cost, path.name, units.get(name, ""), errors.get(name, float("nan"))
        )


def gather(result_paths, volume_paths=(), cost_dir=None) -> xr.Dataset:
    """Build the sweep table from result files (and grey/binary volumes for upstream cost and voxel counts).

    Returns
    -------
    xarray.Dataset
        ``value``, ``wall_s``, ``cpu_s``, ``peak_mb``, ``threads``, ``bench_s``, ``bench_cpu_s``,
        ``bench_max_rss_mb`` over (quantity, a_um, sample_um); ``upstream_wall_s``, ``upstream_cpu_s`` and
        ``voxels`` over (a_um, sample_um): the cost of making the volume the run measured. ``sample_um`` = inf is
        the whole volume.
    """
    bench = read_benchmarks(cost_dir)
    table = _Table()
    for path in map(Path, result_paths):
        _add_result(table, path, bench)
    if not table.values:
        raise PorepipeError(
            f"the sweep found no scalar quantity in the result files {[str(p) for p in result_paths]}"
        )
    upstream: dict[tuple, list] = {}
    for path in volume_paths:
        a, sample, cost, voxels = _volume_record(path)
        up = upstream.setdefault((a, sample), [0.0, 0.0, 0])
        up[0] += cost["wall_s"]
        up[1] += cost["cpu_s"]
        up[2] = max(up[2], voxels)
    for (a, sample), up in upstream.items():
        if (
            sample != FULL and (a, FULL) in upstream
        ):  # a sub-sample also cost the whole volume it was cut from
            up[0] += upstream[(a, FULL)][0]
            up[1] += upstream[(a, FULL)][1]
    return _to_dataset(table, upstream)


def _to_dataset(table: _Table, upstream: dict) -> xr.Dataset:
    quantities = sorted({k[0] for k in table.values})
    a_um = sorted({k[1] for k in table.values} | {k[0] for k in upstream}, reverse=True)
    samples = sorted({k[2] for k in table.values} | {k[1] for k in upstream}, reverse=True)
    shape = (len(quantities), len(a_um), len(samples))
    qi, ai, si = ({v: i for i, v in enumerate(vals)} for vals in (quantities, a_um, samples))
    cost_names = list(COST_KEYS) + list(BENCH_KEYS.values())
    arrays = {name: np.full(shape, np.nan) for name in ["value", "stat_err", "rev_spread", *cost_names]}
    count = np.zeros(shape, dtype=np.int64)
    for key, values in table.values.items():
        idx = (qi[key[0]], ai[key[1]], si[key[2]])
        arrays["value"][idx] = np.mean(values)
        errs = np.asarray(table.errors[key], dtype=np.float64)
        arrays["stat_err"][idx] = np.sqrt(np.sum(errs**2)) / errs.size  # error of the mean of replicas
        arrays["rev_spread"][idx] = np.std(values, ddof=1) if len(values) > 1 else np.nan
        count[idx] = len(values)
        for name in cost_names:
            arrays[name][idx] = table.cost[key].get(name, np.nan)
    up = np.full((3, len(a_um), len(samples)), np.nan)
    for (a, sample), rec in upstream.items():
        up[:, ai[a], si[sample]] = rec
    dims = ("quantity", "a_um", "sample_um")
    units = {
        "wall_s": SECOND,
        "cpu_s": SECOND,
        "startup_s": SECOND,
        "peak_mb": MEBIBYTE,
        "bench_s": SECOND,
        "bench_cpu_s": SECOND,
        "bench_max_rss_mb": MEBIBYTE,
    }
    per_quantity = {"units_from": "unit", "description": "in the unit of its quantity (coordinate `unit`)"}
    ds = xr.Dataset(
        {
            name: (dims, arr, {"units": units[name]} if name in units else per_quantity)
            for name, arr in arrays.items()
        },
        coords={
            "quantity": np.array(quantities, dtype=object),
            "unit": (
                "quantity",
                np.array([table.units.get(q, "") for q in quantities], dtype=object),
                {"description": "unit of each quantity (pint spelling; '' = not stated by its result file)"},
            ),
            "a_um": np.array(a_um, dtype=np.float64),
            "sample_um": (
                "sample_um",
                np.array(samples, dtype=np.float64),
                {"description": "edge of the corner sub-sample; inf = the whole volume"},
            ),
        },
    )
    ds["rev_spread"].attrs.update(
        description="standard deviation of value over the sub-samples of one edge (REV error); NaN: one sample"
    )
    ds["stat_err"].attrs.update(
        description="1-sigma statistical error of value from the run itself (e.g. batch means); NaN: none"
    )
    ds["rev_count"] = (
        dims,
        count,
        {"units": DIMENSIONLESS, "description": "sub-samples averaged into value"},
    )
    ds["source"] = ("quantity", np.array([table.source[q] for q in quantities], dtype=object))
    ds["upstream_wall_s"] = (
        ("a_um", "sample_um"),
        up[0],
        {"units": SECOND, "description": "voxelize + segment (+ crop)"},
    )
    ds["upstream_cpu_s"] = (("a_um", "sample_um"), up[1], {"units": SECOND})
    ds["voxels"] = (
        ("a_um", "sample_um"),
        up[2],
        {"units": DIMENSIONLESS, "description": "voxels of the measured volume (NaN: unknown)"},
    )
    ds["a_um"].attrs.update(units="µm", long_name="voxel edge a")
    ds["sample_um"].attrs["units"] = "µm"
    return ds
