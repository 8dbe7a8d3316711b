"""Scene files a hostile or clumsy user writes: bounded, unambiguous, and every fault one line (issue 20, items 3-4)."""

import time
import tracemalloc

import pytest

from porepipe._shared.errors import PorepipeError
from porepipe._shared.yaml_safe import MAX_NODES, load_yaml
from porepipe.cli import main
from porepipe.scene import SceneError, load_scene

GOOD = """\
name: ok
seed: 3
domain: {size_um: [100, 100, 100], periodic: true}
spheres: {inline: [[10, 10, 10, 5]]}
resolutions_um: [4, 2]
"""


def _write(tmp_path, text, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _alias_bomb(levels: int, fan: int = 10) -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    for level in range(1, levels + 1):
        refs = ", ".join([f"*a{level - 1}"] * fan)
        lines.append(f"a{level}: &a{level} [{refs}]")
    lines.append(f"name: [*a{levels}]")
    return "\n".join(lines) + "\n"


def test_alias_bomb_is_refused_fast_and_small(tmp_path, capsys):
    path = _write(tmp_path, _alias_bomb(8))  # 10^9 values once expanded, from about 1 KB
    assert path.stat().st_size < 2048
    main(["validate", str(_write(tmp_path, GOOD, "warm.yaml"))])  # import the CLI before measuring
    capsys.readouterr()
    start = time.perf_counter()
    code = main(["validate", str(path)])
    elapsed = time.perf_counter() - start
    out = capsys.readouterr()
    assert code == 2
    assert "alias bomb" in out.out + out.err
    assert len(out.out + out.err) < 2000  # before: 1.1 GB printed
    assert elapsed < 2.0  # the node count stops at MAX_NODES: 0.08 s here; 2 s leaves room for a busy CI
    tracemalloc.start()
    with pytest.raises(SceneError, match="alias bomb"):
        load_scene(path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 64 * 2**20  # before: 3.5 GB


def test_node_count_counts_every_use_of_an_alias(tmp_path):
    small = _write(tmp_path, _alias_bomb(3), "small.yaml")  # 10^4 values: allowed
    assert isinstance(load_yaml(small), dict)
    assert 10**4 < MAX_NODES < 10**6
    with pytest.raises(PorepipeError, match="alias bomb"):
        load_yaml(_write(tmp_path, _alias_bomb(5), "big.yaml"))  # 10^6 values


def test_duplicate_key_is_an_error_naming_key_and_lines(tmp_path):
    path = _write(tmp_path, GOOD + "seed: 4\n")
    with pytest.raises(SceneError, match=r"duplicate key 'seed' \(first at line 2\).*line 6"):
        load_scene(path)


def test_exponent_floats_are_numbers_so_the_divisibility_check_runs(tmp_path):
    text = GOOD.replace("[100, 100, 100]", "[1e2, 1e2, 1e2]").replace("[4, 2]", "[3e0]")
    with pytest.raises(SceneError, match=r"resolutions_um\[0\] = 3.0: does not divide"):
        load_scene(_write(tmp_path, text))
    ok = load_scene(_write(tmp_path, GOOD.replace("[4, 2]", "[4e0, 2E0]"), "ok.yaml"))
    assert ok.resolutions_um == [4.0, 2.0]


@pytest.mark.parametrize("value", [".nan", ".inf", "-.inf"])
@pytest.mark.parametrize("key", ["size", "resolution"])
def test_nan_and_inf_are_problems_not_tracebacks(tmp_path, key, value):
    text = (
        GOOD.replace("[100, 100, 100]", f"[100, {value}, 100]")
        if key == "size"
        else GOOD.replace("[4, 2]", f"[4, {value}]")
    )
    with pytest.raises(SceneError) as err:
        load_scene(_write(tmp_path, text))
    assert ("domain.size_um[1]" if key == "size" else "resolutions_um[1]") in str(err.value)


def test_boolean_seed_is_refused(tmp_path):
    with pytest.raises(SceneError, match=r"seed = True: Input should be a valid integer"):
        load_scene(_write(tmp_path, GOOD.replace("seed: 3", "seed: true")))


def test_resolution_too_fine_for_memory_is_refused_with_the_estimate(tmp_path):
    with pytest.raises(
        SceneError, match=r"resolutions_um\[1\] = 1e-06: the volume would have 1e\+24 voxels.*memory"
    ):
        load_scene(_write(tmp_path, GOOD.replace("[4, 2]", "[4, 1e-6]")))


def test_sphere_count_too_large_for_memory_is_refused(tmp_path):
    text = GOOD.replace("spheres: {inline: [[10, 10, 10, 5]]}", "spheres: {pack: true}") + (
        "packing:\n  types:\n    - {name: g, count: 1e11, max_overlap: 0.3, radius_um: {dist: uniform, min_um: 1, "
        "max_um: 2}}\n"
    )
    with pytest.raises(SceneError, match=r"packing.types\[\*\].count = 1e\+11 spheres.*GiB, more than"):
        load_scene(_write(tmp_path, text))


def test_huge_values_are_shown_shortened(tmp_path):
    text = GOOD.replace("name: ok", "name: '" + "x " * 5000 + "'")
    with pytest.raises(SceneError) as err:
        load_scene(_write(tmp_path, text))
    assert len(str(err.value)) < 1000


def test_oversized_file_is_refused(tmp_path):
    path = _write(tmp_path, GOOD + "#" * (5 * 2**20) + "\n")
    with pytest.raises(SceneError, match="bytes, more than"):
        load_scene(path)


def test_permeability_only_on_sub_samples_needs_sub_samples(tmp_path):
    text = GOOD + "permeability: {whole_volume: false}\n"
    with pytest.raises(
        SceneError, match=r"permeability.whole_volume = false: needs sub-samples .*sweep.sample_um"
    ):
        load_scene(_write(tmp_path, text))
    assert not load_scene(_write(tmp_path, text + "sweep: {sample_um: [40]}\n")).permeability.whole_volume
