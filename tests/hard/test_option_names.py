"""A bad value laid over a scene's settings from the command line is named by the option the user typed.

Before, ``porepipe acquire IMG --phases a b c`` said ``acquire settings: segmentation = {...}`` and ``porepipe
diffusion --reaction-w 2`` said ``reactions.w = 2.0``: keys of a scene the user never wrote. Every stage merges
through ``porepipe._shared.overrides.merge_settings``, which now names a problem by the option that gave its key,
and by the scene key where the value came from the scene.
"""

import re

import numpy as np
import pytest
import yaml

from porepipe.cli import main

#: a valid scene that each test extends by one section
_SCENE = {
    "name": "t",
    "domain": {"size_um": [10, 10, 10]},
    "spheres": {"inline": [[5, 5, 5, 2]]},
    "resolutions_um": [1.0],
}

#: (subcommand and its arguments, the bad option as typed, the start of its one-line reason, a scene section with
#: the same bad value, the scene key that a scene's problem names)
_CASES = [
    (
        ["lpt", "b.h5"],
        ["--cell-voxels", "0", "3"],
        "--cell-voxels[0] = 0: Input should be",
        {"lpt": {"cell_voxels": [0, 3]}},
        "lpt.cell_voxels[0]",
    ),
    (
        ["minkowski", "b.h5"],
        ["--slab-planes", "0"],
        "--slab-planes = 0: Input should be",
        {"minkowski": {"slab_planes": 0}},
        "minkowski.slab_planes",
    ),
    (
        ["permeability", "b.h5"],
        ["--tau", "0.4"],
        "--tau = 0.4: Input should be",
        {"permeability": {"tau": 0.4}},
        "permeability.tau",
    ),
    (
        ["sweep", "e.h5"],
        ["--confidence", "0.3"],
        "--confidence = 0.3: Input should be",
        {"sweep": {"confidence": 0.3}},
        "sweep.confidence",
    ),
    (
        ["diffusion", "b.h5"],
        ["--accommodation", "2"],
        "--accommodation = 2.0: Input should be",
        {"diffusion": {"accommodation": 2}},
        "diffusion.accommodation",
    ),
    (
        ["diffusion", "b.h5", "--setup", "reaction"],
        ["--reaction-w", "2"],
        "--reaction-w = 2.0: Input should be",
        {"diffusion": {"setup": "reaction", "reactions": {"w": 2}}},
        "diffusion.reactions.w",
    ),
    (
        ["diffusion", "b.h5", "--setup", "edmd"],
        ["--gas-particles", "N2=0"],
        "--gas-particles = {'N2': 0}: the gas needs at least one particle",
        {"diffusion": {"setup": "edmd", "gas": {"particles": {"N2": 0}}}},
        "diffusion.gas.particles",
    ),
    (
        ["acquire", "i.npy"],
        ["--voxel-um", "-1"],
        "--voxel-um = -1.0: Input should be",
        {"acquire": {"voxel_um": -1}},
        "acquire.voxel_um",
    ),
    (
        ["acquire", "i.npy"],
        ["--raw-header", "-3"],
        "--raw-header = -3: Input should be",
        {"acquire": {"raw": {"header_bytes": -3, "shape": [2, 2, 2]}}},
        "acquire.raw.header_bytes",
    ),
    (
        ["acquire", "i.npy"],
        ["--crop", "0", "2", "2"],
        "--crop[0] = 0: Input should be",
        {"acquire": {"crop": {"size": [0, 2, 2]}}},
        "acquire.crop.size[0]",
    ),
    (
        ["acquire", "i.npy"],
        ["--phases", "a", "b", "c"],
        "--phases = ['a', 'b', 'c']: pore_phases ['pore'] must be a non-empty subset of phases ['a', 'b', 'c']",
        {"acquire": {"segmentation": {"phases": ["a", "b", "c"]}}},
        "acquire.segmentation",
    ),
]


def _error_lines(argv, capsys) -> list[str]:
    assert main(argv) == 2
    return capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize(
    "command,option,reason,section,scene_key", _CASES, ids=[" ".join(c[1]) for c in _CASES]
)
def test_a_bad_option_is_named_as_typed_and_a_bad_scene_key_as_written(
    tmp_path, capsys, command, option, reason, section, scene_key
):
    """From the command line: one line whose problem is named by the option and its value (not by a settings key
    the user never wrote), and no result file. The same value in the scene: its problem names the scene key, no
    option."""
    out = tmp_path / "out.h5"
    (line,) = _error_lines([*command, "-o", str(out), *option], capsys)
    assert re.fullmatch(
        rf"porepipe {command[0]}: error: [a-z]+ (settings|options): {re.escape(reason)}.*", line
    ), line
    assert not out.exists()

    scene = tmp_path / "s.yaml"
    scene.write_text(yaml.safe_dump({**_SCENE, **section}))
    lines = _error_lines([*command, "--scene", str(scene), "-o", str(out)], capsys)
    assert any(text.startswith(f"  - {scene_key} = ") for text in lines), lines
    assert not any(option[0] in text for text in lines), lines
    assert not out.exists()


def test_a_check_across_keys_names_the_options_its_message_names(tmp_path, capsys):
    """``--method thresholds --thresholds 5 3 --phases a b c --pore-phases a``: the thresholds are not ascending; the
    problem is the section's, and its message names method and thresholds, so those options name it, not
    --phases."""
    out = tmp_path / "out.h5"
    argv = ["acquire", "i.npy", "-o", str(out), "--method", "thresholds", "--thresholds", "5", "3"]
    (line,) = _error_lines([*argv, "--phases", "a", "b", "c", "--pore-phases", "a"], capsys)
    assert line.endswith(
        "acquire settings: --method = 'thresholds', --thresholds = [5.0, 3.0]: method thresholds needs 2 ascending "
        "thresholds, got [5.0, 3.0]"
    )


def test_an_option_that_clashes_with_the_scene_is_named_by_the_option(tmp_path, capsys):
    """The scene sets method thresholds with one threshold (two phases: valid); ``--phases a b c`` then needs two.
    The message names the options given in the section (its reason names none of them), not the scene's keys (they
    are in the reason)."""
    np.save(tmp_path / "i.npy", np.arange(64, dtype=np.uint8).reshape(4, 4, 4))
    section = {
        "image": "i.npy",
        "voxel_um": 1.0,
        "segmentation": {"method": "thresholds", "thresholds": [100]},
    }
    scene = tmp_path / "s.yaml"
    scene.write_text(yaml.safe_dump({**_SCENE, "acquire": section}))
    out = tmp_path / "out.h5"
    argv = ["acquire", "--scene", str(scene), "-o", str(out), "--phases", "a", "b", "c", "--pore-phases", "a"]
    (line,) = _error_lines(argv, capsys)
    assert line.endswith(
        "acquire settings: --phases = ['a', 'b', 'c'], --pore-phases = ['a']: method thresholds needs 2 ascending "
        "thresholds, got [100.0]"
    )
    assert not out.exists()


def test_merge_settings_names_a_key_by_its_option_only_where_the_option_gave_it():
    """The same merged value, named by the option when ``options`` says the command line gave its key, else by the
    key (the Python caller's, or a scene's)."""
    from porepipe._shared.errors import PorepipeError
    from porepipe._shared.overrides import merge_settings
    from porepipe.acquire import Settings

    bad = {"segmentation": {"phases": ["a", "a"]}}
    with pytest.raises(PorepipeError) as err:
        merge_settings(Settings, bad, {}, "acquire settings")
    assert str(err.value).startswith("acquire settings: segmentation = {")
    with pytest.raises(PorepipeError) as err:
        merge_settings(Settings, {}, bad, "acquire settings", options={"segmentation.phases": "--phases"})
    assert str(err.value) == (
        "acquire settings: --phases = ['a', 'a']: phases must name at least two distinct phases, got ['a', 'a']"
    )


def test_a_memory_budget_below_one_mb_is_named_by_the_option_and_in_a_scene_by_its_key(tmp_path, capsys):
    """``lpt B --memory-budget-mb 0`` said ``resources.memory_budget_mb = 0; allowed: ...`` (the scene key the option
    overrides); each subcommand taking the option now refuses it there, by its name. A scene's 0 names the key."""
    from porepipe.cli import build_parser

    commands = next(a for a in build_parser()._actions if a.dest == "command").choices
    taking = sorted(name for name, p in commands.items() if "--memory-budget-mb" in p._option_string_actions)
    assert taking == ["lpt", "minkowski", "segment"]
    for name in taking:
        for bad in ("0", "-5"):
            with pytest.raises(SystemExit) as stop:  # argparse's refusal, before any work
                main([name, "b.h5", "-o", str(tmp_path / "o.h5"), "--memory-budget-mb", bad])
            line = capsys.readouterr().err.strip().splitlines()[-1]
            assert stop.value.code == 2
            assert (
                f"error: argument --memory-budget-mb: {bad}: give 1 or more (leave --memory-budget-mb out"
                in line
            )
            assert "resources" not in line
    scene = tmp_path / "s.yaml"
    scene.write_text(yaml.safe_dump({**_SCENE, "resources": {"memory_budget_mb": 0}}))
    lines = _error_lines(["lpt", "b.h5", "--scene", str(scene), "-o", str(tmp_path / "o.h5")], capsys)
    assert any(text.startswith("  - resources.memory_budget_mb = 0") for text in lines), lines
    assert not any("--memory-budget-mb" in text for text in lines), lines
