"""``porepipe minkowski``: φ, S_V, K_V, T_V, χ of pore and matrix of a binary volume (and optionally of the grey
volume at every threshold), written to ``minkowski_a{a}.h5``. Argparse only; the work is in ``_run``.
"""

from __future__ import annotations

from porepipe._shared.errors import PorepipeError
from porepipe._shared.overrides import add_threads_option, given_options, merge_settings, whole_count
from porepipe.minkowski._settings import Adjacency, Settings


def main(args) -> int:
    """Run the subcommand; returns the exit code."""
    from porepipe.minkowski._run import run

    base, budget = None, None
    if args.scene:
        from porepipe.scene import load_scene

        scene = load_scene(args.scene)
        base, budget = scene.minkowski, scene.resources.memory_budget_mb
    if args.memory_budget_mb is not None:
        budget = args.memory_budget_mb
    settings = merge_settings(
        Settings, base, given_options(args, ("adjacency", "slab_planes")), "minkowski options"
    )
    grey = args.grey if (args.grey or not settings.threshold_functions) else None
    if settings.threshold_functions and not grey:
        raise PorepipeError("minkowski.threshold_functions is on: give the grey volume with --grey GREY.h5")
    table = run(args.binary, args.out, settings, grey, args.threads, budget)
    pore = table.sel(phase="pore")
    print(
        f"φ={float(pore.phi):.6f} S_V={float(pore.S_V):.6g} µm^-1 K_V={float(pore.K_V):.6g} µm^-2 "
        f"T_V={float(pore.T_V):.6g} µm^-3 χ={float(pore.chi):.6g}"
    )
    return 0


def register(subparsers) -> None:
    """Add ``minkowski`` to the ``porepipe`` command."""
    p = subparsers.add_parser("minkowski", help="φ, S_V, K_V, T_V, χ of pore and matrix of a binary volume")
    p.add_argument("binary", help="binary_a{a}.h5 (volume 'pore', 1 = pore)")
    p.add_argument("-o", "--out", required=True, help="output minkowski_a{a}.h5")
    p.add_argument("--scene", help="scene YAML (its minkowski section gives the settings)")
    p.add_argument("--grey", help="grey_a{a}.h5: also the functionals at every threshold g_th (one pass)")
    p.add_argument("--adjacency", choices=[a.value for a in Adjacency], help="overrides the scene")
    p.add_argument("--slab-planes", type=int, help="x planes read at once (overrides the scene)")
    p.add_argument(
        "--memory-budget-mb",
        type=whole_count("--memory-budget-mb", "the scene's budget, or none"),
        help="volumes larger than this go box by box (overrides the scene)",
    )
    add_threads_option(p)
    p.set_defaults(func=main)
