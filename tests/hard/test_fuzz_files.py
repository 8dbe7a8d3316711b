"""File fuzzing: truncated, bit-flipped and wrong-stage copies of every result kind, and damaged image inputs, given to
every subcommand that reads them (in-process via ``porepipe.cli.main``).

Truth: the house rule. A damaged file either gives exit code 2 with one error line and no output file, or (a bit
flip HDF5 cannot notice, e.g. in compressed voxel data that still decodes to valid values) a normal run. Anything
else (an exception escaping, exit code 1, two error lines, a file left behind after an error) is a finding. The
counts are printed (``pytest -s``) for the README's reliability section.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from fuzz_files import DATA, RESULTS, SCENE, Mutation, files_in, mutations, place, run_cli

S = str(SCENE)
BINARY = str(DATA / RESULTS["binary"])

#: (kind, subcommand label, argv builder from (input, output), the input's file name)
CONSUMERS = [
    ("packing", "voxelize", lambda i, o: ["voxelize", S, "--a", "4", "--packing", i, "-o", o], "packing.h5"),
    ("grey", "segment", lambda i, o: ["segment", i, "-o", o], "grey_a4.h5"),
    ("grey", "estimate", lambda i, o: ["estimate", i, "-o", o], "grey_a4.h5"),
    ("grey", "minkowski --grey", lambda i, o: ["minkowski", BINARY, "--grey", i, "-o", o], "grey_a4.h5"),
    ("binary", "minkowski", lambda i, o: ["minkowski", i, "-o", o], "binary_a4.h5"),
    ("binary", "lpt", lambda i, o: ["lpt", i, "--scene", S, "-o", o], "binary_a4.h5"),
    ("binary", "permeability", lambda i, o: ["permeability", i, "--scene", S, "-o", o], "binary_a4.h5"),
    ("binary", "diffusion", lambda i, o: ["diffusion", i, "--scene", S, "-o", o], "binary_a4.h5"),
    ("binary", "subsample", lambda i, o: ["subsample", i, "--edge-um", "20", "-o", o], "binary_a4.h5"),
    ("estimate", "sweep", lambda i, o: ["sweep", i, "-o", o], "estimate.h5"),
    ("minkowski", "sweep", lambda i, o: ["sweep", i, "-o", o], "minkowski_a4.h5"),
    ("lpt", "sweep", lambda i, o: ["sweep", i, "-o", o], "lpt_a4.h5"),
    ("permeability", "sweep", lambda i, o: ["sweep", i, "-o", o], "permeability_a4_z.h5"),
    ("diffusion", "sweep", lambda i, o: ["sweep", i, "-o", o], "diffusion_a4_z.h5"),
]
COUNTS = {"files": 0, "runs": 0, "clean errors": 0, "accepted": 0, "other": 0}


def _judge(outcome, out_dir: Path) -> str:
    left = files_in(out_dir) if out_dir.exists() else set()
    if outcome.clean_error and not left:
        return "clean errors"
    if outcome.exception is None and outcome.code == 0:
        return "accepted"
    return "other"


@pytest.mark.parametrize(
    ("kind", "label", "argv", "name"), CONSUMERS, ids=[f"{c[0]}->{c[1]}" for c in CONSUMERS]
)
def test_damaged_results_give_one_line_errors(kind, label, argv, name, tmp_path):
    findings = []
    for n, mutation in enumerate(mutations(kind)):
        case = tmp_path / str(n)
        outcome = run_cli(argv(str(place(mutation, case / "in" / name)), str(case / "out" / "result.h5")))
        verdict = _judge(outcome, case / "out")
        COUNTS["runs"] += 1
        COUNTS[verdict] += 1
        if verdict == "other":
            findings.append(
                f"{mutation.label}: code {outcome.code}, {outcome.exception!r}, {outcome.stderr[-300:]}"
            )
    assert not findings, f"{label}:\n" + "\n".join(findings)


@pytest.mark.parametrize(
    ("kind", "label", "argv", "name"), CONSUMERS, ids=[f"{c[0]}->{c[1]}" for c in CONSUMERS]
)
def test_intact_results_are_accepted(kind, label, argv, name, tmp_path):
    """The control: each consumer reads the intact file (else every refusal above would prove nothing)."""
    intact = place(Mutation("intact", (DATA / RESULTS[kind]).read_bytes()), tmp_path / "in" / name)
    outcome = run_cli(argv(str(intact), str(tmp_path / "out" / "result.h5")))
    assert outcome.exception is None and outcome.code == 0, (outcome.exception, outcome.stderr[-500:])


def _image_inputs(tmp_path: Path) -> dict[str, tuple[Path, list[str]]]:
    """Intact TIFF, RAW, HDF5 and npy images (the tiny grey volume) and the acquire options each needs."""
    import tifffile

    from porepipe._shared.store import read_volume

    grey, _ = read_volume(DATA / RESULTS["grey"], "grey")
    grey = np.ascontiguousarray(grey)
    src = tmp_path / "src"
    src.mkdir()
    tif = src / "image.tif"
    tifffile.imwrite(tif, np.moveaxis(grey, 2, 0))  # pages = z sections
    raw = src / "image.raw"
    raw.write_bytes(np.asfortranarray(grey).tobytes(order="F"))
    h5 = src / "image.h5"
    import h5py

    with h5py.File(h5, "w") as f:
        f["image"] = grey
    npy = src / "image.npy"
    np.save(npy, grey)
    shape = [str(s) for s in grey.shape]
    common = ["--voxel-um", "4", "--no-grains", "--method", "otsu"]
    return {
        "tiff": (tif, ["--format", "tiff", *common]),
        "raw": (raw, ["--format", "raw", "--raw-shape", *shape, *common]),
        "hdf5": (h5, ["--format", "hdf5", "--dataset", "image", *common]),
        "npy": (npy, ["--format", "npy", *common]),
    }


def _image_mutations(path: Path, seed: int) -> list[Mutation]:
    import random

    data = path.read_bytes()
    rng = random.Random(f"{path.suffix}-{seed}")
    out = [
        Mutation(f"{path.suffix} truncated to {f:.0%}", data[: int(len(data) * f)])
        for f in (0.0, 0.03, 0.5, 0.97)
    ]
    for copy in range(3):
        flipped = bytearray(data)
        for i in range(8):
            pos = rng.randrange(min(len(flipped), 1024)) if i % 2 == 0 else rng.randrange(len(flipped))
            flipped[pos] ^= 1 << rng.randrange(8)
        out.append(Mutation(f"{path.suffix} bit-flipped #{copy}", bytes(flipped)))
    out.append(Mutation(f"packing result as {path.suffix}", (DATA / RESULTS["packing"]).read_bytes()))
    return out


@pytest.mark.parametrize("fmt", ["tiff", "raw", "hdf5", "npy"])
def test_damaged_images_give_one_line_errors(fmt, tmp_path):
    path, options = _image_inputs(tmp_path)[fmt]
    findings = []
    for n, mutation in enumerate(_image_mutations(path, 20)):
        case = tmp_path / str(n)
        bad = place(mutation, case / "in" / path.name)
        outcome = run_cli(["acquire", str(bad), *options, "-o", str(case / "out" / "statistics.h5")])
        verdict = _judge(outcome, case / "out")
        COUNTS["runs"] += 1
        COUNTS[verdict] += 1
        if verdict == "other":
            findings.append(
                f"{mutation.label}: code {outcome.code}, {outcome.exception!r}, {outcome.stderr[-300:]}"
            )
    assert not findings, f"acquire {fmt}:\n" + "\n".join(findings)


def test_zzz_print_file_fuzz_counts():
    """Runs last in this module (pytest keeps file order): the tallies for the README's reliability section."""
    COUNTS["files"] = COUNTS["runs"]
    print(f"\nfile fuzzing: {COUNTS}")
    assert COUNTS["other"] == 0
