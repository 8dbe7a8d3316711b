"""The content of a result file, for comparing two runs: every dataset's bytes and every attribute, costs aside."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

#: attributes (and datasets) that differ between two runs by nature (cost and provenance of the run, not its result)
#: (the sweep gathers the costs of every result: Snakemake's benchmark and the upstream jobs'; LBM its MLUPS)
TIMING_ATTRS = {
    "wall_s",
    "cpu_s",
    "startup_s",
    "peak_mb",
    "created",
    "threads",
    "porepipe_version",
    "source",
} | {
    "bench_s",
    "bench_cpu_s",
    "bench_max_rss_mb",
    "upstream_wall_s",
    "upstream_cpu_s",
    "mlups",
}
#: netCDF dimension-scale links: HDF5 object addresses, which depend on the write order, not on the result
ADDRESS_ATTRS = {"REFERENCE_LIST", "DIMENSION_LIST"}


def _bytes(value) -> bytes:
    """The exact content of an array or attribute (strings by value: an object array's bytes are pointers)."""
    arr = np.asarray(value)
    return repr(arr.tolist()).encode() if arr.dtype.kind == "O" else arr.dtype.str.encode() + arr.tobytes()


def h5_content(path: Path) -> dict:
    """Every dataset's bytes and every attribute (timings aside) of an HDF5 file, by name."""
    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            skip = TIMING_ATTRS | ADDRESS_ATTRS
            out[name + "@attrs"] = {k: _bytes(v) for k, v in obj.attrs.items() if k not in skip}
            if isinstance(obj, h5py.Dataset) and name.rsplit("/", 1)[-1] not in TIMING_ATTRS:
                out[name] = _bytes(obj[...])  # pack's history/wall_s is a timing too

        visit("/", f)
        f.visititems(visit)
    return out


def h5_results(cwd: Path) -> dict[str, Path]:
    """Every HDF5 result under ``cwd/results``, by its path relative to ``cwd``."""
    return {str(p.relative_to(cwd)): p for p in (cwd / "results").rglob("*.h5")}


def differences(want: Path, got: Path) -> list[str]:
    """Names of the datasets and attribute sets of ``got`` that differ from (or are missing in) ``want``."""
    a, b = h5_content(want), h5_content(got)
    return sorted(set(a) ^ set(b)) + [key for key in a if key in b and a[key] != b[key]]
