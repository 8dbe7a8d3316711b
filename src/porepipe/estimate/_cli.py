"""``porepipe estimate``: grey-value estimators over all resolutions of a scene (argparse only; work in ``_run``)."""

from __future__ import annotations


def main(args) -> int:
    """Run the subcommand; returns the exit code."""
    from porepipe.estimate._run import run

    ds = run(args.grey, args.out)
    if "phi_limit" in ds:
        print(f"phi(a->0) = {float(ds.phi_limit):.6f} +- {float(ds.phi_limit_err):.1e}")
    return 0


def register(subparsers) -> None:
    """Add ``estimate`` to the ``porepipe`` command."""
    p = subparsers.add_parser(
        "estimate", help="porosity and specific-surface estimators from grey histograms"
    )
    p.add_argument("grey", nargs="+", help="grey_a{a}.h5 files, one per resolution")
    p.add_argument("-o", "--out", required=True, help="output estimate.h5")
    p.set_defaults(func=main)
