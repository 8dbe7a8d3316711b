"""``porepipe lpt``: local porosity theory of a binary volume (μ(φ, L), μ(S_V, L), λ_α(φ, L), p_α(L))."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.progress import Progress
from porepipe._shared.store import ResultWriter, hash_of, open_volume, read_attrs
from porepipe.lpt._api import cell_sizes, local_porosity_analysis
from porepipe.lpt._plot import plot_lpt
from porepipe.lpt._settings import Connectivity, Direction, Placement, Settings


def cubic_voxel_um(voxel_um, path) -> float:
    """The voxel edge of a volume; anisotropic voxels are refused (LPT cells are cubes of L voxels)."""
    values = np.atleast_1d(np.asarray(voxel_um, dtype=np.float64))
    if values.size not in (1, 3) or not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise PorepipeError(f"{path}: voxel_um must be one positive number or three, got {voxel_um!r}")
    if not np.allclose(values, values[0], rtol=1e-9, atol=0):
        raise PorepipeError(
            f"{path}: anisotropic voxels {values.tolist()} µm are not supported by lpt: its cells are "
            "cubes of L voxels, which would not be cubes in space; resample to cubic voxels first"
        )
    return float(values[0])


def read_binary(
    path, subsample_um: float | None = None
) -> tuple[np.ndarray, float, tuple[bool, bool, bool], str]:
    """Pore volume, voxel edge, periodicity and a note; optionally only the corner cube of edge ``subsample_um``.

    A file written by ``porepipe subsample`` (root attribute ``sample_um``) is itself a corner sub-sample.
    """
    root = read_attrs(path)
    with open_volume(path, "pore") as dset:
        attrs = dict(dset.attrs)
        voxel_um = cubic_voxel_um(attrs.get("voxel_um"), path)
        periodic = tuple(bool(p) for p in np.broadcast_to(np.asarray(attrs.get("periodic", 0)), (3,)))
        if subsample_um is None:
            note = "whole sample"
            if "sample_um" in root:
                note = f"sub-sample: corner cube of {float(root['sample_um']):g} µm edge from {root.get('source', '?')}"
            return dset[...], voxel_um, periodic, note
        edge = int(np.floor(subsample_um / voxel_um + 0.5))
        if not 1 <= edge <= min(dset.shape):
            raise PorepipeError(
                f"--subsample-um {subsample_um} is {edge} voxels of {voxel_um} µm; allowed 1 .. "
                f"{min(dset.shape)} voxels for the volume of shape {dset.shape} in {path}"
            )
        note = (
            f"sub-sample: corner cube [0, {edge})^3 voxels = {edge * voxel_um:g} µm edge, not periodic "
            "(the cut breaks the periodicity)"
        )
        return dset[:edge, :edge, :edge], voxel_um, (False, False, False), note


def lpt_file(
    binary_path,
    out,
    settings: Settings,
    *,
    subsample_um: float | None = None,
    threads: int | None = None,
    plots: bool | None = None,
):
    """Write ``lpt_a{a}.h5`` (the Dataset of :func:`local_porosity_analysis` at the root) and its PNG plots."""
    threads = set_threads(threads)
    src = read_attrs(binary_path)
    pore, voxel_um, periodic, note = read_binary(binary_path, subsample_um)
    is_part = (
        subsample_um is not None or "sample_um" in src
    )  # a sub-sample leaves out the cells that do not fit
    sizes, _ = cell_sizes(settings, voxel_um, pore.shape)
    progress = Progress("lpt", total=sum(s <= min(pore.shape) for s in sizes))
    ds = local_porosity_analysis(
        pore,
        voxel_um=voxel_um,
        periodic=periodic,
        settings=settings,
        skip_too_large=is_part,
        progress=progress,
    )
    ds.attrs["sample"] = note
    part = {
        "binary": src.get("scene_hash", ""),
        "lpt": settings.model_dump(mode="json"),
        "subsample_um": subsample_um,
    }
    with ResultWriter(
        out, stage="lpt", scene=src.get("scene", ""), scene_hash=hash_of(part), threads=threads
    ) as w:
        w.write_table(ds)
        w.attrs.update(
            voxel_um=voxel_um, phi_bar=ds.attrs["phi_bar"], L_star_um=ds.attrs["L_star_um"], sample=note
        )
    if settings.plots if plots is None else plots:
        out = Path(out)
        plot_lpt(ds, out.with_name(out.name.removesuffix(".h5")))
    return ds


def settings_from_args(args) -> Settings:
    """Scene ``lpt:`` section (if --scene) with the options given on the command line on top."""
    base = {}
    if args.scene:
        from porepipe.scene import load_scene

        base = load_scene(args.scene).lpt.model_dump()
    given = {
        key: getattr(args, key)
        for key in (
            "cell_um",
            "cell_voxels",
            "placement",
            "mu_stride",
            "lambda_stride",
            "lambda_max_cells",
            "connectivity",
            "directions",
            "max_bins",
            "surface",
            "surface_bins",
            "plots",
        )
        if getattr(args, key) is not None
    }
    if "cell_um" in given:
        base["cell_voxels"] = []
    if "cell_voxels" in given:
        base["cell_um"] = []
    try:
        return Settings(**{**base, **given})
    except ValueError as err:
        raise PorepipeError(f"lpt options: {err}") from err


def main(args) -> int:
    ds = lpt_file(
        args.binary, args.out, settings_from_args(args), subsample_um=args.subsample_um, threads=args.threads
    )
    print(
        f"lpt: phi_bar = {ds.attrs['phi_bar']:.6f}, L = {ds.L.values.tolist()} voxels, "
        f"L* = {ds.attrs['L_star']} voxels; written {args.out}"
    )
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "lpt", help="local porosity theory: mu(phi,L), mu(S_V,L), lambda_alpha(phi,L), p(L)"
    )
    p.add_argument("binary", help="binary_a{a}.h5 (volume 'pore', 1 = pore)")
    p.add_argument("-o", "--out", required=True, help="output lpt_a{a}.h5 (PNG plots beside it)")
    p.add_argument("--scene", help="scene YAML whose lpt: section gives the defaults")
    p.add_argument("--cell-um", type=float, nargs="+", help="cell edges L in µm (rounded to whole voxels)")
    p.add_argument("--cell-voxels", type=int, nargs="+", help="cell edges L in voxels")
    p.add_argument("--placement", choices=[m.value for m in Placement])
    p.add_argument(
        "--mu-stride", type=int, help="voxels between cell origins for mu and S_V (1 = all positions)"
    )
    p.add_argument("--lambda-stride", type=int, help="voxels between cell origins for lambda")
    p.add_argument(
        "--lambda-max-cells", type=int, help="cap on percolation cells per L without --lambda-stride"
    )
    p.add_argument("--connectivity", type=int, choices=[c.value for c in Connectivity])
    p.add_argument("--directions", nargs="+", choices=[d.value for d in Direction])
    p.add_argument("--max-bins", type=int, help="porosity bins per L (exact while L^3 + 1 <= max-bins)")
    p.add_argument(
        "--surface", action=argparse.BooleanOptionalAction, default=None, help="local S_V distribution"
    )
    p.add_argument("--surface-bins", type=int)
    p.add_argument("--plots", action=argparse.BooleanOptionalAction, default=None, help="write PNG plots")
    p.add_argument(
        "--subsample-um",
        type=float,
        help="analyse only the corner cube of this edge (cells larger than "
        "it are left out; the workflow's sample-size sweep uses `porepipe subsample` files instead)",
    )
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=main)
