"""Damaged and misplaced input files for the file-fuzzing suite (``test_fuzz_files.py``).

Every result kind of a tiny scene lies in ``data/tiny`` (written by porepipe itself, see ``data/tiny/README``);
:func:`mutations` makes truncated, bit-flipped and wrong-stage copies of one of them, deterministically (a seeded
``random.Random``), and :func:`run_cli` runs one subcommand in-process and reports how it ended.
"""

from __future__ import annotations

import contextlib
import io
import random
import shutil
from dataclasses import dataclass
from pathlib import Path

DATA = Path(__file__).parent / "data" / "tiny"
SCENE = DATA / "tiny.yaml"

#: result kind -> its file in DATA
RESULTS = {
    "packing": "packing.h5",
    "grey": "grey_a4.h5",
    "binary": "binary_a4.h5",
    "estimate": "estimate.h5",
    "minkowski": "mink_a4.h5",
    "lpt": "lpt_a4.h5",
    "permeability": "perm_a4_z.h5",
    "diffusion": "diff_a4_z.h5",
}
#: fractions of the file kept by the truncated copies
TRUNCATE_AT = (0.0, 0.03, 0.5, 0.97)
#: bit-flipped copies per file, each flipping FLIPS bits at seeded random places
BIT_FLIP_COPIES = 3
FLIPS = 8


@dataclass(frozen=True)
class Mutation:
    """A damaged or misplaced copy: what was done (``label``) and its bytes."""

    label: str
    data: bytes


def mutations(kind: str, seed: int = 20) -> list[Mutation]:
    """Truncated, bit-flipped and wrong-stage copies of the result ``kind``."""
    original = (DATA / RESULTS[kind]).read_bytes()
    rng = random.Random(f"{kind}-{seed}")
    out = [Mutation(f"{kind} truncated to {f:.0%}", original[: int(len(original) * f)]) for f in TRUNCATE_AT]
    for copy in range(BIT_FLIP_COPIES):
        flipped = bytearray(original)
        # half the flips in the first 4 KiB (superblock, object headers), half anywhere
        for i in range(FLIPS):
            pos = rng.randrange(min(len(flipped), 4096)) if i % 2 == 0 else rng.randrange(len(flipped))
            flipped[pos] ^= 1 << rng.randrange(8)
        out.append(Mutation(f"{kind} bit-flipped #{copy}", bytes(flipped)))
    for other, name in RESULTS.items():
        if other != kind:
            out.append(Mutation(f"{other} result in place of {kind}", (DATA / name).read_bytes()))
    out.append(Mutation(f"text file in place of {kind}", b"x y z r\n1 2 3 4\n"))
    return out


@dataclass
class Outcome:
    """How one in-process CLI call ended."""

    code: int | None
    stderr: str
    exception: BaseException | None = None

    @property
    def clean_error(self) -> bool:
        """Exit code 2 with one line on stderr (warnings before it allowed), no exception escaping."""
        lines = [line for line in self.stderr.strip().splitlines() if "error" in line]
        return (
            self.exception is None and self.code == 2 and len(lines) == 1 and "Traceback" not in self.stderr
        )


def run_cli(argv: list[str]) -> Outcome:
    """``porepipe.cli.main(argv)`` in this process; stdout discarded, stderr captured, escaping exceptions caught."""
    from porepipe.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exit_:
            code = exit_.code if isinstance(exit_.code, int) else 1
        except BaseException as exc:
            return Outcome(None, err.getvalue(), exc)
    return Outcome(code, err.getvalue())


def files_in(directory: Path) -> set[str]:
    """Names of all files below ``directory`` (to check that a failed call wrote nothing)."""
    return {str(p.relative_to(directory)) for p in directory.rglob("*") if p.is_file()}


def place(mutation: Mutation, path: Path) -> Path:
    """Write a mutated copy to ``path`` (its parent created)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(mutation.data)
    return path


def copy_data(name: str, directory: Path) -> Path:
    """An intact copy of ``DATA/name`` in ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    return Path(shutil.copy(DATA / name, directory / name))
