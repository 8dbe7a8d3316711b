"""``permeability --out-dir`` is checked before anything is computed, like ``-o`` (issue 20, item 5)."""

from porepipe.cli import main


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
