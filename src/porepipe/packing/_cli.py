"""``porepipe pack``: the scene's DEM packing protocol -> ``packing.h5`` (argparse only; work in ``_run``)."""

from __future__ import annotations

import argparse

from porepipe._shared.overrides import add_threads_option, check_resume_has_checkpoint


def main(args) -> int:
    """Run the subcommand; returns the exit code."""
    from porepipe.packing._run import run

    check_resume_has_checkpoint(args)
    packing = run(
        args.scene,
        args.out,
        xyzr=args.xyzr,
        threads=args.threads,
        checkpoint=args.checkpoint,
        resume=args.resume,
    )
    if not packing.all_converged:
        print(
            f"porepipe pack: warning: not every sphere converged (stage steps {packing.stage_steps}); "
            "see the history in the output file"
        )
    return 0


def register(subparsers) -> None:
    """Add ``pack`` to the ``porepipe`` command."""
    p = subparsers.add_parser(
        "pack", help="DEM packing of overlapping spheres (PackDEM protocol) -> packing.h5"
    )
    p.add_argument("scene", help="scene YAML with a `packing:` section")
    p.add_argument("-o", "--out", required=True, help="output packing.h5")
    p.add_argument("--xyzr", help="also write the spheres as an 'x y z r' text file (µm)")
    p.add_argument(
        "--checkpoint",
        help="checkpoint file: the run's state is saved there every packing.checkpoint_every_s wall seconds "
        "(default 300) and every packing.checkpoint_every steps (default 0: off), whichever comes first, and "
        "deleted when the packing is complete (a run that ends before an interval has passed writes none); "
        "without it nothing is saved",
    )
    p.add_argument(
        "--resume",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="continue from --checkpoint if it exists and was written for the same packing (settings less run "
        "control, box, seed, input files); one written for another, or damaged (its checksums), is discarded with a "
        "message",
    )
    add_threads_option(p)
    p.set_defaults(func=main)
