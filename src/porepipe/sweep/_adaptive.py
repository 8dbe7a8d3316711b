"""Adaptive refinement (Zauner 2020 §7.5): add the next finer resolution until the extrapolated error of one
quantity meets a target or the budget is spent.

:func:`decide` is the pure decision; :func:`run_adaptive` drives ``porepipe run`` for successive resolution lists.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

from porepipe._shared.errors import PorepipeError
from porepipe.sweep._fit import fit_power

#: cost exponent k in cost ∝ a^-k assumed with one run only (work ∝ voxels ∝ a^-3)
DEFAULT_COST_EXPONENT = 3.0
COST_EXPONENT_RANGE = (1.0, 6.0)


class Outcome(str, enum.Enum):
    """Why an adaptive sweep stops, or that it refines once more."""

    target_met = "target_met"
    budget_spent = "budget_spent"
    max_rounds = "max_rounds"
    refine = "refine"


@dataclasses.dataclass(frozen=True)
class Decision:
    """The adaptive sweep's decision after a round: outcome, next voxel size (µm), the limit q∞ and its error."""

    outcome: Outcome
    next_a: float | None
    q_inf: float
    err: float
    rel_err: float
    status: str
    spent: float
    predicted_next: float
    budget: float
    message: str

    def as_dict(self) -> dict:
        return {**dataclasses.asdict(self), "outcome": self.outcome.value}


def _check_runs(a_um, cost) -> tuple[np.ndarray, np.ndarray]:
    """Refuse no runs, resolutions not positive, finite and distinct, and costs not one finite value >= 0 each."""
    a = np.asarray(a_um, dtype=np.float64)
    c = np.asarray(cost, dtype=np.float64)
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a) & (a > 0)) or np.unique(a).size != a.size:
        raise PorepipeError(
            f"resolutions a_um need at least one positive, finite, distinct value, got {a.tolist()}"
        )
    if c.shape != a.shape or np.any(~np.isfinite(c)) or np.any(c < 0):
        raise PorepipeError(f"cost needs one finite non-negative value per resolution, got {c.tolist()}")
    return a, c


def predict_cost(a_um, cost, next_a: float) -> float:
    """Cost of a run at ``next_a`` from cost ∝ a^-k, k from the two finest runs (clamped to [1, 6]), else 3."""
    a, c = _check_runs(a_um, cost)
    if not 0 < next_a < np.inf:
        raise PorepipeError(f"the next resolution next_a must be positive and finite, got {next_a}")
    order = np.argsort(a)
    a, c = a[order], c[order]
    k = DEFAULT_COST_EXPONENT
    if a.size >= 2 and c[0] > 0 and c[1] > 0:
        k = float(np.clip(np.log(c[0] / c[1]) / np.log(a[1] / a[0]), *COST_EXPONENT_RANGE))
    return float(c[0] * (a[0] / next_a) ** k)


def decide(
    a_um,
    values,
    cost,
    *,
    target_rel_err: float,
    budget: float,
    exponent: float | None = None,
    confidence: float = 0.95,
    refine_factor: float = 2.0,
    rounds_done: int = 0,
    max_rounds: int | None = None,
) -> Decision:
    """Decide whether to stop or to add the next finer resolution.

    Parameters
    ----------
    a_um, values : (n,) array_like
        Resolutions run so far and the quantity at each.
    cost : (n,) array_like
        Cost of each run in the budget's unit (wall seconds, or voxels).
    target_rel_err : float
        Stop when the limit is supported and err(q∞)/|q∞| <= this.
    budget : float
        Total allowed cost; refinement stops when the runs so far plus the predicted next run would exceed it.

    Returns
    -------
    Decision
        ``target_met``, ``budget_spent``, ``max_rounds`` or ``refine`` (with ``next_a`` = finest / refine_factor).
    """
    if not 0 < target_rel_err < 1 or not budget > 0 or not refine_factor > 1:
        raise PorepipeError(
            f"adaptive mode needs 0 < target_rel_err < 1, budget > 0 and refine_factor > 1, got "
            f"{target_rel_err}, {budget}, {refine_factor}"
        )
    a, cost = _check_runs(a_um, cost)
    lim = fit_power(a, values, exponent=exponent, confidence=confidence)
    spent = float(cost.sum())
    next_a = float(a.min() / refine_factor)
    predicted = predict_cost(a, cost, next_a)
    state = (
        f"q_inf = {lim.text()} (rel. err {lim.rel_err:.3g}, target {target_rel_err:.3g}); "
        f"spent {spent:.4g} of {budget:.4g}"
    )

    def decision(outcome, nxt, msg):
        return Decision(
            outcome,
            nxt,
            lim.q_inf,
            lim.err,
            lim.rel_err,
            lim.status.value,
            spent,
            predicted,
            budget,
            f"{msg}: {state}",
        )

    if lim.supported and lim.rel_err <= target_rel_err:
        return decision(Outcome.target_met, None, "target met")
    if spent + predicted > budget:
        return decision(
            Outcome.budget_spent,
            None,
            f"budget spent before the target was met (next run at a = {next_a:g} would cost "
            f"~{predicted:.4g}, {budget - spent:.4g} left)",
        )
    if max_rounds is not None and rounds_done >= max_rounds:
        return decision(
            Outcome.max_rounds, None, f"stopped after {rounds_done} refinement round(s), target not met"
        )
    return decision(Outcome.refine, next_a, f"refine to a = {next_a:g}")


# -- driver -------------------------------------------------------------------------------------------------------------
def _scene_copy(raw: dict, scene_dir: Path, resolutions: list[float], path: Path) -> Path:
    copy = dict(raw)
    copy["resolutions_um"] = [float(a) for a in resolutions]
    spheres = dict(copy.get("spheres") or {})
    for key in ("xyzr", "hdf5"):
        if isinstance(spheres.get(key), str):
            spheres[key] = str((scene_dir / spheres[key]).resolve())
    if spheres:
        copy["spheres"] = spheres
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(copy, sort_keys=False))
    return path


def _running_copy(raw: dict, scene_dir: Path, resolutions: list[float], path: Path) -> Path:
    """The scene copy the workflow runs: one path, and its first modification time kept.

    Only ``resolutions_um`` changes between rounds, which no per-resolution job depends on; keeping the path and
    the mtime stops Snakemake from rerunning the resolutions already done (the gather rules still rerun, because
    their input lists grow).
    """
    stat = path.stat() if path.is_file() else None
    _scene_copy(raw, scene_dir, resolutions, path)
    if stat is not None:
        os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    return path


def _observed(sweep_path: Path, quantity: str, per_voxel: bool):
    from porepipe._shared.store import read_table

    ds = read_table(sweep_path)
    if quantity not in ds.quantity.values:
        raise PorepipeError(
            f"sweep.adaptive.quantity = {quantity!r} is not in {sweep_path}; "
            f"quantities there: {ds.quantity.values.tolist()}"
        )
    sel = ds.sel(quantity=quantity, sample_um=np.inf)
    keep = np.isfinite(sel.value.values)
    if per_voxel:
        cost = sel.voxels.values
    else:
        cost = np.nan_to_num(sel.wall_s.values) + np.nan_to_num(sel.upstream_wall_s.values)
    return sel.a_um.values[keep], sel.value.values[keep], np.nan_to_num(cost[keep])


def run_adaptive(scene_path, cores: int = 1, runner=None) -> Decision:
    """Run the scene, extrapolate ``sweep.adaptive.quantity``, and refine until :func:`decide` says stop.

    ``runner(scene_copy_path, target)`` runs the workflow (default: ``porepipe run`` with the sweep target).
    Each round's scene copy and the decisions are written under ``results/<scene>/sweep/adaptive/``.
    """
    from porepipe.scene import load_scene
    from porepipe.sweep._api import exponent_value

    scene_path = Path(scene_path)
    scene = load_scene(scene_path)
    settings = scene.sweep.adaptive
    if settings.quantity is None:
        raise PorepipeError(
            f"{scene_path}: sweep.adaptive.quantity is not set; name the quantity to converge"
        )
    per_voxel = settings.budget_s is None
    budget = float(settings.budget_voxels if per_voxel else settings.budget_s)
    raw = yaml.safe_load(scene_path.read_text())
    out_dir = Path("results", scene.name, "sweep", "adaptive")
    target = str(Path("results", scene.name, "sweep", "sweep.h5"))
    runner = runner or _porepipe_run(cores)
    resolutions = sorted(scene.resolutions_um, reverse=True)
    log = []
    for round_no in range(settings.max_rounds + 1):
        _scene_copy(raw, scene_path.parent, resolutions, out_dir / f"round{round_no}.yaml")  # the record
        runner(_running_copy(raw, scene_path.parent, resolutions, out_dir / "scene.yaml"), target)
        a, q, cost = _observed(Path(target), settings.quantity, per_voxel)
        dec = decide(
            a,
            q,
            cost,
            target_rel_err=settings.target_rel_err,
            budget=budget,
            exponent=exponent_value(scene.sweep.exponent),
            confidence=scene.sweep.confidence,
            refine_factor=settings.refine_factor,
            rounds_done=round_no,
            max_rounds=settings.max_rounds,
        )
        log.append({"round": round_no, "resolutions_um": resolutions, **dec.as_dict()})
        (out_dir / "decisions.json").write_text(json.dumps(log, indent=1, default=float))
        print(
            f"porepipe sweep --adaptive: round {round_no}, a = {resolutions}: {dec.message}", file=sys.stderr
        )
        if dec.outcome is not Outcome.refine:
            return dec
        resolutions = resolutions + [dec.next_a]
    return dec


def _porepipe_run(cores: int):
    def run(scene_copy: Path, target: str) -> None:
        from porepipe.cli import snakemake_command

        cmd = snakemake_command(scene_copy, cores, extra=[target])
        if subprocess.run(cmd, check=False).returncode != 0:
            raise PorepipeError(f"the workflow failed for {scene_copy} (command: {' '.join(cmd)})")

    return run
