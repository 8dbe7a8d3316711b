"""``porepipe decorate`` (grains.h5) and ``porepipe voxelize-grains`` (grey volume of the grain model).

Argparse only; the work is in ``_run``.
"""

from __future__ import annotations

from porepipe._shared.overrides import add_threads_option


def _main_decorate(args) -> int:
    from porepipe.decorate._run import run
    from porepipe.scene import load_scene

    run(load_scene(args.scene), args.scene, args.out, packing_path=args.packing, threads=args.threads)
    return 0


def _main_voxelize(args) -> int:
    from porepipe.decorate._run import run_grey
    from porepipe.scene import load_scene

    run_grey(load_scene(args.scene), args.grains, args.a, args.out, threads=args.threads)
    return 0


def register(subparsers) -> None:
    """Add ``decorate`` and ``voxelize-grains`` to the ``porepipe`` command."""
    p = subparsers.add_parser(
        "decorate", help="give every sphere a grain type, rotation and scale (grains.h5)"
    )
    p.add_argument("scene", help="scene YAML with a `decoration:` section")
    p.add_argument("-o", "--out", required=True, help="output grains.h5")
    p.add_argument("--packing", help="packing.h5 from the pack stage (when spheres.pack is set)")
    add_threads_option(p)
    p.set_defaults(func=_main_decorate)
    p = subparsers.add_parser(
        "voxelize-grains", help="grey volume (0..216) of the decorated grains at one voxel size"
    )
    p.add_argument("scene", help="scene YAML")
    p.add_argument("--grains", required=True, help="grains.h5 from `porepipe decorate`")
    p.add_argument("--a", type=float, required=True, help="voxel size in µm")
    p.add_argument("-o", "--out", required=True, help="output grey_a{a}.h5")
    add_threads_option(p)
    p.set_defaults(func=_main_voxelize)
