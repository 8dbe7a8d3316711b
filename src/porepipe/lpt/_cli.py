"""``porepipe lpt``: local porosity theory of a binary volume (μ(φ, L), μ(S_V, L), λ_α(φ, L), p_α(L)).

Argparse only; the work is in ``_run``.
"""

from __future__ import annotations

import argparse

from porepipe._shared.overrides import (
    add_threads_option,
    given_options,
    merge_settings,
    option_names,
    whole_count,
)
from porepipe.lpt._settings import Connectivity, Direction, Placement, Settings

#: command-line options that override the scene's ``lpt`` section (flag name = settings key)
_OVERRIDES = (
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


def settings_from_args(args) -> tuple[Settings, int | None]:
    """Scene ``lpt:`` section (if --scene) with the options given on the command line on top, and the memory budget."""
    base, budget = None, None
    if args.scene:
        from porepipe.scene import load_scene

        scene = load_scene(args.scene)
        base, budget = scene.lpt, scene.resources.memory_budget_mb
    if getattr(args, "memory_budget_mb", None) is not None:
        budget = args.memory_budget_mb
    given = given_options(args, _OVERRIDES)
    options = option_names(given)  # the options given, not the emptied other cell list below
    if "cell_um" in given:  # cells given one way replace the scene's cells given the other way
        given.setdefault("cell_voxels", [])
    if "cell_voxels" in given:
        given.setdefault("cell_um", [])
    return merge_settings(Settings, base, given, "lpt options", options=options), budget


def main(args) -> int:
    """Run the subcommand; returns the exit code."""
    from porepipe.lpt._run import run

    settings, budget = settings_from_args(args)
    ds = run(
        args.binary,
        args.out,
        settings,
        subsample_um=args.subsample_um,
        threads=args.threads,
        memory_budget_mb=budget,
    )
    print(
        f"lpt: phi_bar = {ds.attrs['phi_bar']:.6f}, L = {ds.L.values.tolist()} voxels, "
        f"L* = {ds.attrs['L_star']} voxels; written {args.out}"
    )
    return 0


def register(subparsers) -> None:
    """Add ``lpt`` to the ``porepipe`` command."""
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
    p.add_argument(
        "--memory-budget-mb",
        type=whole_count("--memory-budget-mb", "the scene's budget, or none"),
        help="a volume larger than this goes box by box (overrides the scene)",
    )
    add_threads_option(p)
    p.set_defaults(func=main)
