"""``porepipe diffusion``: Knudsen diffusion of a binary volume along one axis."""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path

from porepipe._shared.errors import PorepipeError
from porepipe._shared.overrides import add_threads_option, merge_settings, seed_number
from porepipe.diffusion._settings import (
    MODES,
    Axis,
    InletLaw,
    Settings,
    Setup,
    SpeedDist,
    WallLaw,
    WallSpeed,
    readers_text,
    run_mode,
    used_by,
)

#: CLI option -> settings key, for the options that override the scene
_OVERRIDES = (
    "setup",
    "wall_law",
    "accommodation",
    "wall_speed",
    "inlet_law",
    "inlet_speed",
    "initial_speed",
    "species",
    "temperature_K",
    "target_rel_error",
    "max_wall_hits",
    "max_rounds",
    "batches",
    "batch_particles",
    "profile_bins",
    "hit_map_bins",
    "orientation_bins",
    "wk_time_jiffies",
    "msd_time_jiffies",
)


def _settings(args) -> tuple[Settings, int, str]:
    base, seed, name = {}, 0, ""
    if args.scene:
        from porepipe.scene import load_scene

        scene = load_scene(args.scene)
        base, seed, name = scene.diffusion.model_dump(), scene.seed, scene.name
    for key in _OVERRIDES:
        value = getattr(args, key, None)
        if value is not None:
            base[key] = value
    if args.seed is not None:
        seed = args.seed
    _nested_overrides(args, base)
    given = {
        _SETTING.get(dest, dest): _option(dest)
        for dest in (*_OVERRIDES, *_SETTING)
        if getattr(args, dest, None) is not None
    }
    settings = merge_settings(Settings, base, {}, "diffusion settings", options=given)
    _refuse_unused(args, settings)
    return settings, seed, name


#: options that set a nested setting: argparse dest -> its name in the settings (the others are named as the setting)
_SETTING = {
    "gas_particles": "gas.particles",
    "collisions": "gas.collisions",
    "duration_ps": "gas.duration_ps",
    "reaction_w": "reactions.w",
    "reaction_w_reverse": "reactions.w_reverse",
    "reaction_w_follow": "reactions.w_follow",
    "reaction_particles": "reactions.particles",
}
_CHECKPOINTED = ("transmission", "wicke_kallenbach", "msd")  # the runs that save their tallies (--checkpoint)
#: the setup-specific options, each with the modes that read it, from the settings' one table (_settings.USED_BY)
#: plus --checkpoint, which is no setting. An option given on the command line for a run of any other mode is
#: refused: it would be ignored without a word. Options every mode reads (--setup, --wall-law, --seed, --scene,
#: --threads, --axis, -o) are not listed, nor --resume, which the workflow passes to every run (a run without
#: checkpoints has nothing to resume).
_USED_BY = {
    dest: modes
    for dest in (*_OVERRIDES, "checkpoint", *_SETTING)
    if (modes := _CHECKPOINTED if dest == "checkpoint" else used_by(_SETTING.get(dest, dest)))
}


def _option(dest: str) -> str:
    return f"--{dest.replace('_', '-')}"


def _refuse_unused(args, settings: Settings) -> None:
    """One line naming the first option given on the command line that this run's mode does not read."""
    mode = run_mode(settings)
    for dest, modes in _USED_BY.items():
        if mode not in modes and getattr(args, dest, None) is not None:
            users = readers_text(modes)
            raise PorepipeError(
                f"{_option(dest)} is read only by {users}; this run is {MODES[mode]}, which would ignore it "
                "(leave it out, or choose a setup that uses it)"
            )


def _gas_particles(text: str) -> dict:
    counts = {}
    for item in text.split(","):
        name, _, number = item.partition("=")
        if not number.strip().isdigit():
            raise PorepipeError(f"--gas-particles wants SPECIES=N[,SPECIES=N], got {text!r}")
        counts[name.strip()] = int(number)
    return counts


def _nested_overrides(args, base: dict) -> None:
    """The options of nested settings (:data:`_SETTING`) laid over their sections of ``base``."""
    for option, setting in _SETTING.items():
        value = getattr(args, option, None)
        if value is not None:
            section, _, key = setting.partition(".")
            value = _gas_particles(value) if option == "gas_particles" else value
            base[section] = {**dict(base.get(section) or {}), key: value}


def _summary(v, settings: Settings) -> str:
    """One line of the headline figures of the setups edmd and reaction."""
    if settings.setup is Setup.edmd:
        d = f", D_self = {float(v['D_self_m2_s']):.4g} m^2/s" if "D_self_m2_s" in v else ""
        return (
            f"Z = {float(v['collision_rate']):.4g}/ps (Enskog {float(v['collision_rate_enskog']):.4g}), "
            f"lambda_eff = {float(v['lambda_eff_nm']):.4g} nm, Kn = {float(v['Kn']):.3g}{d}, "
            f"{int(v['events'])} events"
        )
    if "series_eta" in v:
        etas = ", ".join(f"{float(e):.3g}" for e in v["series_eta"].values)
        return f"study of {len(v['series_eta'])} sets, {int(v['runs'])} runs: eta = {etas}"
    eta = f"eta = {float(v['eta']):.4g} ± {float(v['eta_err']):.2g}, " if "eta" in v else ""
    phi = f"Phi = {float(v['phi']):.4g}, " if "phi" in v else ""
    return f"{eta}{phi}{int(v['products'])} products, {int(v['wall_hits'])} wall hits"


def _unmet(attrs, settings: Settings) -> str:
    """``; target NOT met: ...`` for a run of rounds that a limit stopped before ``target_rel_error``, else ``""``."""
    if "target_met" not in attrs or int(attrs["target_met"]):
        return ""
    rel = float(attrs["rel_error"])
    error = (
        f"relative error {rel:.2g} > target_rel_error {settings.target_rel_error:g}"
        if math.isfinite(rel)
        else f"no relative error to compare with target_rel_error {settings.target_rel_error:g} (it needs 2 rounds "
        "and a nonzero estimate)"
    )
    limits = dict.fromkeys(by for by in str(attrs["stopped_by"]).split(",") if by != "target_rel_error")
    return f"; target NOT met: {error}, stopped by " + ", ".join(
        f"{by} = {getattr(settings, by)}" for by in limits
    )


def _output(args, binary: Path, axis: str) -> Path:
    if args.out:
        return Path(args.out)
    match = re.search(r"_a([0-9.]+?)\.h5$", binary.name)
    tag = match.group(1) if match else binary.stem
    return binary.parent / f"diffusion_a{tag}_{axis}.h5"


def main(args) -> int:
    from porepipe.diffusion._run import run

    settings, seed, scene = _settings(args)
    from porepipe._shared.numba_config import set_threads

    threads = set_threads(args.threads)
    binary = Path(args.binary)
    out = _output(args, binary, args.axis)
    run(
        settings,
        binary,
        out,
        args.axis,
        seed=seed,
        scene=scene,
        threads=threads,
        checkpoint=args.checkpoint,
        resume=args.resume,
    )
    from porepipe._shared.store import read_attrs, read_table

    v = read_table(out)
    unmet = _unmet(read_attrs(out), settings)
    if settings.setup is Setup.surface:
        cov = ", ".join(
            f"{k[: -len('_coverage')]} {float(v[k]):.4g}" for k in v.data_vars if k.endswith("_coverage")
        )
        print(
            f"diffusion (surface): coverage {cov}; LH {int(v['lh_reactions'])}, ER {int(v['er_reactions'])} -> {out}"
        )
        return 0
    if settings.setup in (Setup.edmd, Setup.reaction):
        print(f"diffusion {args.axis} ({settings.setup.value}): {_summary(v, settings)} -> {out}")
        return 0
    if settings.lengths:
        print(
            f"diffusion {args.axis} (length series, {len(settings.lengths)} lengths): alpha = "
            f"{float(v['alpha']):.4g} ± {float(v['alpha_err']):.2g}, chi2/dof = {float(v['chi2_per_dof']):.3g}{unmet} -> {out}"
        )
        return 0
    head = f"W = {float(v['W']):.5g} ± {float(v['W_err']):.2g}, " if "W" in v else ""
    print(
        f"diffusion {args.axis} ({settings.setup.value}): {head}D = {float(v['D_m2_s']):.5g} "
        f"± {float(v['D_err_m2_s']):.2g} m^2/s, {int(v['wall_hits'])} wall hits{unmet} -> {out}"
    )
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "diffusion",
        help="gas in the pore space of a binary volume: Knudsen flights (transmission, Wicke-Kallenbach, msd), "
        "event-driven gas (edmd), wall reactions (reaction, surface)",
    )
    p.add_argument("binary", help="binary_a{a}.h5 (volume 'pore', 1 = pore)")
    p.add_argument("--axis", choices=[a.value for a in Axis], default="z", help="transport axis (default z)")
    p.add_argument("-o", "--out", help="result file; default diffusion_a{a}_{axis}.h5 beside the input")
    p.add_argument("--scene", help="scene YAML whose `diffusion` section and seed give the defaults")
    p.add_argument("--seed", type=seed_number, help="override the scene seed")
    add_threads_option(p)
    p.add_argument("--checkpoint", help="checkpoint file (default .{out}.checkpoint.npz)")
    p.add_argument(
        "--resume",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="continue from a matching checkpoint",
    )
    for name, enum in (
        ("setup", Setup),
        ("wall-law", WallLaw),
        ("wall-speed", WallSpeed),
        ("inlet-law", InletLaw),
        ("inlet-speed", SpeedDist),
        ("initial-speed", SpeedDist),
    ):
        p.add_argument(f"--{name}", dest=name.replace("-", "_"), choices=[e.value for e in enum])
    p.add_argument("--species")
    for name, kind in (
        ("accommodation", float),
        ("temperature-K", float),
        ("target-rel-error", float),
        ("max-wall-hits", int),
        ("max-rounds", int),
        ("batches", int),
        ("batch-particles", int),
        ("profile-bins", int),
        ("hit-map-bins", int),
        ("orientation-bins", int),
        ("wk-time-jiffies", float),
        ("msd-time-jiffies", float),
    ):
        p.add_argument(f"--{name}", dest=name.replace("-", "_"), type=kind)
    p.add_argument("--gas-particles", help="setup edmd: particles per species, e.g. N2=1000,He=200")
    p.add_argument(
        "--collisions",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="setup edmd: gas-gas collisions (--no-collisions: Knudsen regime, point particles)",
    )
    for name, kind, meaning in (
        ("duration-ps", float, "setup edmd: simulated time in ps"),
        ("reaction-w", float, "setup reaction: probability that a wall hit turns A into P"),
        ("reaction-w-reverse", float, "setup reaction: probability that a wall hit turns P back into A"),
        (
            "reaction-w-follow",
            float,
            "setup reaction: probability that a wall hit turns P into S (A -> P -> S)",
        ),
        ("reaction-particles", int, "setup reaction: reactant histories (each enters at the inlet face)"),
    ):
        p.add_argument(f"--{name}", dest=name.replace("-", "_"), type=kind, help=meaning)
    p.epilog = (
        "Options that only some setups read (given for another, they are refused; length_series = transmission "
        "with diffusion.lengths, reaction_study = reaction with diffusion.reactions.series): "
    ) + "; ".join(f"{_option(dest)}: {', '.join(modes)}" for dest, modes in _USED_BY.items())
    p.set_defaults(func=main)
    register_capillary(subparsers)


def main_capillary(args) -> int:
    from porepipe.diffusion._capillary import write_capillary
    from porepipe.scene import load_scene

    scene = load_scene(args.scene)
    geometry = scene.diffusion.geometry
    if geometry is None:
        raise PorepipeError(f"{args.scene}: the scene has no diffusion.geometry to build a capillary from")
    out = write_capillary(geometry, args.a, args.out, seed=scene.seed, scene=scene.name)
    print(f"capillary {geometry.kind.value} at a = {args.a} µm -> {out}")
    return 0


def register_capillary(subparsers) -> None:
    """``porepipe diffusion-capillary``: write the scene's ``diffusion.geometry`` as a binary volume."""
    p = subparsers.add_parser(
        "diffusion-capillary",
        help="write the scene's synthetic capillary (diffusion.geometry) as binary_a{a}.h5",
    )
    p.add_argument("--scene", required=True, help="scene YAML with a diffusion.geometry")
    p.add_argument("--a", type=float, required=True, help="resolution (voxel edge) in µm")
    p.add_argument("-o", "--out", required=True, help="output binary_a{a}.h5")
    p.set_defaults(func=main_capillary)
