"""``porepipe export``: a result as a ParaView file (argparse only; the work is in ``_api``)."""

from __future__ import annotations


def main(args) -> int:
    """Run the subcommand; returns the exit code."""
    from porepipe.export._api import export_result

    print(
        export_result(
            args.result,
            args.out,
            gradient_pa_m=args.gradient_pa_m,
            viscosity_pa_s=args.viscosity_pa_s,
            frame=args.frame,
        )
    )
    return 0


def register(subparsers) -> None:
    """Add ``export`` to the ``porepipe`` command."""
    p = subparsers.add_parser(
        "export",
        help="write a result for ParaView (.vti volumes and LBM fields, .vtp packings, grains and granular frames, "
        ".pvd granular time series)",
    )
    p.add_argument(
        "result",
        help="grey/binary volume, packing.h5, grains.h5, granular.h5 or a permeability result with fields",
    )
    p.add_argument(
        "-o",
        "--out",
        required=True,
        help="output file: .vti for volumes and flow, .vtp for the rest; .pvd for every frame of a granular result",
    )
    p.add_argument(
        "--gradient-pa-m",
        type=float,
        default=1.0e4,
        help="LBM fields: applied pressure gradient in Pa/m (default 1e4)",
    )
    p.add_argument(
        "--viscosity-pa-s",
        type=float,
        default=1.0e-3,
        help="LBM fields: fluid viscosity in Pa s (water: 1e-3)",
    )
    p.add_argument(
        "--frame",
        type=int,
        default=None,
        help="granular result as .vtp: the frame to write (negative counts from the end; default the last)",
    )
    p.set_defaults(func=main)
