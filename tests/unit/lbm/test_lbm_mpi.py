"""``porepipe permeability --mpi`` under ``mpirun -n 2``: the one-process κ̂, per-rank checkpoints, dead ranks.

Truth: the one-process run of the same sample (an independent decomposition of the same arithmetic). Every
reduction sums per-layer tables and a layer lies on one rank, so κ̂ agrees to the last bit; the tests allow 1e-12
relative (a compiler that vectorised a slab's tiles differently could change the last bits of a node's update).
"""

import importlib.util
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import psutil
import pytest
import xarray as xr
from scipy import ndimage

from porepipe._shared.store import ResultWriter
from porepipe.cli import main

pytestmark = [
    pytest.mark.skipif(
        shutil.which("mpirun") is None or importlib.util.find_spec("mpi4py") is None,
        reason="needs mpirun (Debian: apt-get install openmpi-bin libopenmpi-dev) and mpi4py (pip install '.[mpi]')",
    ),
    pytest.mark.slow,  # 7 mpirun launches: ~40 s on 2 idle cores
    pytest.mark.serial,  # its two busy-polling ranks beside a second test worker ran past LIMIT_S
]

#: relative κ̂ tolerance against the one-process run (see the module docstring)
ROUND_OFF = 1e-12
#: a converging run: checks every 100 steps, the periodic sample settles in ~300 steps
FAST = ["--axis", "x", "--window-steps", "100", "--collision", "trt"]
#: seconds an mpirun may take (start-up and cached kernels ~5 s on 2 busy cores; a hang is what this catches)
LIMIT_S = 120


def _binary(tmp_path):
    """A porous sample (smoothed noise, porosity 0.55), 24 layers along the flow: two slabs of ~12."""
    noise = ndimage.gaussian_filter(np.random.default_rng(3).random((24, 16, 16)), 2, mode="wrap")
    path = tmp_path / "binary_a2.h5"
    with ResultWriter(path, stage="segment", scene="t", scene_hash="h") as w:
        w.write_volume("pore", (noise > np.quantile(noise, 0.45)).astype(np.uint8), voxel_um=2.0)
    return path


def _python(ranks: int, args: list[str]) -> list[str]:
    """``mpirun -n ranks python args`` (as root too)."""
    root = ["--allow-run-as-root"] if os.geteuid() == 0 else []
    return ["mpirun", "-n", str(ranks), "--oversubscribe", *root, sys.executable, *args]


def _command(ranks: int, args: list[str]) -> list[str]:
    """``mpirun -n ranks porepipe args``."""
    return _python(ranks, ["-c", "import sys; from porepipe.cli import main; sys.exit(main())", *args])


def _env() -> dict:
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    return env


def _mpirun(ranks: int, args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(
        _command(ranks, ["permeability", *args]), env=_env(), capture_output=True, text=True, timeout=LIMIT_S
    )


def _errors(done: subprocess.CompletedProcess) -> int:
    """Number of error lines of the ranks (an error every rank has alike is reported once, by rank 0)."""
    return sum(line.startswith("porepipe permeability: error") for line in done.stderr.splitlines())


def _kappa(path) -> float:
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return float(ds["kappa_lu"])


def test_two_ranks_give_the_one_process_kappa_with_chambers(tmp_path):
    """The chamber set-up: force zone on rank 0 only, pressure gradient from layer means of both ranks (the
    periodic set-up is compared in the checkpoint test).
    """
    binary = _binary(tmp_path)
    one, two = tmp_path / "one.h5", tmp_path / "two.h5"
    args = [str(binary), *FAST, "--setup", "chambers"]
    assert main(["permeability", *args, "-o", str(one)]) == 0
    done = _mpirun(2, [*args, "-o", str(two), "--mpi"])
    assert done.returncode == 0, done.stderr
    assert _kappa(two) == pytest.approx(_kappa(one), rel=ROUND_OFF, abs=0)
    assert done.stdout.count("kappa =") == 1  # rank 0 alone reports and writes


#: two ranks run two simple-cubic sphere cells along x with CLI walls at the exact sphere surfaces
_SPHERES = """
import sys
import numpy as np
from porepipe.lbm import Settings, SphereWalls, permeability
from porepipe.lbm._mpi import decomposition
cells, a = 12, 3.2
x = np.arange(2 * cells) + 0.5
y = np.arange(cells) + 0.5
centre = np.where(x < cells, cells / 2, 1.5 * cells)
r2 = (x - centre)[:, None, None] ** 2 + (y - cells / 2)[None, :, None] ** 2 + (y - cells / 2)[None, None, :] ** 2
walls = SphereWalls(np.array([[6.0, 6, 6], [18.0, 6, 6]]), np.array([a, a]), (24.0, 12.0, 12.0))
comm = decomposition(sys.argv[1] == "mpi")
settings = Settings(walls="cli", window_steps=100)
r = permeability(r2 >= a * a, "x", settings, comm=comm, progress=False, geometry=walls)
if comm.root:
    print(repr(r.kappa_lu), r.n_links, r.walls)
"""


def test_two_ranks_give_the_one_process_kappa_with_interpolated_walls():
    """Each slab sees the sphere surfaces through its own coordinates; the mass the interpolated walls leak is
    restored over all ranks (a sum in another order: the last bit of κ̂ may differ, within ROUND_OFF).
    """
    one = subprocess.run(
        [sys.executable, "-c", _SPHERES, "one"], capture_output=True, text=True, timeout=LIMIT_S, env=_env()
    )
    two = subprocess.run(
        _python(2, ["-c", _SPHERES, "mpi"]),
        capture_output=True,
        text=True,
        timeout=LIMIT_S,
        env=_env(),
    )
    assert one.returncode == 0 and two.returncode == 0, one.stderr + two.stderr
    # ranks under mpirun write to a terminal (Open MPI forwards through a pty): drop colour codes
    (k1, links1, walls1), (k2, links2, walls2) = (
        re.sub(r"\x1b\[[0-9;]*m", "", r.stdout).split() for r in (one, two)
    )
    assert walls1 == walls2 == "cli" and links1 == links2 and int(links1) > 0
    assert float(k2) == pytest.approx(float(k1), rel=ROUND_OFF, abs=0)


def test_checkpoints_are_per_rank_resumed_together_and_refused_when_stale(tmp_path):
    binary, out, ckpt = _binary(tmp_path), tmp_path / "perm.h5", tmp_path / "c.h5"
    args = [str(binary), *FAST, "-o", str(out), "--checkpoint", str(ckpt), "--mpi"]
    stopped = _mpirun(2, [*args, "--max-steps", "200"])  # step limit: an error, no result, checkpoints kept
    assert stopped.returncode != 0 and not out.exists()
    assert _errors(stopped) == 1 and "not converged after 200 steps" in stopped.stderr  # rank 0 reports alone
    ranks = [tmp_path / "c.rank0of2.h5", tmp_path / "c.rank1of2.h5"]
    assert all(p.is_file() for p in ranks)
    # one process does not resume a two-rank state: refused with the files named
    assert main(["permeability", *args[:-1], "--max-steps", "20000"]) == 2
    # rank 1 lost its state, rank 0 still has it: refused, nothing written
    kept = ranks[1].rename(tmp_path / "kept.h5")
    refused = _mpirun(2, args)
    assert refused.returncode != 0 and not out.exists()
    assert "disagree: steps [200, -1]" in refused.stderr and _errors(refused) == 1
    kept.rename(ranks[1])
    resumed = _mpirun(2, args)
    assert resumed.returncode == 0, resumed.stderr
    assert not any(p.exists() for p in ranks)  # converged: checkpoints deleted
    one = [str(binary), *FAST, "-o", str(tmp_path / "one.h5"), "--checkpoint", str(tmp_path / "one.ckpt.h5")]
    assert main(["permeability", *one, "--max-steps", "200"]) == 2  # the same stop and resume in one process
    assert main(["permeability", *one]) == 0
    assert _kappa(out) == pytest.approx(_kappa(tmp_path / "one.h5"), rel=ROUND_OFF, abs=0)


def test_a_rank_that_raises_ends_the_run_with_one_line_and_no_result(tmp_path):
    binary, out, ckpt = _binary(tmp_path), tmp_path / "perm.h5", tmp_path / "c.h5"
    (tmp_path / "c.rank1of2.h5").write_text("not a checkpoint")  # rank 1 fails, rank 0 waits for it
    t0 = time.monotonic()
    done = _mpirun(2, [str(binary), *FAST, "-o", str(out), "--checkpoint", str(ckpt), "--mpi"])
    assert done.returncode != 0 and not out.exists()
    assert _errors(done) == 1 and "damaged" in done.stderr and "MPI rank 1 of 2" in done.stderr, done.stderr
    assert time.monotonic() - t0 < LIMIT_S


def _rank_process(mpirun: subprocess.Popen, rank: int, wait_s: float) -> psutil.Process:
    """The process of ``rank`` under ``mpirun`` once it runs (Open MPI gives each its rank in the environment)."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        for child in psutil.Process(mpirun.pid).children(recursive=True):
            try:
                if child.environ().get("OMPI_COMM_WORLD_RANK") == str(rank):
                    return child
            except psutil.Error:
                continue
        time.sleep(0.2)
    raise AssertionError(f"rank {rank} did not start within {wait_s} s")


def test_a_killed_rank_ends_the_run_without_a_result(tmp_path):
    binary, out = _binary(tmp_path), tmp_path / "perm.h5"
    never = ["--stop", "density", "--tolerance-density", "1e-300", "--max-steps", "100000000"]
    args = ["permeability", str(binary), *FAST, *never, "-o", str(out), "--mpi"]
    with subprocess.Popen(
        _command(2, args), env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    ) as mpirun:
        victim = _rank_process(mpirun, 1, LIMIT_S)
        line = "-"
        while line and not line.startswith("[lbm x]"):  # rank 0's first progress line: the ranks are stepping
            line = mpirun.stderr.readline()
        assert line, "the run ended before its first step"
        victim.send_signal(signal.SIGKILL)
        _, stderr = mpirun.communicate(timeout=LIMIT_S)  # no hang: the other rank is ended too
    assert mpirun.returncode != 0 and not out.exists()
    assert "signal 9" in stderr, stderr
