"""``porepipe segment``: binary pore volume from a grey volume (argparse only; work in ``_run``)."""

from __future__ import annotations

from porepipe._shared.overrides import given_options, merge_settings, whole_count
from porepipe.segment._settings import Segmentation, SegmentationMethod


def main(args) -> int:
    """Run the subcommand; returns the exit code."""
    from porepipe.segment._run import run

    # checked as a scene's `segmentation:` is (--threshold with another method than fixed went unused without a word)
    seg = merge_settings(Segmentation, None, given_options(args, ("method", "threshold")), "segment options")
    decision = run(
        args.grey,
        args.out,
        seg.method,
        seg.threshold,
        memory_budget_mb=args.memory_budget_mb,
    )
    if decision.note:
        print(decision.note)
    return 0


def register(subparsers) -> None:
    """Add ``segment`` to the ``porepipe`` command."""
    p = subparsers.add_parser("segment", help="binary pore volume (pore if grey <= threshold)")
    p.add_argument("grey", help="grey_a{a}.h5")
    p.add_argument("-o", "--out", required=True, help="output binary_a{a}.h5")
    p.add_argument(
        "--method",
        choices=[m.value for m in SegmentationMethod],
        default="otsu",
        help="threshold rule: otsu on the grey histogram, fixed g_th, or trivial (pore iff g < 128)",
    )
    p.add_argument("--threshold", type=int, default=None, help="g_th for --method fixed (0..215)")
    p.add_argument(
        "--memory-budget-mb",
        type=whole_count("--memory-budget-mb", "no budget"),
        help="memory budget in MB: fewer than 64 x planes are held at once where they exceed it (default: no "
        "budget; the workflow passes the scene's resources.memory_budget_mb)",
    )
    p.set_defaults(func=main)
