"""``permeability --out-dir`` is checked before anything is computed, like ``-o`` (issue 20, item 5)."""

from pathlib import Path

import numpy as np

from porepipe._shared.store import ResultWriter
from porepipe.cli import main

SCENES = Path(__file__).resolve().parents[2] / "config" / "scenes"


def test_out_dir_with_a_file_in_the_way_is_one_line_before_any_work(tmp_path, capsys):
    blocker = tmp_path / "results"
    blocker.write_text("not a folder")
    # the input does not even exist: the output folder is refused first, so nothing was read or computed
    code = main(
        ["permeability", str(tmp_path / "missing.h5"), "--axis", "z", "--out-dir", str(blocker / "perm")]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and "a file is in the way" in err[0] and str(blocker) in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]


def test_out_dir_that_is_a_file_is_refused(tmp_path, capsys):
    target = tmp_path / "perm.h5"
    target.write_text("x")
    code = main(["permeability", str(tmp_path / "missing.h5"), "--axis", "z", "--out-dir", str(target)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and "a file is in the way" in err[0] and str(target) in err[0]
    assert target.read_text() == "x"  # the file in the way is left as it was


def test_out_dir_is_created_when_missing(tmp_path, capsys):
    folder = tmp_path / "new" / "deeper"
    code = main(["permeability", str(tmp_path / "missing.h5"), "--axis", "z", "--out-dir", str(folder)])
    assert folder.is_dir()  # created before the run; the missing input is then the one error
    assert code == 2
    assert "missing.h5" in capsys.readouterr().err


def test_output_that_is_the_input_is_refused_and_the_input_kept(tmp_path, capsys):
    """``-o`` naming the command's own input (also by another spelling or through a link) was written over it by the
    atomic rename: the binary volume became a Minkowski result. Now one line, and the input keeps its bytes."""
    binary = tmp_path / "binary.h5"
    with ResultWriter(binary, stage="segment", scene="t") as w:
        w.write_volume("pore", np.ones((4, 4, 4), dtype=np.uint8), voxel_um=1.0, periodic=(True, True, True))
    before = binary.read_bytes()
    (tmp_path / "link.h5").symlink_to(binary)
    for argv in (
        ["minkowski", str(binary), "-o", str(binary)],
        ["minkowski", str(tmp_path / "." / "binary.h5"), "-o", str(binary)],
        ["minkowski", str(tmp_path / "link.h5"), "-o", str(binary)],
    ):
        code = main(argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2
        assert len(err) == 1 and "is also an input of this command" in err[0]
    assert binary.read_bytes() == before


def test_a_bad_command_line_option_is_one_line_naming_each_value(tmp_path, capsys):
    """pydantic's reasons for an option laid over the scene came as four lines per problem; now one line."""
    code = main(["lpt", str(tmp_path / "missing.h5"), "-o", str(tmp_path / "l.h5"), "--cell-um", "0", "-5"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1
    assert "--cell-um[0] = 0.0: Input should be greater than 0" in err[0] and "--cell-um[1] = -5.0" in err[0]


def test_two_outputs_naming_one_file_are_refused_before_any_work(tmp_path, capsys):
    """``pack -o p.h5 --xyzr p.h5`` left the xyzr text where the packing was; ``granular -o g.h5 --checkpoint g.h5``
    removed the result with the checkpoint at the end, exit code 0; a checkpoint on the scene file would overwrite it.
    """
    scene = tmp_path / "box.yaml"
    scene.write_text((SCENES / "granular-box.yaml").read_text())
    out = tmp_path / "r.h5"
    for argv, words in (
        (
            ["pack", str(SCENES / "mini.yaml"), "-o", str(out), "--xyzr", str(tmp_path / "." / "r.h5")],
            "-o and --xyzr",
        ),
        (["granular", str(scene), "-o", str(out), "--checkpoint", str(out)], "-o and --checkpoint"),
        (["granular", str(scene), "-o", str(out), "--checkpoint", str(scene)], "is also an input"),
    ):
        code = main(argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2
        assert len(err) == 1 and words in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["box.yaml"]
    assert scene.read_text() == (SCENES / "granular-box.yaml").read_text()


def test_out_and_out_dir_together_are_refused_before_any_work(tmp_path, capsys):
    """``-o`` won and ``--out-dir`` was created empty and ignored; now one line naming both, nothing made."""
    folder = tmp_path / "perm"
    argv = ["permeability", str(tmp_path / "missing.h5"), "--axis", "z", "-o", str(tmp_path / "p.h5")]
    code = main([*argv, "--out-dir", str(folder)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and "-o" in err[0] and "--out-dir" in err[0] and str(folder) in err[0]
    assert list(tmp_path.iterdir()) == []


def test_resume_without_a_checkpoint_is_refused_where_none_is_kept(tmp_path, capsys):
    """``pack S -o p.h5 --resume`` (and granular's) started afresh without a word: these stages keep no checkpoint
    unless --checkpoint names one."""
    for argv in (
        ["pack", str(SCENES / "mini.yaml"), "-o", str(tmp_path / "p.h5"), "--resume"],
        ["granular", str(SCENES / "granular-box.yaml"), "-o", str(tmp_path / "g.h5"), "--resume"],
    ):
        code = main(argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and "--resume needs --checkpoint FILE" in err[0]
    assert list(tmp_path.iterdir()) == []
