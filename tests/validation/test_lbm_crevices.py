"""Interpolated walls in the crevices of a decorated grain model (issue 19's "CLI creep at 8 µm").

The fontainebleau-like model (99 quartz types on overlapping spheres) at 8 µm: 40³ voxels, 9 235 pore nodes, 31 % of
the boundary nodes with ≥ 10 wall links (crevices one or two voxels wide). Two causes, one guard each:

* a growing local mode: a force-free perturbation grew (CLI ×1.01, MR1 ×1.2 per 2000 steps after ~20 000 steps;
  it sat in ~20 crevice nodes with 11-17 wall links) and the driven κ̂ crept (+0.9 % from 50 000 to 200 000 steps).
  Guard: ``porepipe.lbm._walls.CROWDED_LINKS`` (halfway bounce-back at such nodes);
* a slow drift from links with q → 0: with the first guard alone the driven κ̂ still moved +0.27 % from 20 000 to
  150 000 steps. Guard: ``Q_MIN`` = 0.1.

The mass the walls leak (2.4e-10 per node and step, restored at every check) was not the cause: restoring it every
window left the creep unchanged.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from porepipe._shared.store import read_binary_volume
from porepipe.lbm._api import prepare
from porepipe.lbm._settings import Settings
from porepipe.lbm._solver import make_stepper
from porepipe.lbm._walls import build_links, geometry_from_files

SCENE = Path(__file__).parents[2] / "config" / "scenes" / "fontainebleau-like.yaml"


def _porepipe(*args):
    exe = shutil.which("porepipe", path=str(Path(sys.executable).parent)) or "porepipe"
    subprocess.run(
        [exe, *map(str, args)], check=True, capture_output=True, env={**os.environ, "NUMBA_NUM_THREADS": "1"}
    )


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """(pore, grain geometry) of the decorated model at 8 µm, built by the pipeline's commands."""
    d = tmp_path_factory.mktemp("crevices")
    _porepipe("decorate", SCENE, "-o", d / "grains.h5", "--threads", "1")
    _porepipe(
        "voxelize-grains", SCENE, "--grains", d / "grains.h5", "--a", 8, "-o", d / "grey.h5", "--threads", "1"
    )
    _porepipe("segment", d / "grey.h5", "-o", d / "binary.h5", "--method", "otsu")
    pore, meta = read_binary_volume(d / "binary.h5")
    geo = geometry_from_files(
        pore.shape, meta.voxel_um, meta.origin_um, grains=d / "grains.h5", periodic=meta.periodic
    )
    return np.ascontiguousarray(np.moveaxis(pore.astype(bool), 2, 0)), geo.permuted([2, 0, 1])


def _stepper(model, walls: str, body_force: float):
    pore, geo = model
    settings = Settings(walls=walls, body_force=body_force)
    lat = prepare(pore, settings, keep_wall_links=True).lattice
    links = build_links(lat.pore, lat.periodic, *lat.wall_links, geo, settings.walls)
    return make_stepper(settings, lat, links), lat.n_nodes


@pytest.mark.slow
@pytest.mark.parametrize("walls", ["cli", "mr1"])
def test_no_mode_grows_in_the_crevices(model, walls):
    """Force-free, from a random perturbation (1e-6): the change per 2000 steps does not grow from step 10 000 to
    30 000 (allowed: +2 %, round-off of a decaying or steady leak; unguarded MR1 grew +25 % by then)."""
    step, n = _stepper(model, walls, 1e-300)
    src = 1e-6 * np.random.default_rng(0).standard_normal(19 * n)
    dst, fields = np.zeros_like(src), np.zeros((4, n))
    changes = []
    for _ in range(15):
        before = src.copy()
        step(src, dst, fields, False, 2000)
        changes.append(np.linalg.norm(src - before))
    assert np.all(np.isfinite(changes))
    assert changes[-1] < 1.02 * changes[4]


@pytest.mark.slow
def test_driven_mass_leak_is_small_and_steady(model):
    """Driven flow (b = 1e-6), CLI: the walls' mass leak per node and step stays below 1e-9 (measured 2.4e-10; the
    solver puts it back at every check) and is steady (two windows within 5 %)."""
    step, n = _stepper(model, "cli", 1e-6)
    src = np.zeros(19 * n)
    dst, fields = np.zeros_like(src), np.zeros((4, n))
    leaks = []
    for _ in range(6):
        before = src.sum()
        step(src, dst, fields, False, 2000)
        leaks.append((src.sum() - before) / n / 2000)
    assert max(abs(x) for x in leaks) < 1e-9
    assert abs(leaks[-1] / leaks[-2] - 1) < 0.05


@pytest.mark.slow
def test_driven_flow_settles(model):
    """Driven flow (b = 1e-6), CLI: the flux changes by less than 5e-5 from step 30 000 to 40 000 (measured 1.7e-5;
    halfway walls 1.2e-5; without Q_MIN ~2e-4 per 10 000 steps, without either guard growing)."""
    step, n = _stepper(model, "cli", 1e-6)
    src = np.zeros(19 * n)
    dst, fields = np.zeros_like(src), np.zeros((4, n))
    step(src, dst, fields, True, 30_000)
    flux = fields[1].sum()
    step(src, dst, fields, True, 10_000)
    assert abs(fields[1].sum() / flux - 1) < 5e-5
