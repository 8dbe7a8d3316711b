"""What every benchmark script shares: where its records go (never into the source tree)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

#: default folder of benchmark records: the git-ignored results tree of the checkout
RESULTS = Path(__file__).resolve().parents[1] / "results" / "benchmarks"


def add_out_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``-o/--out DIR`` (default ``results/benchmarks/`` of the checkout) to ``parser``."""
    parser.add_argument(
        "-o", "--out", default=str(RESULTS), help=f"folder for the JSON/markdown records (default: {RESULTS})"
    )


def write_record(out: str | Path, name: str, record: object) -> Path:
    """Write ``record`` as ``<out>/<name>`` (JSON) and return the path; the folder is created if missing."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(json.dumps(record, indent=1))
    print(f"record: {path}")
    return path
