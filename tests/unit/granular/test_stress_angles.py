"""Principal stress axes in heaps against Wittmer, Cates & Claudin (thesis §1.3, §4.2; digest §2.2, §2.6).

Truths: the closures' angles in closed form (FPA: Psi = (pi/2 - phi)/2 at every S, the thesis's 28.5° for
phi = atan 0.65; BCC: vertical on the axis by symmetry, the same surface value in its outer region); the read-out's
mirror symmetry (a heap mirrored about its apex gives the same folded angles and opposite raw ones, to rounding:
this pins the sign conventions of the stress tensor, the fold and the grid); the thesis's observation that each
half of a poured heap has a preferred direction (Fig. 4.24), on the poured heap scene (slow).
"""

import math
from pathlib import Path

import numpy as np
import pytest

from porepipe.granular import analyse_heap, heap_stress_angles, read_granular, run, wittmer_angles
from porepipe.scene import load_scene

SCENES = Path(__file__).parents[3] / "config" / "scenes"
PHI = math.atan(0.65)


def test_fpa_keeps_the_surface_angle_and_bcc_turns_vertical_on_the_axis():
    S = np.linspace(1e-6, 0.999, 50)  # at S = 0 itself FPA's stress is isotropic (s_xx = s_zz, s_xz = 0)
    w = wittmer_angles(S, PHI)
    assert math.degrees(w["surface"][0]) == pytest.approx(28.49, abs=0.01)  # the thesis's 28.5°
    np.testing.assert_allclose(
        w["FPA"], w["surface"], rtol=1e-10
    )  # arctan of ratios: ~1e-11 rounding near S = 0
    assert abs(w["BCC"][0]) < 1e-5
    outer = S > 0.5  # BCC's inner/outer boundary c1/c = 0.479 for this phi
    np.testing.assert_allclose(w["BCC"][outer], w["surface"][outer], rtol=1e-12)
    assert np.all(np.diff(w["BCC"][~outer]) > 0)


def _mirrored(tables):
    """The result mirrored about x = 0: positions, angles, body outlines, walls, contact points and forces."""
    f = tables["frames"].copy(deep=True)
    c = tables["contacts"].copy(deep=True)
    for name in ("position_m", "vertices_m", "wall_vertices_m", "velocity_m_s"):
        f[name].values[..., 0] *= -1
    f["angle_rad"].values[...] *= -1
    for name in ("sx_m", "fx_N"):
        c[name].values[...] *= -1
    return {**tables, "frames": f, "contacts": c}


@pytest.fixture(scope="module")
def heap_ci(tmp_path_factory):
    scene = load_scene(SCENES / "granular-heap-ci.yaml")
    out = run(
        scene.granular, tmp_path_factory.mktemp("heap") / "granular.h5", seed=scene.seed, progress=False
    )
    return read_granular(out)


def test_mirrored_heap_gives_the_same_folded_angles(heap_ci):
    h = analyse_heap(heap_ci)
    a = heap_stress_angles(heap_ci, h, phi=PHI, grains_per_area=10)
    hm = {**h, "apex_x_m": -h["apex_x_m"], "foot_m": (-h["foot_m"][1], -h["foot_m"][0])}
    b = heap_stress_angles(_mirrored(heap_ci), hm, phi=PHI, grains_per_area=10)
    assert len(a["S"]) >= 3
    ia, ib = np.lexsort((a["x_m"], a["y_m"])), np.lexsort((-b["x_m"], b["y_m"]))
    np.testing.assert_allclose(b["x_m"][ib], -a["x_m"][ia], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(b["psi_rad"][ib], -a["psi_rad"][ia], atol=1e-9)
    np.testing.assert_allclose(b["psi_folded_rad"][ib], a["psi_folded_rad"][ia], atol=1e-9)
    np.testing.assert_allclose(b["S"][ib], a["S"][ia], rtol=1e-9)


@pytest.mark.slow
def test_poured_heap_halves_have_a_preferred_direction(tmp_path):
    """granular-heap-poured (400 grains, 136 000 steps): the folded angle leans away from the axis on average,
    by more than 3 standard errors (measured 17.6° ± 3.3° with 30 grains per area; FPA's 28.5° is not met, as
    the thesis found its Fig. 4.25 'only poorly described' by Wittmer's prediction)."""
    scene = load_scene(SCENES / "granular-heap-poured.yaml")
    tables = read_granular(run(scene.granular, tmp_path / "granular.h5", seed=scene.seed, progress=False))
    a = heap_stress_angles(tables, analyse_heap(tables), phi=PHI)
    assert a["mean_folded_rad"] > 3 * a["sem_folded_rad"]
    assert len(a["S"]) >= 8
