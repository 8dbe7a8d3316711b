"""Adaptive refinement (§7.5): the pure decision on synthetic data, and the driver loop with a fake workflow."""

import json

import numpy as np
import pytest
import yaml

from porepipe._shared.errors import PorepipeError
from porepipe.sweep import Outcome, _adaptive, decide, fit_power, predict_cost


def synthetic(a):
    """q(a) = 1 + 0.05·a^1.5 with a fixed deterministic wobble of ±1e-3: the limit's error shrinks as finer
    points add degrees of freedom and lever arm."""
    a = np.asarray(a, dtype=np.float64)
    wobble = 1e-3 * np.where(np.round(np.log2(a)) % 2 == 0, 1.0, -1.0)
    return 1.0 + 0.05 * a**1.5 + wobble


def loop(target, budget, cost_of=lambda a: (16.0 / a) ** 3, start=(16.0, 8.0, 4.0), max_rounds=20):
    a = list(start)
    history = []
    for rounds in range(max_rounds + 1):
        dec = decide(
            a,
            synthetic(a),
            [cost_of(x) for x in a],
            target_rel_err=target,
            budget=budget,
            exponent=None,
            rounds_done=rounds,
            max_rounds=max_rounds,
        )
        history.append((list(a), dec))
        if dec.outcome is not Outcome.refine:
            return history
        a.append(dec.next_a)
    return history


def test_stops_exactly_when_the_target_is_met():
    target = 0.003
    history = loop(target, budget=1e12)
    final = history[-1][1]
    assert final.outcome is Outcome.target_met
    assert len(history) >= 3  # the case needs refinement: the first rounds miss the target
    # independent check with the fit itself: every earlier round missed the target, the last one meets it
    for a, dec in history:
        lim = fit_power(a, synthetic(a))
        met = lim.supported and lim.rel_err <= target
        assert met == (dec is final), (a, lim)
    assert final.rel_err <= target


def test_budget_exhaustion_is_reported():
    target = 0.003
    needed = loop(target, budget=1e12)
    full_cost = sum((16.0 / x) ** 3 for x in needed[-1][0])
    history = loop(target, budget=full_cost / 2)
    final = history[-1][1]
    assert final.outcome is Outcome.budget_spent
    assert "budget spent before the target was met" in final.message
    # it stopped because the next run would not fit: spent + predicted > budget, and spent <= budget
    assert final.spent <= full_cost / 2 < final.spent + final.predicted_next


def test_voxel_budget_counts_voxels_exactly():
    # voxels ∝ a^-3: predicted voxels of the next run are exact
    assert predict_cost([4.0, 2.0], [1000.0, 8000.0], 1.0) == pytest.approx(64000.0, rel=1e-12)
    assert predict_cost([2.0], [8000.0], 1.0) == pytest.approx(64000.0, rel=1e-12)  # one run: k = 3


def test_max_rounds_stops_the_loop():
    history = loop(1e-6, budget=1e18, max_rounds=2)
    assert history[-1][1].outcome is Outcome.max_rounds and len(history) == 3


@pytest.mark.parametrize(
    "kwargs", [{"target_rel_err": 0.0, "budget": 1.0}, {"target_rel_err": 0.1, "budget": -1.0}]
)
def test_bad_settings_are_rejected(kwargs):
    with pytest.raises(PorepipeError):
        decide([2.0, 1.0], [1.0, 1.1], [1.0, 1.0], **kwargs)


def test_driver_refines_until_the_decision_stops(tmp_path, monkeypatch):
    # the driver writes scene copies with growing resolution lists; a fake runner plays the workflow
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.xyzr").write_text("50 50 50 20\n")
    scene = {
        "name": "adapt",
        "domain": {"size_um": [64, 64, 64]},
        "spheres": {"xyzr": "s.xyzr"},
        "resolutions_um": [16, 8, 4],
        "analyses": ["estimate"],
        "sweep": {
            "exponent": "free",
            "adaptive": {"quantity": "estimate.q", "target_rel_err": 0.003, "budget_voxels": 10**9},
        },
    }
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    runs = []

    def fake_runner(copy, target):
        raw = yaml.safe_load(copy.read_text())
        assert raw["spheres"]["xyzr"] == str((tmp_path / "s.xyzr").resolve())
        a = np.array(sorted(raw["resolutions_um"], reverse=True))
        runs.append(a.tolist())
        import xarray as xr

        ds = xr.Dataset(
            {
                "value": (("quantity", "a_um", "sample_um"), synthetic(a)[None, :, None]),
                "voxels": (("a_um", "sample_um"), ((64 / a) ** 3)[:, None]),
                "wall_s": (("quantity", "a_um", "sample_um"), np.ones((1, a.size, 1))),
                "upstream_wall_s": (("a_um", "sample_um"), np.ones((a.size, 1))),
            },
            coords={"quantity": ["estimate.q"], "a_um": a, "sample_um": [np.inf]},
        )
        from porepipe._shared.store import ResultWriter

        with ResultWriter(target, stage="sweep") as w:
            w.write_table(ds)

    dec = _adaptive.run_adaptive(path, runner=fake_runner)
    assert dec.outcome is Outcome.target_met
    assert runs[0] == [16, 8, 4] and runs[-1][-1] == pytest.approx(runs[0][-1] / 2 ** (len(runs) - 1))
    log = json.loads((tmp_path / "results/adapt/sweep/adaptive/decisions.json").read_text())
    assert [r["outcome"] for r in log] == ["refine"] * (len(runs) - 1) + ["target_met"]
