"""``porepipe voxelize``: grey volume of the scene's spheres at one resolution (argparse only; work in ``_run``)."""

from __future__ import annotations

from porepipe._shared.overrides import add_threads_option


def main(args) -> int:
    """Run the subcommand; returns the exit code."""
    from porepipe.scene import load_scene
    from porepipe.voxelize._run import run

    run(load_scene(args.scene), args.a, args.out, packing_path=args.packing, threads=args.threads)
    return 0


def register(subparsers) -> None:
    """Add ``voxelize`` to the ``porepipe`` command."""
    p = subparsers.add_parser(
        "voxelize", help="grey volume (0..216) of the scene's spheres at one voxel size"
    )
    p.add_argument("scene", help="scene YAML")
    p.add_argument("--a", type=float, required=True, help="voxel size in µm")
    p.add_argument("-o", "--out", required=True, help="output grey_a{a}.h5")
    p.add_argument("--packing", help="packing.h5 from the pack stage (when spheres.pack is set)")
    add_threads_option(p)
    p.set_defaults(func=main)
