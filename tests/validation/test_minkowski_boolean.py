"""Boolean model of overlapping balls: measured densities against Miles' formulae.

For a Boolean model of balls of radius r with intensity λ (V̄ = 4πr³/3, S̄ = 4πr², M̄ = 4πr, q = exp(-λV̄)):
V_V = 1 - q, S_V = λS̄q, M_V = q(λM̄ - π²λ²S̄²/32), χ_V = q(λ - λ²M̄S̄/(4π) + πλ³S̄³/384)
(Miles 1976; Ohser & Mücklich 2000, §5.2). Twenty periodic realisations in a box of side 8r, digitised at
a = r/16 (a 128³ volume each); the test asks |mean - Miles| <= 3 standard errors of the mean of the realisations
(statistical error of this sample, printed with ``pytest -s``: V_V ± 0.006, S_V ± 0.013 µm⁻¹ at η = 0.4).

KNOWN LIMITATION (xfail below): M_V and χ_V of the digitised Boolean model stay biased (M_V -12 %, χ_V several σ
too negative at r/a = 16, and hardly better at r/a = 48). Along every intersection circle the background forms a thin
wedge; its digitised tip breaks into isolated background pixels in the planar sections (spurious holes, so M_V too
low) and into spurious tunnels in 3-D. This bias does not shrink with the resolution for a local 2x2x2 estimator;
Ohser, Nagel & Schladitz (2009, "Miles formulae for Boolean models observed on lattices", Image Anal. Stereol.
28:77-92) give the lattice versions of Miles' formulae that would be the right reference.
"""

import numpy as np
import pytest

from porepipe.minkowski import minkowski_functionals

R_UM, BOX_R, K, ETA, REALISATIONS = 1.0, 8, 16, 0.4, 20


def paint(centres, radius, n, a):
    """Periodic voxel-centre digitisation of the union of balls."""
    volume = np.zeros((n, n, n), np.uint8)
    k = int(np.ceil(radius / a)) + 1
    offsets = np.arange(-k, k + 1)
    for p in centres / a:
        base = np.floor(p).astype(int)
        index = [(base[d] + offsets) % n for d in range(3)]
        d2 = [(base[d] + offsets + 0.5 - p[d]) ** 2 for d in range(3)]
        inside = d2[0][:, None, None] + d2[1][None, :, None] + d2[2][None, None, :] <= (radius / a) ** 2
        volume[np.ix_(*index)] |= inside.astype(np.uint8)
    return volume


def miles(lam, r):
    v, s, m = 4 / 3 * np.pi * r ** 3, 4 * np.pi * r * r, 4 * np.pi * r
    q = np.exp(-lam * v)
    return np.array([1 - q, lam * s * q, q * (lam * m - np.pi ** 2 / 32 * lam ** 2 * s ** 2),
                     q * (lam - lam ** 2 * m * s / (4 * np.pi) + np.pi * lam ** 3 * s ** 3 / 384)])


def _sample():
    rng = np.random.default_rng(2020)
    box_um, a = BOX_R * R_UM, R_UM / K
    lam = ETA / (4 / 3 * np.pi * R_UM ** 3)
    samples = []
    for _ in range(REALISATIONS):
        centres = rng.uniform(0, box_um, (rng.poisson(lam * box_um ** 3), 3))
        ds = minkowski_functionals(paint(centres, R_UM, BOX_R * K, a), a, periodic=True).sel(phase="pore")
        samples.append([float(ds.phi), float(ds.S_V), float(ds.K_V), float(ds.T_V) / (4 * np.pi)])
    samples = np.asarray(samples)
    mean = samples.mean(axis=0)
    stderr = samples.std(axis=0, ddof=1) / np.sqrt(REALISATIONS)
    exact = miles(lam, R_UM)
    report = "\n".join(f"{q}: {m:.5g} ± {e:.2g} (Miles {x:.5g}, {(m - x) / e:+.2f} σ)"
                       for q, m, e, x in zip(("V_V", "S_V", "M_V", "χ_V"), mean, stderr, exact))
    print(report)
    return mean, stderr, exact, report


def test_boolean_volume_and_surface_match_miles():
    mean, stderr, exact, report = _sample()
    assert np.all(np.abs(mean[:2] - exact[:2]) <= 3 * stderr[:2]), report


@pytest.mark.xfail(strict=True, reason="crease digitisation bias of local M_V / χ_V estimators (see module doc)")
def test_boolean_curvature_and_euler_match_miles():
    mean, stderr, exact, report = _sample()
    assert np.all(np.abs(mean[2:] - exact[2:]) <= 3 * stderr[2:]), report
