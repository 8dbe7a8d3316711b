"""The one atomic write (porepipe._shared.atomic) and the one binary-volume reader (store.read_binary_volume)."""

import os
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest
import xarray as xr

from porepipe._shared.atomic import atomic_path, commit, file_identity, temporary_path, write_text_atomic
from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter, read_binary_volume


def test_atomic_path_replaces_the_file_only_when_the_block_succeeds(tmp_path):
    path = tmp_path / "sub" / "t.txt"
    write_text_atomic(path, "old\n")
    with pytest.raises(RuntimeError), atomic_path(path) as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert path.read_text() == "old\n"
    assert sorted(p.name for p in path.parent.iterdir()) == ["t.txt"]  # the temporary file is gone too
    with atomic_path(path) as tmp:
        tmp.write_text("new\n")
        assert path.read_text() != "new\n"  # nothing visible under the final name before the commit
    assert path.read_text() == "new\n"


@pytest.mark.parametrize("writer", ["text", "result"])
def test_kill_mid_write_keeps_the_old_file_whole(tmp_path, writer):
    """SIGKILL while the new content is half written: the final name still holds the old, complete file."""
    path = tmp_path / ("t.txt" if writer == "text" else "r.h5")
    if writer == "text":
        write_text_atomic(path, "old\n")
        body = (
            "from porepipe._shared.atomic import atomic_path\n"
            f"with atomic_path({str(path)!r}) as tmp, open(tmp, 'w') as f:\n"
            "    f.write('x' * 100000); f.flush()\n"
            "    print('writing', flush=True); time.sleep(60)\n"
        )
    else:
        with ResultWriter(path, stage="old") as w:
            w.write_volume("v", np.ones((4, 4, 4), np.uint8), voxel_um=1.0)
        body = (
            "import numpy as np\nfrom porepipe._shared.store import ResultWriter\n"
            f"with ResultWriter({str(path)!r}, stage='new') as w:\n"
            "    d = w.create_volume('v', (64, 64, 64), np.uint8, voxel_um=1.0); d[:32] = 2; w.h5.flush()\n"
            "    print('writing', flush=True); time.sleep(60)\n"
        )
    before = path.read_bytes()
    with subprocess.Popen(
        [sys.executable, "-c", "import time\n" + body], stdout=subprocess.PIPE, text=True
    ) as proc:
        assert proc.stdout.readline().strip() == "writing"
        assert temporary_path(path).name.startswith(".")  # a hidden name no rule takes for a result
        assert any(p.name.endswith(f".{proc.pid}.tmp") for p in tmp_path.iterdir())  # really mid-write
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    assert path.read_bytes() == before


def _binary(path, **attrs):
    with ResultWriter(path, stage="segment") as w:
        w.write_volume(
            "pore",
            np.eye(3, dtype=np.uint8)[:, :, None].repeat(2, axis=2),
            voxel_um=0.5,
            origin_um=(1.0, 2.0, 3.0),
            periodic=(True, False, True),
        )
    with h5py.File(path, "a") as f:
        for key, value in attrs.items():
            if value is None:
                del f["volumes/pore"].attrs[key]
            else:
                f["volumes/pore"].attrs[key] = value


def test_read_binary_volume_returns_the_geometry(tmp_path):
    _binary(tmp_path / "b.h5")
    pore, meta = read_binary_volume(tmp_path / "b.h5")
    assert pore.shape == (3, 3, 2) and pore.dtype == np.uint8 and int(pore.sum()) == 6
    assert meta.voxel_um == 0.5 and isinstance(meta.voxel_um, float)
    assert meta.origin_um == (1.0, 2.0, 3.0) and meta.periodic == (True, False, True)


@pytest.mark.parametrize("key", ["voxel_um", "origin_um", "periodic"])
def test_read_binary_volume_refuses_missing_metadata_naming_file_and_key(tmp_path, key):
    _binary(tmp_path / "b.h5", **{key: None})
    with pytest.raises(PorepipeError, match=rf"b\.h5.*{key}"):
        read_binary_volume(tmp_path / "b.h5")


@pytest.mark.parametrize(
    ("key", "value"),
    [("voxel_um", [1.0, 2.0, 1.0]), ("voxel_um", -1.0), ("origin_um", [0.0, 1.0]), ("periodic", [1, 2, 0])],
)
def test_read_binary_volume_refuses_malformed_metadata(tmp_path, key, value):
    _binary(tmp_path / "b.h5", **{key: value})
    with pytest.raises(PorepipeError, match=key):
        read_binary_volume(tmp_path / "b.h5")


def test_anisotropic_voxels_only_where_a_stage_asks_for_them(tmp_path):
    _binary(tmp_path / "b.h5", voxel_um=[0.17, 0.17, 1.04])  # serial sections
    with pytest.raises(PorepipeError, match="anisotropic voxels are not supported"):
        read_binary_volume(tmp_path / "b.h5")
    _, meta = read_binary_volume(tmp_path / "b.h5", anisotropic=True)
    assert meta.voxel_xyz_um == (0.17, 0.17, 1.04)
    _binary(tmp_path / "c.h5")
    assert read_binary_volume(tmp_path / "c.h5", anisotropic=True)[1].voxel_xyz_um == (0.5, 0.5, 0.5)
    with pytest.raises(PorepipeError, match="voxel_um"):
        _binary(tmp_path / "d.h5", voxel_um=[0.17, -1.0, 1.0])
        read_binary_volume(tmp_path / "d.h5", anisotropic=True)


@pytest.mark.parametrize("table", [False, True])
def test_writer_whose_temporary_file_was_removed_commits_nothing(tmp_path, table):
    """A rerun on another node removed this writer's temporary file (its process id means nothing there): the
    writer must not commit what it would write on into a new file under that name (attributes, tables only)."""
    path = tmp_path / "r.h5"
    with pytest.raises(PorepipeError, match=r"r\.h5: its temporary file .* was removed while it was written"):
        with ResultWriter(path, stage="test") as w:
            w.write_volume("v", np.ones((4, 4, 4), np.uint8), voxel_um=1.0)
            if table:
                w.write_table(xr.Dataset({"q": ("i", np.arange(3.0))}))
            w.h5.flush()
            w.tmp_path.unlink()
    assert list(tmp_path.iterdir()) == []


def test_commit_refuses_a_temporary_file_made_again_under_the_same_name(tmp_path):
    tmp, path = tmp_path / ".t.txt.1.tmp", tmp_path / "t.txt"
    with open(tmp, "w") as held:  # the writer holds its file open (as ResultWriter holds its HDF5 handle)
        held.write("first half")
        made = file_identity(tmp)
        tmp.unlink()
        tmp.write_text("second half")  # the same name, another file (the first one's inode is still held)
        with pytest.raises(PorepipeError, match="was removed while it was written"):
            commit(tmp, path, made)
    assert not path.exists()
    commit(tmp, path, file_identity(tmp))
    assert path.read_text() == "second half"
