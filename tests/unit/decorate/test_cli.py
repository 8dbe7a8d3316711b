"""`porepipe decorate` and `porepipe voxelize-grains` end to end on a tiny scene."""

import numpy as np
import pytest
import yaml

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import read_attrs, read_table, read_volume
from porepipe.cli import build_parser
from porepipe.decorate import read_grains, voxelize_grains

SCENE = {
    "name": "tiny-deco",
    "seed": 3,
    "domain": {"size_um": [12, 12, 12], "periodic": True},
    "spheres": {"inline": [[2, 3, 4, 2.5], [8, 8, 8, 3.0], [11.5, 0.5, 6, 2.0]]},
    "decoration": {
        "families": [
            {"name": "q", "generator": "quartz", "count": 2},
            {"name": "f", "generator": "file", "file": "cube.planes"},
        ]
    },
    "resolutions_um": [2, 1],
}


def _run(*argv):
    args = build_parser().parse_args([str(a) for a in argv])
    return args.func(args)


def test_decorate_then_voxelize(tmp_path):
    (tmp_path / "cube.planes").write_text(
        "\n".join(f"box {x} {y} {z} 1" for x, y, z in np.vstack([np.eye(3), -np.eye(3)]).astype(int)) + "\n"
    )
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump(SCENE))
    grains = tmp_path / "grains.h5"
    assert _run("decorate", scene, "-o", grains, "--threads", "1") == 0
    table = read_table(grains)
    assert table.sizes["grain"] == 3 and table.sizes["type"] == 3  # 2 quartz + 1 cube from the file
    assert table["volume"].values[2] == pytest.approx(8.0, rel=1e-12)  # the file's cube, exact
    assert read_attrs(grains)["stage"] == "decorate"
    out = tmp_path / "grey_a1.h5"
    assert _run("voxelize-grains", scene, "--grains", grains, "--a", 1, "-o", out) == 0
    grey, attrs = read_volume(out, "grey")
    deco, _ = read_grains(grains)
    assert np.array_equal(grey, voxelize_grains(deco, (12.0,) * 3, 1.0))
    hist = read_table(out)["grey_histogram"].values
    assert hist.sum() == 12**3 and np.array_equal(hist, np.bincount(grey.ravel(), minlength=217))
    assert attrs["voxel_um"] == 1.0


def test_decorate_needs_a_decoration_section(tmp_path):
    scene = tmp_path / "plain.yaml"
    scene.write_text(yaml.safe_dump({k: v for k, v in SCENE.items() if k != "decoration"}))
    with pytest.raises(PorepipeError, match="no `decoration:` section"):
        _run("decorate", scene, "-o", tmp_path / "g.h5")
