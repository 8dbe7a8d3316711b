"""The README's "Using it" block, pasted in order in a fresh folder: every command runs (the heavy ones at a test
size, each change listed below), none is dropped without a reason written here, and each one that writes a file
leaves it. Then the polish items: `estimate` given a binary volume and `acquire --voxel-um` over the file's own
voxel size each answer with one line.

Test size: `config/scenes/mini.yaml` is replaced by a 32 µm box of 60 spheres (same name and analyses), the
granular box settles for 0.01 s instead of 0.2 s, full-scene `run` lines run as dry runs (`-n`), and the diffusion
line stops after 2·10⁵ wall hits. Commands run in this process through `porepipe.cli.main` (one interpreter, the
numba cache of the earlier tests), `run` lines start Snakemake as they do for a user."""

import re
import shlex
import shutil
from pathlib import Path

import h5py
import pytest

from porepipe.cli import main

ROOT = Path(__file__).resolve().parents[2]

TINY_MINI = """\
name: mini
seed: 7
domain: {size_um: [32, 32, 32], periodic: true}
spheres: {pack: true}
resolutions_um: [4, 2, 1]
segmentation: {method: otsu}
analyses: [segment, estimate, minkowski, lpt, permeability, report]
permeability: {axes: [z], collision: trt, resolutions_um: [4]}
packing:
  cutoff: 1.3
  types:
    - {name: grain, count: 60, max_overlap: 0.3, radius_um: {dist: uniform, min_um: 3, max_um: 4}}
  stages:
    - {name: primary, insert: [grain], steps: 100, dt: 0.05, k: {grain: 400}, damping: {grain: 4}}
"""

#: lines of the block this test does not run, and why (a new line in the README must be run or listed here)
NOT_RUN = {
    ".ci/run --checks-only": "CI itself: it reinstalls the virtual environment this test runs in",
    "report config/scenes/mini.yaml": "needs the finished mini run of the first block (tests/workflow/test_report_workflow.py)",
}
#: extra arguments that bring a command to test size
TEST_SIZE = {"diffusion": ["--max-wall-hits", "200000"]}


def _block() -> list[str]:
    text = (ROOT / "README.md").read_text()
    body = re.search(r"## Using it\n\n```bash\n(.*?)```", text, re.S).group(1)
    return [line for line in body.splitlines() if line.strip() and not line.lstrip().startswith("#")]


def _argv(line: str) -> list[str] | None:
    words = shlex.split(line, comments=True)
    if " ".join(words[1:]) in NOT_RUN or " ".join(words) in NOT_RUN:
        return None
    assert words[0] == ".venv/bin/porepipe", f"a README command this test cannot run: {line}"
    argv = words[1:]
    if argv[0] == "run" and not {"-n", "--unlock", "--"} & set(argv):
        argv.append("-n")
    return argv + TEST_SIZE.get(argv[0], [])


@pytest.fixture
def fresh_clone(tmp_path, monkeypatch):
    shutil.copytree(ROOT / "config", tmp_path / "config")
    (tmp_path / "config" / "scenes" / "mini.yaml").write_text(TINY_MINI)
    box = tmp_path / "config" / "scenes" / "granular-box.yaml"
    box.write_text(box.read_text().replace("duration_s: 0.2", "duration_s: 0.01"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.slow
def test_using_it_block_runs_in_order(fresh_clone, capsys):
    lines = _block()
    skipped = [line for line in lines if _argv(line) is None]
    assert len(skipped) == len(NOT_RUN)  # every reason above names a line that is still in the README
    for line in lines:
        argv = _argv(line)
        if argv is None:
            continue
        if "*" in line:
            argv = argv[:1] + sorted(str(p) for p in Path().glob(argv[1])) + argv[2:]
        assert main(argv) == 0, f"{line}\n{capsys.readouterr().err[-3000:]}"
        for out in [argv[i + 1] for i, a in enumerate(argv) if a in ("-o", "--xyzr")]:
            assert Path(out).is_file(), f"{line}: {out} was not written"
    with h5py.File("perm_a2_z.h5") as f:
        assert "velocity_z" in f["volumes"]  # the export line found fields to export


def test_estimate_given_a_binary_volume_and_acquire_voxel_override_answer_in_one_line(fresh_clone, capsys):
    main(["pack", "config/scenes/mini.yaml", "-o", "packing.h5"])
    main(["voxelize", "config/scenes/mini.yaml", "--packing", "packing.h5", "--a", "4", "-o", "grey.h5"])
    main(["segment", "grey.h5", "-o", "binary.h5"])
    capsys.readouterr()
    assert main(["estimate", "binary.h5", "-o", "estimate.h5"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "is not a grey volume file" in err and "'segment'" in err
    assert not Path("estimate.h5").exists()
    image = "config/scenes/data/image-to-model.tif"  # an ImageJ TIFF stating 2 µm voxels
    assert main(["acquire", image, "--voxel-um", "3.7", "--no-grains", "-o", "statistics.h5"]) == 0
    (warning,) = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert "2 × 2 × 2 µm" in warning and "3.7 µm" in warning
