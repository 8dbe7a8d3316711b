"""Length series of the Knudsen resistance (Mahler 2001 §3.6.4, eq. 3.51): the α fit and a run against Clausing.

Truths: the weighted fit returns α and D₀ of an exact line; a voxelised Lambert cylinder (R = 8) at L/R = 1, 2, 4
gives the α that Clausing's exact transmission probabilities (digest §5.4: 0.671, 0.514, 0.358) give through the same
fit; the report section puts the thesis's α = 8.55 and the literature's 2.9 beside porepipe's, never its own.
"""

import numpy as np
import pytest
from pydantic import ValidationError

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter
from porepipe.diffusion import Settings, cylinder, fit_length_series, length_series, square_capillary
from porepipe.diffusion._api import DiffusionResult
from porepipe.diffusion._run import _dataset
from porepipe.report._length_series import parts, series_rows

CLAUSING = {1: 0.671, 2: 0.514, 4: 0.358}


def test_fit_recovers_an_exact_line():
    x = np.array([0.5, 0.2, 0.1, 0.02])
    d0, alpha = 3.0, 2.9
    d = d0 / (1.0 + alpha * x)
    fit = fit_length_series(x, d, 1e-3 * d)
    assert fit["alpha"] == pytest.approx(alpha, rel=1e-10) and fit["D0"] == pytest.approx(d0, rel=1e-10)
    assert fit["chi2_per_dof"] < 1e-12 and fit["alpha_err"] > 0
    for bad in ((x[:1], d[:1], d[:1]), (x, -d, d), ([0.1, 0.1], [1.0, 2.0], [0.1, 0.1])):
        with pytest.raises(PorepipeError, match="length series"):
            fit_length_series(*bad)


def test_lambert_cylinder_series_gives_clausings_alpha():
    """Tolerance: 4 σ of our α plus 3 % for the staircase wall (the voxelised tube's W lies within 0.1-0.7 % of
    Clausing's, which moves α by a few per cent through the fit's near-cancellation)."""
    settings = Settings(wall_law="lambert", inlet_law="lambert", target_rel_error=0.005, batch_particles=256)
    out = length_series(cylinder(8, 32).pore, 2, [8, 16, 32], settings, seed=1)
    lr = np.array([1.0, 2.0, 4.0])
    w = np.array([CLAUSING[k] for k in lr])
    np.testing.assert_allclose(out["series_W"], w, atol=4 * out["series_W_err"].max() + 0.007)
    x = out["r_equal_area"] / (8.0 * lr)  # our r (area-equivalent radius of the voxelised disk) on both sides
    ref = fit_length_series(x, lr * w / 4.0, 1e-4 * lr * w)
    assert abs(out["alpha"] - ref["alpha"]) <= 4 * out["alpha_err"] + 0.03 * ref["alpha"]
    with pytest.raises(PorepipeError, match="lengths"):
        length_series(cylinder(8, 32).pore, 2, [8, 64], settings)


def test_settings_refuse_lengths_without_transmission_or_with_one_length():
    with pytest.raises(ValidationError, match="needs setup transmission"):
        Settings(setup="reaction", lengths=[4, 8])
    with pytest.raises(ValidationError, match="lengths must be"):
        Settings(lengths=[4])


def test_report_section_puts_thesis_and_literature_beside_porepipe(tmp_path):
    settings = Settings(
        wall_law="isotropic", target_rel_error=0.05, batch_particles=64, lengths=[3, 6, 12, 24]
    )
    series = length_series(square_capillary(3, 24).pore, 2, settings.lengths, settings, seed=2)
    arrays = {k: series.pop(k) for k in list(series) if k.startswith("series_")}
    folder = tmp_path / "diffusion"
    folder.mkdir()
    with ResultWriter(folder / "diffusion_a1_z.h5", stage="diffusion", scene="t") as w:
        w.write_table(_dataset(DiffusionResult("length_series", "z", series, arrays), settings))
    rows = series_rows(folder / "diffusion_a1_z.h5")
    assert [r["length"] for r in rows] == [3, 6, 12, 24]
    assert rows[-1]["W"] == arrays["series_W"][-1]
    html = "".join(parts(folder, tmp_path))
    assert f"{series['alpha']:.3f} ± {series['alpha_err']:.3f}" in html
    assert "<td class=l>8.55</td>" in html and "<td class=l>2.9</td>" in html
    assert (tmp_path / "length_series.csv").read_text().count("\n") == 5
    assert parts(tmp_path / "none", tmp_path) == []
