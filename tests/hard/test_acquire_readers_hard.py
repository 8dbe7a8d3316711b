"""Image readers refuse what they cannot read correctly, with one PorepipeError naming the file (issue 20, item 7)."""

import os

import numpy as np
import pytest
import tifffile

from porepipe._shared.errors import PorepipeError
from porepipe.acquire._io import read_image, read_raw
from porepipe.acquire._settings import Raw


def test_rgb_tiff_is_refused_not_read_as_three_sections(tmp_path):
    path = tmp_path / "rgb.tif"
    tifffile.imwrite(path, np.zeros((32, 32, 3), np.uint8), photometric="rgb")
    with pytest.raises(PorepipeError, match=r"rgb.tif has 3 samples per pixel.*one grey channel"):
        read_image(path)


def test_garbage_tiff_is_a_clear_error(tmp_path):
    path = tmp_path / "garbage.tif"
    path.write_bytes(b"II*\x00" + np.random.default_rng(1).bytes(200))
    with pytest.raises(PorepipeError, match=r"garbage.tif"):
        read_image(path)


def test_truncated_tiff_is_a_clear_error(tmp_path):
    path = tmp_path / "cut.tif"
    tifffile.imwrite(
        path, np.arange(16 * 16 * 4, dtype=np.uint16).reshape(4, 16, 16), photometric="minisblack"
    )
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 3])
    with pytest.raises(PorepipeError, match=r"cut.tif"):
        read_image(path)


def test_grey_tiff_still_reads_as_x_y_z(tmp_path):
    stack = np.arange(4 * 5 * 6, dtype=np.uint8).reshape(4, 5, 6)  # tifffile order (z, y, x)
    tifffile.imwrite(tmp_path / "g.tif", stack, photometric="minisblack")
    image = read_image(tmp_path / "g.tif")
    np.testing.assert_array_equal(np.asarray(image.data), stack.transpose(2, 1, 0))


def test_sections_of_unequal_shape_are_refused(tmp_path):
    tifffile.imwrite(tmp_path / "s0.tif", np.zeros((8, 8), np.uint8))
    tifffile.imwrite(tmp_path / "s1.tif", np.zeros((8, 9), np.uint8))
    with pytest.raises(PorepipeError, match=r"s1.tif has shape \(8, 9\).*one shape"):
        read_image(tmp_path)


def test_raw_shape_whose_voxel_count_overflows_int64_is_refused(tmp_path):
    path = tmp_path / "v.raw"
    path.write_bytes(bytes(64))
    huge = 2**21 + 1  # (2^21+1)^3 * 8 bytes > 2^63: int64 arithmetic would wrap round
    raw = Raw(dtype="float64", shape=(huge, huge, huge))
    with pytest.raises(PorepipeError, match=r"v.raw has 64 bytes"):
        read_raw(path, raw)


def test_tiff_whose_shape_exceeds_free_memory_is_refused_before_reading(tmp_path, monkeypatch):
    import psutil

    path = tmp_path / "big.tif"
    tifffile.imwrite(path, np.zeros((2, 64, 64), np.uint8), photometric="minisblack")
    real = psutil.virtual_memory()
    monkeypatch.setattr(psutil, "virtual_memory", lambda: real._replace(available=1024))
    with pytest.raises(PorepipeError, match=r"big.tif claims shape \(2, 64, 64\).*free memory"):
        read_image(path)
    assert os.path.exists(path)


@pytest.mark.parametrize("content", ["tiff", "empty"])
def test_npy_suffix_on_another_format_is_named_not_unpickled(tmp_path, content):
    # before: numpy took a TIFF named .npy for a pickle and its message advised loading it with allow_pickle
    path = tmp_path / "image.npy"
    if content == "tiff":
        tifffile.imwrite(path, np.zeros((2, 4, 4), np.uint8))
    else:
        path.write_bytes(b"")
    with pytest.raises(PorepipeError) as err:
        read_image(path, voxel_um=1.0)
    assert str(err.value) == (
        f"{path} is not a .npy file (no NumPy header); if it is an image of another format, set that format "
        "(acquire.format, --format)"
    )
