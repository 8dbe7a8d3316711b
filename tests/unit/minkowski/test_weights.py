"""Weight tables against independent counts: cubical-complex Euler numbers, plane-by-plane section Euler numbers,
scikit-image's euler_number, the published Crofton direction weights, and the exact phase identities."""

import numpy as np
import pytest
from naive_minkowski import euler6_periodic_naive, section_sums_naive
from skimage.measure import euler_number

from porepipe.minkowski import Adjacency, configuration_histogram, matrix_histogram, minkowski_functionals
from porepipe.minkowski import _weights as W


def _random_blobs(shape, seed, p=0.5):
    """Random volume smoothed a little so that it has components, tunnels and cavities of several sizes."""
    rng = np.random.default_rng(seed)
    v = rng.random(shape)
    v = (v + np.roll(v, 1, 0) + np.roll(v, 1, 1) + np.roll(v, 1, 2)) / 4
    return (v < np.quantile(v, p)).astype(np.uint8)


def _padded(volume):
    return np.pad(volume, 1)


@pytest.mark.parametrize("seed", range(4))
def test_euler6_equals_cubical_complex_count_periodic(seed):
    v = _random_blobs((12, 10, 14), seed, p=0.3 + 0.1 * seed)
    hist = configuration_histogram(v, True)
    assert hist @ W.euler_table(6) == 8 * euler6_periodic_naive(v)
    # 26-adjacency is the dual: on the torus χ26(X) = χ6(Xᶜ)
    assert hist @ W.euler_table(26) == 8 * euler6_periodic_naive(1 - v)


@pytest.mark.parametrize("seed", range(6))
def test_euler_matches_scikit_image(seed):
    # skimage.measure.euler_number (Ohser et al. LUT; connectivity 1 = 6, 3 = 26) on a body inside the window
    v = _padded(_random_blobs((9, 11, 8), seed, p=0.25 + 0.08 * seed))
    hist = configuration_histogram(v, False)
    for adjacency, connectivity in ((6, 1), (26, 3)):
        chi = hist @ W.euler_table(adjacency)
        assert chi % 8 == 0
        assert chi // 8 == euler_number(v, connectivity=connectivity), (adjacency, seed)


@pytest.mark.parametrize("seed", range(3))
def test_section_euler_matches_plane_by_plane_count(seed):
    v = _padded(_random_blobs((8, 9, 7), seed, p=0.35))
    hist = configuration_histogram(v, False)
    (ax4, ax8), (d4, d8), tri = section_sums_naive(v)
    e6 = W.section_euler_table(6) @ hist
    e26 = W.section_euler_table(26) @ hist
    assert np.all(e6 % 24 == 0) and np.all(e26 % 24 == 0)
    # families 0 = x normal, 7 = (0,1,1) normal, 9 = (1,1,1) normal
    assert (e6[0] // 24, e6[7] // 24, e6[9] // 24) == (ax4, d4, tri)
    assert (e26[0] // 24, e26[7] // 24, e26[9] // 24) == (ax8, d8, tri)


def test_section_families_are_related_by_lattice_symmetry():
    # Each family's table is built by the same code; check all 13 against the three checked above by permuting
    # and flipping the axes of a volume (a flip maps e.g. the (1,1,1) family onto (1,1,-1)).
    v = _padded(_random_blobs((7, 8, 9), 5, p=0.4))
    base = W.section_euler_table(6) @ configuration_histogram(v, False)
    for perm in ((0, 1, 2), (1, 2, 0), (2, 0, 1), (1, 0, 2)):
        for flip in ((), (0,), (1,), (2,), (0, 1)):
            w = np.flip(np.transpose(v, perm), flip) if flip else np.transpose(v, perm)
            got = W.section_euler_table(6) @ configuration_histogram(np.ascontiguousarray(w), False)
            sign = np.ones(3, int)
            sign[list(flip)] = -1
            for j, d in enumerate(W.DIRECTIONS):
                image = sign * d[list(perm)]  # family j of v is family `image` of w
                k = [
                    i
                    for i, e in enumerate(W.DIRECTIONS)
                    if np.array_equal(e, image) or np.array_equal(e, -image)
                ]
                assert got[k[0]] == base[j], (perm, flip, d)


def test_direction_weights_match_published_values():
    # Schladitz, Ohser & Nagel (2006), Table 1: per lattice point 0.045778 (axes), 0.036981 (face diagonals),
    # 0.035196 (space diagonals); here summed over the ± pair. Rounding of the printed values: 1e-6.
    g = W.geometry((1.0, 1.0, 1.0))
    expected = np.r_[[2 * 0.0457778912] * 3, [2 * 0.0369806279] * 6, [2 * 0.0351956398] * 4]
    np.testing.assert_allclose(g.line_weight, expected, atol=2e-6)
    np.testing.assert_allclose(g.plane_weight, expected, atol=2e-6)
    np.testing.assert_allclose(g.plane_spacing_um, np.r_[[1.0] * 3, [2**-0.5] * 6, [3**-0.5] * 4], rtol=1e-14)


@pytest.mark.parametrize("voxel", [(1.0, 1.0, 2.0), (0.5, 1.5, 1.0)])
def test_anisotropic_geometry(voxel):
    g = W.geometry(voxel)
    assert g.line_weight.sum() == pytest.approx(1.0, abs=1e-12)  # Voronoi cells tile the sphere
    assert g.plane_weight.sum() == pytest.approx(1.0, abs=1e-12)
    # axis planes are spaced by the voxel edge; the plane family and its 2-D cell area recover the cell volume
    np.testing.assert_allclose(g.plane_spacing_um[:3], voxel, rtol=1e-14)
    assert g.cell_volume_um3 == pytest.approx(np.prod(voxel), rel=1e-14)


@pytest.mark.parametrize("adjacency", list(Adjacency))
@pytest.mark.parametrize("periodic", [True, False])
def test_phase_identities_hold_exactly(adjacency, periodic):
    # S_V(P) = S_V(M), K_V(P) = -K_V(M), φ(P) + φ(M) = 1, χ26(P) = χ6(M) by construction: no tolerance.
    v = _random_blobs((14, 12, 10), 7, p=0.4)
    ds = minkowski_functionals(v, (0.7, 1.0, 1.3), periodic, adjacency)
    pore, matrix = ds.sel(phase="pore"), ds.sel(phase="matrix")
    assert float(pore.S_V) == float(matrix.S_V)
    assert float(pore.K_V) == -float(matrix.K_V)
    assert float(pore.phi) + float(matrix.phi) == 1.0
    hist = configuration_histogram(v, periodic)
    assert hist @ W.euler_table(26) == matrix_histogram(hist) @ W.euler_table(6)
    assert hist @ W.euler_table(6) == matrix_histogram(hist) @ W.euler_table(26)
    if periodic:  # on the 3-torus the complementary-adjacency Euler numbers agree: χ(P) = χ(M) (Zauner §4.5)
        assert float(pore.chi) == float(matrix.chi)
        assert float(pore.T_V) == float(matrix.T_V)
