"""``porepipe permeability``: LBM permeability of a binary volume along one or more axes (argparse only).

The work is in ``_run``.
"""

from __future__ import annotations

import argparse

from porepipe._shared.errors import PorepipeError
from porepipe._shared.overrides import add_threads_option, given_options, merge_settings
from porepipe.lbm._settings import (
    Axis,
    Collision,
    Gradient,
    Lateral,
    Precision,
    Settings,
    Setup,
    StopRule,
    Velocity,
    Walls,
)

#: CLI flag -> settings key for the options that override the scene
_OVERRIDES = (
    "collision",
    "tau",
    "tau_bulk",
    "magic",
    "setup",
    "mirror",
    "lateral",
    "precision",
    "body_force",
    "gradient",
    "velocity",
    "max_steps",
    "window_steps",
    "tolerance_velocity",
    "tolerance_density",
    "tolerance_kappa",
    "write_fields",
    "write_vti",
    "accept_unconverged",
    "walls",
    "stop",
)


def _settings(args) -> Settings:
    base = None
    if args.scene:
        from porepipe.scene import load_scene

        base = load_scene(args.scene).permeability
    return merge_settings(Settings, base, given_options(args, _OVERRIDES), "permeability settings")


def main(args) -> int:
    """Run the subcommand; returns the exit code. With ``--mpi`` an error on any rank ends every rank."""
    if not args.mpi:
        return _main(args)
    try:
        return _main(args)
    except Exception as err:
        from porepipe.lbm._mpi import SharedError, abort_world

        kind = "error" if isinstance(err, PorepipeError) else type(err).__name__
        abort_world(f"porepipe permeability: {kind}: {err}", shared=isinstance(err, SharedError))
        raise


def _main(args) -> int:
    from porepipe.lbm._run import run

    results = run(
        args.binary,
        _settings(args),
        args.axis,
        out=args.out,
        out_dir=args.out_dir,
        threads=args.threads,
        checkpoint=args.checkpoint,
        resume=args.resume,
        packing=args.packing,
        grey=args.grey,
        grains=args.grains,
        mpi=args.mpi,
    )
    if args.mpi and not _is_root():
        return 0
    for out, r in results:
        print(
            f"axis {r.axis.value}: kappa = {r.kappa_lu:.6g} voxel^2 = "
            f"{r.kappa_m2:.6g} m^2 = {r.kappa_mD:.6g} mD ({r.method}, {r.reason}, {r.steps} steps, "
            f"{r.mlups:.1f} MLUPS, walls {r.walls}) -> {out}"
        )
        if r.warning:
            print(f"warning: {r.warning}")
    return 0


def _is_root() -> bool:
    from mpi4py import MPI

    return MPI.COMM_WORLD.Get_rank() == 0


def register(subparsers) -> None:
    """Add ``permeability`` to the ``porepipe`` command."""
    p = subparsers.add_parser("permeability", help="lattice-Boltzmann permeability of a binary volume")
    p.add_argument("binary", help="binary_a{a}.h5 (volume 'pore', 1 = pore)")
    p.add_argument(
        "--axis",
        action="append",
        choices=[a.value for a in Axis],
        help="flow axis (repeatable); default: the scene's `axes`",
    )
    p.add_argument("-o", "--out", help="output file (one axis); default perm_a{a}_{axis}.h5 beside the input")
    p.add_argument("--out-dir", help="directory for perm_a{a}_{axis}.h5 files")
    p.add_argument("--scene", help="scene YAML whose `permeability` section gives the defaults")
    add_threads_option(p)
    p.add_argument(
        "--checkpoint", help="checkpoint file (one axis; default .<out>.checkpoint.h5 beside the result)"
    )
    p.add_argument(
        "--resume",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="continue from a matching checkpoint (default); --no-resume starts afresh",
    )
    p.add_argument(
        "--mpi",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="run as one rank of `mpirun -n P porepipe permeability --mpi …`: slabs along the flow, "
        "rank 0 writes the result (needs mpi4py: pip install 'porepipe[mpi]')",
    )
    p.add_argument("--collision", choices=[c.value for c in Collision])
    p.add_argument("--walls", choices=[w.value for w in Walls])
    p.add_argument("--stop", choices=[r.value for r in StopRule])
    p.add_argument(
        "--grey", help="grey_a{a}.h5 of the binary volume: sub-voxel wall distances from grey values"
    )
    p.add_argument("--packing", help="packing.h5 whose spheres the binary volume shows: exact wall distances")
    p.add_argument(
        "--grains", help="grains.h5 whose decorated grains the binary volume shows: exact wall distances"
    )
    p.add_argument("--setup", choices=[s.value for s in Setup])
    p.add_argument("--lateral", choices=[s.value for s in Lateral])
    p.add_argument("--precision", choices=[s.value for s in Precision])
    p.add_argument("--gradient", choices=[s.value for s in Gradient])
    p.add_argument("--velocity", choices=[s.value for s in Velocity])
    p.add_argument("--mirror", action=argparse.BooleanOptionalAction)
    p.add_argument("--write-fields", dest="write_fields", action=argparse.BooleanOptionalAction)
    p.add_argument("--write-vti", dest="write_vti", action=argparse.BooleanOptionalAction)
    p.add_argument("--accept-unconverged", dest="accept_unconverged", action=argparse.BooleanOptionalAction)
    for name, kind in (
        ("tau", float),
        ("tau-bulk", float),
        ("magic", float),
        ("body-force", float),
        ("max-steps", int),
        ("window-steps", int),
        ("tolerance-velocity", float),
        ("tolerance-density", float),
        ("tolerance-kappa", float),
    ):
        p.add_argument(f"--{name}", dest=name.replace("-", "_"), type=kind)
    p.set_defaults(func=main)
