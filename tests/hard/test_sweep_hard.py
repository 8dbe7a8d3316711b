"""Degenerate and extreme inputs to the sweep: finite answers or a clear PorepipeError, never NaN as a number."""

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_attrs
from porepipe.sweep import (
    Status,
    build_sweep,
    corner_voxels,
    decide,
    fit_power,
    limit_of,
    predict_cost,
    subsample_offsets,
    two_point_limit,
)


def test_converged_constant_data_give_the_value_with_zero_error():
    lim = fit_power([4.0, 2.0, 1.0, 0.5], [0.3] * 4)
    assert (
        lim.status is Status.ok
        and lim.q_inf == pytest.approx(0.3, abs=1e-15)
        and lim.err == pytest.approx(0.0)
    )


@pytest.mark.parametrize("scale", [1e-300, 1e300])
def test_extreme_magnitudes_stay_finite(scale):
    a = np.array([8.0, 4.0, 2.0, 1.0, 0.5])
    lim = fit_power(a, scale * (1.0 + 0.1 * a), exponent=1.0)
    assert lim.q_inf / scale == pytest.approx(1.0, rel=1e-9) and np.isfinite(lim.err)


def test_tiny_voxel_sizes():
    a = np.array([8e-9, 4e-9, 2e-9, 1e-9])
    lim = fit_power(a, 2.0 + 1e7 * a**1.3)
    assert lim.q_inf == pytest.approx(2.0, abs=1e-6) and lim.p == pytest.approx(1.3, rel=1e-4)


def test_missing_runs_are_dropped_not_fitted():
    lim = limit_of([4.0, 2.0, 1.0, 0.5], [1.4, np.nan, 1.1, 1.05], exponent=1.0)
    assert lim.n == 3 and np.isfinite(lim.q_inf)
    assert limit_of([4.0, 2.0], [np.nan, np.nan], None).status is Status.too_few_points


def test_zero_cost_runs_fall_back_to_the_voxel_scaling():
    assert predict_cost([2.0, 1.0], [0.0, 0.0], 0.5) == 0.0
    dec = decide([4.0, 2.0, 1.0], [1.3, 1.1, 1.0], [0.0, 0.0, 0.0], target_rel_err=1e-9, budget=1.0)
    assert dec.outcome.value == "refine" and dec.next_a == 0.5


@pytest.mark.parametrize("cost", [[1.0, np.nan], [1.0, -2.0], [1.0]])
def test_bad_costs_are_rejected(cost):
    with pytest.raises(PorepipeError, match="cost"):
        decide([2.0, 1.0], [1.0, 1.1], cost, target_rel_err=0.1, budget=10.0)


def test_a_file_that_is_not_a_result_is_named(tmp_path):
    bad = tmp_path / "junk_a1.h5"
    bad.write_bytes(b"not hdf5")
    with pytest.raises(PorepipeError, match="junk_a1.h5"):
        build_sweep([bad])
    with pytest.raises(PorepipeError, match="does not exist"):
        build_sweep([tmp_path / "missing_a1.h5"])


def test_infinite_quantity_is_not_extrapolated(tmp_path):
    paths = []
    for a, v in ((2.0, np.inf), (1.0, 3.0), (0.5, 2.0), (0.25, 1.5)):
        with ResultWriter(tmp_path / f"e_a{a:g}.h5", stage="e") as w:
            w.write_table(xr.Dataset({"k": ((), v)}))
        paths.append(tmp_path / f"e_a{a:g}.h5")
    ds = build_sweep(paths)
    sel = ds.sel(quantity="e.k", form="linear", sample_um=np.inf)
    assert int(sel.n) == 3 and np.isfinite(float(sel.q_inf))


_A, _Q = [2.0, 1.0, 0.5, 0.25], [2.0, 1.5, 1.2, 1.1]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"exponent": float("nan")}, "exponent p"),  # before: status ok with q_inf = NaN
        ({"exponent": -1.0}, "exponent p"),  # before: status ok for a curve that diverges as a -> 0
        ({"exponent": 0.0}, "exponent p"),  # a^0 = 1 cannot be told from q_inf
        ({"exponent": 2000.0}, r"exponent p .* must lie in \[0.2, 6.0\]"),  # before: OverflowError of a^p
        ({"confidence": 1.0}, "confidence"),  # before: status ok with err = NaN
        ({"confidence": 0.0}, "confidence"),  # before: status ok with err = 0
        ({"sigma": float("inf")}, "sigma"),  # before: RuntimeWarning and NaN weights
        ({"sigma": [1.0, 2.0]}, "sigma"),  # before: numpy's broadcast ValueError
    ],
)
def test_fit_power_refuses_parameters_without_a_meaning(kwargs, match):
    with pytest.raises(PorepipeError, match=match):
        fit_power(_A, _Q, **kwargs)


def test_two_point_limit_refuses_an_infinite_ratio():
    with pytest.raises(PorepipeError, match="ratio"):  # before: NaN returned
        two_point_limit(1.0, 2.0, float("inf"))


@pytest.mark.parametrize(
    "edge_um, voxel_um", [(2.0, 0.0), (2.0, float("nan")), (float("inf"), 1.0), (0.0, 1.0), (-2.0, 1.0)]
)
def test_corner_cube_refuses_a_bad_voxel_size_or_edge(edge_um, voxel_um):
    # before: ZeroDivisionError, "cannot convert float NaN to integer", OverflowError; an edge of 0 or below was
    # "not a whole number of voxels"
    with pytest.raises(PorepipeError, match="must both be positive and finite"):
        corner_voxels(edge_um, voxel_um, (10, 10, 10))


def test_subsample_cube_larger_than_the_volume_is_refused():
    # before: offsets (-10, -10, -10), i.e. a cube cut from outside the volume
    with pytest.raises(PorepipeError, match="does not fit the volume shape"):
        subsample_offsets(7, 8, 20, (10, 10, 10))


@pytest.mark.parametrize(
    "a_um, cost, next_a, match",
    [
        ([], [], 0.5, "at least one"),  # before: IndexError
        ([2.0, -1.0], [1.0, 2.0], 0.5, "positive, finite, distinct"),  # before: RuntimeWarning of log
        ([1.0, 1.0], [1.0, 2.0], 0.5, "positive, finite, distinct"),  # before: divide by zero
        ([2.0, 1.0], [1.0], 0.5, "one finite non-negative value per resolution"),  # before: IndexError
        ([2.0, 1.0], [1.0, 2.0], 0.0, "next_a must be positive and finite"),  # before: divide by zero
        ([2.0, 1.0], [1.0, 2.0], float("nan"), "next_a must be positive and finite"),  # before: NaN
    ],
)
def test_predict_cost_refuses_runs_it_cannot_scale_from(a_um, cost, next_a, match):
    with pytest.raises(PorepipeError, match=match):
        predict_cost(a_um, cost, next_a)


def test_decide_without_runs_is_refused():
    with pytest.raises(PorepipeError, match="a_um need at least one"):  # before: numpy's zero-size ValueError
        decide([], [], [], target_rel_err=0.1, budget=10.0)


def _limit_files(tmp_path):
    paths = []
    for a, v in zip(_A, _Q):
        with ResultWriter(tmp_path / f"e_a{a:g}.h5", stage="e") as w:
            w.write_table(xr.Dataset({"k": ((), v)}))
        paths.append(str(tmp_path / f"e_a{a:g}.h5"))
    return paths


def test_sweep_options_win_over_the_scene_and_are_checked_as_its_keys(tmp_path, capsys):
    # before: with --scene, --exponent and --confidence were dropped without a word (the file said free, 0.95), and
    # without it --confidence 0.3 went through although a scene's sweep.confidence must be above 0.5
    from porepipe.cli import main

    scene = Path(__file__).resolve().parents[2] / "config" / "scenes" / "mini.yaml"
    out = tmp_path / "sweep.h5"
    argv = ["sweep", *_limit_files(tmp_path), "-o", str(out)]
    assert main([*argv, "--scene", str(scene), "--exponent", "linear", "--confidence", "0.9"]) == 0
    attrs = read_attrs(out)
    assert (attrs["exponent"], np.ravel(attrs["confidence"]).tolist(), attrs["scene"]) == (
        "linear",
        [0.9],
        "mini",
    )
    out.unlink()
    capsys.readouterr()
    assert main([*argv, "--confidence", "0.3"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert (
        line == "porepipe sweep: error: sweep options: --confidence = 0.3: Input should be greater than 0.5"
    )
    assert not out.exists()


@pytest.mark.parametrize("scale", [1e-100, 1e100])
def test_a_fit_coefficient_beyond_float64_is_refused_in_one_line(scale):
    # before: Python's float power raised a bare ZeroDivisionError (1e-100) or OverflowError (1e100) out of the sweep
    a = np.array([2.0, 1.0, 0.5, 0.25]) * scale
    with pytest.raises(PorepipeError, match="beyond float64 in the data's own units"):
        fit_power(a, 0.1 + 3.0 * (a / scale) ** 4, exponent=4)


@pytest.mark.parametrize("scale", [1e-20, 1.0, 1e20])
def test_the_fit_coefficient_of_exact_data_is_exact_at_any_representable_scale(scale):
    a = np.array([2.0, 1.0, 0.5, 0.25]) * scale
    limit = fit_power(a, 0.1 + 3.0 * (a / scale) ** 2, exponent=2)
    assert limit.q_inf == pytest.approx(0.1, rel=1e-12)
    assert limit.c == pytest.approx(3.0 / scale**2, rel=1e-12)  # q = q_inf + c a^2 exactly
