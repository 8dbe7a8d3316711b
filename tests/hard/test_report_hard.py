"""Report hard cases: quantity names and clocks that are not in the sweep, a sweep of sub-samples only, runs of
unknown cost or error on the Pareto front."""

import numpy as np
import pytest
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_table
from porepipe.report import (
    build_report,
    cost_per_digit,
    error_cost_table,
    pareto_front,
    reference_limit,
    runs_of,
    varying_quantities,
)
from porepipe.report._settings import Settings
from porepipe.sweep import build_sweep

A_UM = (4.0, 2.0, 1.0, 0.5)


def _sweep(root, sample: str = ""):
    """sweep.h5 of eng_a{a}{sample}.h5 with φ = 0.35 + 0.02 a (one quantity per phase) and of
    diffusion_a{a}_z{sample}.h5 with W = 0.5 + 0.1 a."""
    results = []
    for a in A_UM:
        phi = 0.35 + 0.02 * a
        path = root / "eng" / f"eng_a{a:g}{sample}.h5"
        with ResultWriter(path, stage="eng", scene="t", threads=1) as w:
            w.write_table(
                xr.Dataset({"phi": ("phase", [phi, 1 - phi])}, coords={"phase": ["pore", "matrix"]})
            )
        results.append(path)
        path = root / "diffusion" / f"diffusion_a{a:g}_z{sample}.h5"
        with ResultWriter(path, stage="diffusion", scene="t", threads=1) as w:
            w.write_table(xr.Dataset({"W": ((), 0.5 + 0.1 * a)}))
        results.append(path)
    with ResultWriter(root / "sweep" / "sweep.h5", stage="sweep", scene="t") as w:
        w.write_table(build_sweep(results))
    return root / "sweep" / "sweep.h5"


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    return _sweep(tmp_path_factory.mktemp("report"))


@pytest.mark.parametrize(
    "call",
    [
        lambda ds: reference_limit(ds, "eng.phi"),
        lambda ds: runs_of(ds, "eng.phi"),
        lambda ds: error_cost_table(ds, ["eng.phi[pore]", "eng.phi"]),
        lambda ds: varying_quantities(ds, ["eng.phi"], 12),
    ],
    ids=["reference_limit", "runs_of", "error_cost_table", "varying_quantities"],
)
def test_a_quantity_not_in_the_sweep_is_one_line_naming_it_and_the_allowed(call, sweep):
    """xarray's KeyError 'not all values found in index' before; varying_quantities dropped an unknown name silently
    (the page then said 'No quantity changes with resolution')."""
    with pytest.raises(
        PorepipeError,
        match=r"eng\.phi: not in the sweep; allowed: diffusion_z\.W, eng\.phi\[matrix\], eng\.phi\[pore\]",
    ):
        call(read_table(sweep))


def test_an_unknown_clock_and_a_bare_string_are_refused(sweep):
    ds = read_table(sweep)
    with pytest.raises(PorepipeError, match=r"clock = 'gpu'; allowed: wall, cpu"):  # KeyError 'gpu' before
        error_cost_table(ds, ["eng.phi[pore]"], "gpu")
    with pytest.raises(PorepipeError, match="give a list of names"):  # iterated letter by letter before
        error_cost_table(ds, "eng.phi[pore]")


def test_a_misspelt_report_quantity_writes_nothing(sweep, tmp_path):
    with pytest.raises(PorepipeError, match="report.quantities eng.phi: not in the sweep"):
        build_report(sweep, tmp_path / "report" / "index.html", settings=Settings(quantities=["eng.phi"]))
    assert list(tmp_path.iterdir()) == []


def test_a_sweep_of_sub_samples_only_gets_its_report(tmp_path):
    """A sweep of eng_a{a}_L20.h5 alone has no whole sample: xarray's KeyError on sample_um = inf escaped the report."""
    sweep = _sweep(tmp_path, "_L20")
    ds = read_table(sweep)
    assert list(ds.sample_um.values) == [20.0]
    assert reference_limit(ds, "eng.phi[pore]") is None  # no whole-sample limit
    assert reference_limit(ds, "eng.phi[pore]", 20.0).value == pytest.approx(
        0.35, rel=1e-9
    )  # exact linear data
    page = build_report(sweep, tmp_path / "report" / "index.html", settings=Settings(dpi=30, slices=False))
    assert "<h2>Limits a → 0</h2>" in page.read_text()


def test_runs_of_unknown_cost_or_error_stay_off_the_front_and_the_slope():
    """A NaN cost was put on the Pareto front (first, cheapest); an infinite error raised numpy's 'invalid value
    encountered in divide' in the fit (an error under pytest). Left out, the other runs give ×10 per digit (exact
    data, rel 1e-9 for the fit's round-off)."""
    cost = np.array([np.nan, 1.0, 10.0, 100.0, 5.0])
    err = np.array([1e-9, 1e-1, 1e-2, 1e-3, np.inf])
    assert pareto_front(cost, err).tolist() == [1, 2, 3]
    assert cost_per_digit(cost, err) == pytest.approx(10.0, rel=1e-9)
    assert cost_per_digit([1.0, 10.0, np.inf], [1e-1, 1e-2, 1e-3]) == pytest.approx(10.0, rel=1e-9)


@pytest.mark.parametrize("call", [pareto_front, cost_per_digit])
def test_cost_and_error_of_different_lengths_are_one_line(call):
    """numpy's 'all keys need to be the same shape' or 'operands could not be broadcast' before."""
    with pytest.raises(PorepipeError, match=r"got shapes \(3,\) and \(2,\)"):
        call([1.0, 2.0, 3.0], [0.1, 0.01])


def test_a_sweep_without_cost_columns_is_one_line_and_without_threads_still_a_report(sweep, tmp_path):
    """A hand-made sweep without its cost columns raised AttributeError deep in the page ('numpy.int64' has no
    'values': ``ds.threads`` fell back to the file's attribute); without the cost columns it is now refused in one line
    naming them, without the per-run threads it gets its page ('not recorded')."""
    ds = read_table(sweep)
    for name, drop in (("nocost", ["wall_s", "cpu_s"]), ("nothreads", ["threads"])):
        with ResultWriter(tmp_path / name / "sweep.h5", stage="sweep", scene="t") as w:
            w.write_table(ds.drop_vars(drop))
    with pytest.raises(PorepipeError, match=r"is not a sweep result \(no wall_s, cpu_s\)"):
        build_report(tmp_path / "nocost" / "sweep.h5", tmp_path / "nocost" / "report" / "index.html")
    assert not (tmp_path / "nocost" / "report").exists()
    page = build_report(
        tmp_path / "nothreads" / "sweep.h5",
        tmp_path / "nothreads" / "report" / "index.html",
        settings=Settings(dpi=30, slices=False),
    )
    assert "not recorded" in page.read_text()


def test_the_report_of_a_heap_too_small_to_measure_is_still_written(tmp_path):
    """The CI heap shrunk to 21 grains (a user's first smaller scene): its report job failed on 'repose_angle_fit:
    fewer than 2 occupied intervals', and the run with it; the page now says why the heap was not measured and shows
    the rest (fabric, force network)."""
    from pathlib import Path

    import yaml

    from porepipe.granular import run
    from porepipe.report._granular import granular_report
    from porepipe.scene import parse_scene

    raw = yaml.safe_load((Path(__file__).parents[2] / "config/scenes/granular-heap-ci.yaml").read_text())
    raw["granular"]["duration_s"] = 0.3
    raw["granular"]["drop_sources"][0]["to_s"] = 0.2
    scene = parse_scene(raw)
    result = run(scene.granular, tmp_path / "granular.h5", seed=scene.seed, progress=False)
    page = granular_report(result, tmp_path / "index.html", kind="heap").read_text()
    assert "Heap not measured: repose_angle_fit: fewer than 2 occupied intervals" in page
    assert "granular_network.png" in page and (tmp_path / "granular_network.png").is_file()


@pytest.mark.parametrize("a_max", [1.0, 1e20])
@pytest.mark.parametrize("p", [0.2, 1.0, 2.5, 6.0])
def test_the_fitted_curve_is_c_a_to_the_p_to_round_off_where_nothing_overflows(a_max, p):
    from porepipe.report._figures import power_term

    grid = np.linspace(0.0, a_max, 100)
    c = 0.02 / a_max**p  # the term is 0.02 at the largest a, whatever the unit
    got = power_term(grid, c, p)
    np.testing.assert_allclose(got, c * grid**p, rtol=1e-13, atol=0)  # a few ulps of reordering
    assert got[0] == 0.0 and got[-1] == pytest.approx(0.02, rel=1e-13)
    assert np.all(power_term(grid, 0.0, p) == 0.0)


@pytest.mark.parametrize(
    ("a_max", "p", "c"), [(4e60, 5.5, 1e-306), (4e60, 6.0, -1e-300), (1e-60, 6.0, 1e300)]
)
def test_the_fitted_curve_does_not_overflow_where_c_a_to_the_p_is_representable(a_max, p, c):
    # before: c * grid**p took grid**p first, inf beyond 1e308 (a curve of inf with numpy's overflow warning), or 0
    # below 1e-308 (a flat curve) where c * grid**p is ~1e28 (~1e-60)
    from porepipe.report._figures import power_term

    grid = np.linspace(0.0, a_max, 100)
    truth = np.sign(c) * np.exp(
        np.log(abs(c)) + p * np.log(grid[1:])
    )  # logarithms: no overflow; rtol ~ 700 eps
    got = power_term(grid, c, p)
    assert got[0] == 0.0
    np.testing.assert_allclose(got[1:], truth, rtol=1e-12, atol=0)


def test_the_quantities_figure_of_a_quantity_fitted_over_shorter_lengths_than_the_sweep_draws(tmp_path):
    # the sweep's a reaches 4e60 µm (engine "wide"), quantity "short.q" is measured up to 1e55 µm only, with p = 5.5:
    # its fit is representable (c ~ 1e-305), but the figure's grid runs to 4e60 µm, where grid**p is 1e333
    from porepipe._shared.naming import res_tag
    from porepipe.report._figures import quantities_figure

    results = []
    for engine, scale, a_list in (
        ("wide", 1e60, (4.0, 2.0, 1.0)),
        ("short", 1e55, (1.0, 0.8, 0.6, 0.4, 0.3)),
    ):
        for a in a_list:
            path = tmp_path / engine / f"{engine}_a{res_tag(a * scale)}.h5"
            with ResultWriter(path, stage=engine, scene="t", threads=1) as w:
                w.write_table(
                    xr.Dataset({"q": ((), 0.35 + 0.001 * a ** (5.5 if engine == "short" else 1.0))})
                )
            results.append(path)
    ds = build_sweep(results)
    assert reference_limit(ds, "short.q").form == "power"
    rows = quantities_figure(
        ds, ["short.q"], tmp_path / "f.png", 40
    )  # pytest turns numpy's warning into an error
    assert (tmp_path / "f.png").is_file() and rows[-1]["a_um"] == 0.0
