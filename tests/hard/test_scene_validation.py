"""`porepipe validate` on broken scenes: one clear message per fault, naming key, value and what is allowed."""

import textwrap

import pytest

from porepipe.cli import main
from porepipe.scene import SceneError, parse_scene

GOOD = """
name: ok
domain: {size_um: [100, 100, 100], periodic: true}
spheres: {inline: [[10, 10, 10, 5]]}
resolutions_um: [4, 2]
"""

BROKEN = {
    "negative radius": ("spheres: {inline: [[10, 10, 10, -5]]}", ["spheres.inline", "radius -5", "r > 0"]),
    "zero box edge": ("domain: {size_um: [100, 0, 100]}", ["domain.size_um[1]", "greater than 0"]),
    "resolution not dividing": (
        "resolutions_um: [3, 2]",
        ["resolutions_um[0] = 3", "does not divide", "33.3333"],
    ),
    "negative resolution": ("resolutions_um: [-1]", ["resolutions_um[0]", "greater than 0"]),
    "unknown analysis": ("analyses: [segment, porosimetry]", ["analyses[1] = 'porosimetry'", "'minkowski'"]),
    "missing xyzr file": (
        "spheres: {xyzr: nowhere.xyzr}",
        ["spheres.xyzr = 'nowhere.xyzr'", "file not found"],
    ),
    "two sphere sources": ("spheres: {inline: [[1, 1, 1, 1]], xyzr: a.xyzr}", ["exactly one of"]),
    "misspelt key": ("resolution_um: [2]", ["resolution_um", "unknown key"]),
    "fixed without threshold": ("segmentation: {method: fixed}", ["segmentation", "needs `threshold`"]),
    "threshold out of range": (
        "segmentation: {method: fixed, threshold: 216}",
        ["segmentation.threshold = 216", "less than or equal to 215"],
    ),
    "bad name": ("name: 'two words'", ["name = 'two words'", "pattern"]),
    "unknown segmentation method": (
        "segmentation: {method: kmeans}",
        ["segmentation.method = 'kmeans'", "'otsu'"],
    ),
    "duplicate resolutions": ("resolutions_um: [2, 2]", ["resolutions_um", "distinct"]),
    "pack without packing section": ("spheres: {pack: true}", ["spheres.pack", "packing:"]),
}


def _scene(tmp_path, override: str):
    import yaml

    data = yaml.safe_load(GOOD)
    data.update(yaml.safe_load(override))
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(data))
    (tmp_path / "a.xyzr").write_text("1 1 1 1\n")
    return path


def test_good_scene_validates(tmp_path, capsys):
    assert main(["validate", str(_scene(tmp_path, "{}"))]) == 0
    assert "ok" in capsys.readouterr().out


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_each_fault_gives_one_clear_message(case, tmp_path, capsys):
    override, fragments = BROKEN[case]
    assert main(["validate", str(_scene(tmp_path, override))]) == 2
    err = capsys.readouterr().err
    assert "1 problem(s)" in err, err
    for fragment in fragments:
        assert fragment in err, (fragment, err)


def test_all_faults_reported_at_once(tmp_path, capsys):
    path = tmp_path / "scene.yaml"
    path.write_text(
        textwrap.dedent("""
        name: bad
        domain: {size_um: [100, 100, 100]}
        spheres: {inline: [[10, 10, 10, -5]]}
        resolutions_um: [3]
        analyses: [nonsense]
        colour: blue
    """)
    )
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "4 problem(s)" in err
    for fragment in ("radius -5", "does not divide", "nonsense", "colour"):
        assert fragment in err


def test_not_yaml_and_missing_file(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed")
    assert main(["validate", str(bad), str(tmp_path / "absent.yaml")]) == 2
    err = capsys.readouterr().err
    assert "not valid YAML" in err and "absent.yaml does not exist" in err


_SPHERES = {"name": "s", "domain": {"size_um": [8, 8, 8]}, "spheres": {"inline": [[4, 4, 4, 2]]}}


@pytest.mark.parametrize(
    "scene,match",
    [
        # before: `porepipe validate` said ok, and the granular job failed after the run had started
        (
            {"name": "g", "analyses": ["granular"]},
            r"analyses = \['granular'\]: lists granular, but the `granular:`",
        ),
        (
            {"name": "g", "analyses": ["granular"], "granular": {"duration_s": 1}},
            "no particles, blocks or drop",
        ),
        # before: ok, then a Snakemake traceback while it built the DAG
        ({**_SPHERES, "resolutions_um": [2], "analyses": ["acquire"]}, "lists acquire, but the scene has no"),
        (
            {
                **_SPHERES,
                "resolutions_um": [2],
                "analyses": ["permeability"],
                "permeability": {"resolutions_um": [4]},
            },
            r"permeability.resolutions_um = \[4\]: \[4\] not among resolutions_um = \[2\]",
        ),
        (
            {
                **_SPHERES,
                "resolutions_um": [2, 1],
                "analyses": ["diffusion"],
                "diffusion": {"resolutions_um": [1, 3]},
            },
            r"diffusion.resolutions_um = \[1, 3\]: \[3\] not among",
        ),
        # before: ok, and the run ran nothing but said where its results were
        (
            {**_SPHERES, "resolutions_um": [2], "analyses": []},
            r"analyses = \[\]: List should have at least 1 item",
        ),
    ],
)
def test_what_a_listed_analysis_needs_is_checked_with_the_scene(scene, match):
    with pytest.raises(SceneError, match=match) as err:
        parse_scene(scene)
    assert len(err.value.problems) == 1


def test_resolutions_of_an_analysis_not_listed_are_not_judged():
    scene = {**_SPHERES, "resolutions_um": [2], "permeability": {"resolutions_um": [4]}}
    assert parse_scene(scene).permeability.resolutions_um == [4.0]


_ONE = [{"position_m": (0.0, 0.0), "shape": {"size_m": (0.001, 0.001)}}]


@pytest.mark.parametrize(
    "scene,line",
    [
        # before: 'Input should be a valid dictionary or instance of Box' (a class name, not YAML)
        (
            {"name": "g", "analyses": ["granular"], "granular": {"box": [1, 2], "particles": _ONE}},
            "granular.box = [1, 2]: should be a mapping of keys to values",
        ),
        (
            {"name": "g", "analyses": ["granular"], "granular": {"drop_sources": {"x_m": 0}}},
            "granular.drop_sources = {'x_m': 0}: should be a list ([a, b, ...] or lines starting with `- `), "
            "not a mapping",
        ),
        # before: two problems, the second 'missing resolutions_um' judging the default analyses, with the whole
        # scene printed as its value
        (
            {"name": "g", "analyses": "granular", "granular": {"duration_s": 1}},
            "analyses = 'granular': should be a list",
        ),
    ],
)
def test_a_value_of_the_wrong_shape_is_named_in_yaml_words_once(scene, line):
    with pytest.raises(SceneError) as err:
        parse_scene(scene)
    assert len(err.value.problems) == 1
    assert err.value.problems[0].startswith(line)
    assert err.value.problems[0].endswith(("not a list", "not a mapping", "not a string"))


def test_a_problem_across_keys_does_not_print_the_whole_scene():
    """A granular section without `analyses: [granular]` (the default is estimate): before, the line showed the whole
    scene as its value and did not say why a granular scene would need resolutions."""
    with pytest.raises(SceneError) as err:
        parse_scene({"name": "g", "granular": {"duration_s": 1, "dt_s": 1e-5}})
    (problem,) = err.value.problems
    assert problem.startswith("(top level): missing resolutions_um")
    assert "analyses [granular]" in problem and "dt_s" not in problem


@pytest.mark.parametrize(
    "name,match",
    [
        (
            "a" * 300,
            "name = .*: 300 characters; allowed: at most 100",
        ),  # before: OSError 'File name too long'
        ("run-" + "0" * 20, "ends in '0' repeated 20 times"),  # before: Snakemake's PeriodicWildcardError
        ("x" + "ab" * 20, "ends in 'ab' repeated 20 times"),
    ],
)
def test_a_scene_name_snakemake_cannot_run_is_refused_with_the_scene(name, match):
    with pytest.raises(SceneError, match=match) as err:
        parse_scene({**_SPHERES, "name": name, "resolutions_um": [2]})
    assert len(err.value.problems) == 1


def test_names_near_the_limits_are_fine():
    for name in ("0123456789" * 10, "run-" + "0" * 19, "mini-2026-01-01"):
        assert parse_scene({**_SPHERES, "name": name, "resolutions_um": [2]}).name == name
