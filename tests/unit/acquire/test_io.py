"""Readers: every format written with its reference library (tifffile, NumPy tofile, h5py, np.save) reads back
bit-identical through porepipe, in (x, y, z) order, with the voxel size from the metadata or the caller."""

import h5py
import numpy as np
import pytest
import tifffile

from porepipe._shared.errors import PorepipeError
from porepipe.acquire._io import read_image, require_spacing
from porepipe.acquire._settings import Raw


@pytest.fixture
def volume():
    rng = np.random.default_rng(11)
    return rng.integers(0, 60000, size=(7, 5, 4)).astype(np.uint16)  # distinct edges catch axis mix-ups


def test_multipage_tiff_with_imagej_spacing(tmp_path, volume):
    path = tmp_path / "v.tif"
    # tifffile stores pages along z: array (z, y, x); resolution in pixels per µm
    tifffile.imwrite(
        path,
        volume.transpose(2, 1, 0),
        imagej=True,
        resolution=(1 / 3.7, 1 / 3.7),
        metadata={"spacing": 5.0, "unit": "um"},
    )
    img = read_image(path)
    np.testing.assert_array_equal(img.data, volume)
    # rationals of the resolution tag: 1/3.7 is stored as a fraction, exact to ~1e-7 relative
    np.testing.assert_allclose(img.spacing_um, (3.7, 3.7, 5.0), rtol=1e-6)
    assert not img.is_2d


def test_tiff_resolution_in_centimetres(tmp_path, volume):
    path = tmp_path / "cm.tif"
    tifffile.imwrite(
        path,
        volume.transpose(2, 1, 0),
        resolution=(2000.0, 2000.0),
        resolutionunit="CENTIMETER",
        photometric="minisblack",
    )
    img = read_image(path)
    np.testing.assert_allclose(img.spacing_um[:2], (5.0, 5.0), rtol=1e-9)  # 10^4 µm / 2000 px


def test_tiff_without_voxel_size_is_an_error_unless_given(tmp_path, volume):
    path = tmp_path / "plain.tif"
    tifffile.imwrite(path, volume.transpose(2, 1, 0), photometric="minisblack")
    img = read_image(path)
    with pytest.raises(PorepipeError, match="no voxel size"):
        require_spacing(img)
    assert require_spacing(read_image(path, voxel_um=2.5)) == (2.5, 2.5, 2.5)


def test_serial_sections_directory_stacked_along_z(tmp_path, volume):
    folder = tmp_path / "sections"
    folder.mkdir()
    for k in range(volume.shape[2]):
        tifffile.imwrite(folder / f"s{k:03d}.tif", volume[:, :, k].T)
    img = read_image(folder, voxel_um=1.0, section_um=4.0)
    np.testing.assert_array_equal(img.data, volume)
    assert img.spacing_um == (1.0, 1.0, 4.0)
    img_glob = read_image(str(folder / "s00[0-1].tif"), voxel_um=1.0)
    np.testing.assert_array_equal(img_glob.data, volume[:, :, :2])


def test_2d_tiff_is_a_section(tmp_path, volume):
    path = tmp_path / "sem.tif"
    tifffile.imwrite(path, volume[:, :, 0].T)
    img = read_image(path, voxel_um=0.1)
    assert img.is_2d and img.shape == (7, 5, 1)
    np.testing.assert_array_equal(img.data[:, :, 0], volume[:, :, 0])


@pytest.mark.parametrize("order", ["F", "C"])
@pytest.mark.parametrize("byte_order", ["little", "big"])
@pytest.mark.parametrize("dtype", ["uint16", "float32", "int16"])
def test_raw_round_trip_with_header(tmp_path, volume, order, byte_order, dtype):
    data = volume.astype(dtype) - (1000 if dtype == "int16" else 0)
    path = tmp_path / "v.raw"
    header = b"HEADER-0123456789" * 3
    with open(path, "wb") as f:
        f.write(header)
        f.write(
            data.astype(np.dtype(dtype).newbyteorder("<" if byte_order == "little" else ">")).tobytes(
                order=order
            )
        )
    raw = Raw(dtype=dtype, shape=data.shape, byte_order=byte_order, header_bytes=len(header), order=order)
    img = read_image(path, raw=raw, voxel_um=1.0)
    assert isinstance(img.data, np.memmap)  # never loaded whole
    np.testing.assert_array_equal(np.asarray(img.data), data)


def test_raw_size_mismatch_is_a_clear_error(tmp_path, volume):
    path = tmp_path / "v.raw"
    volume.tofile(path)
    raw = Raw(dtype="uint16", shape=(7, 5, 5))
    with pytest.raises(PorepipeError, match=r"has 280 bytes.*= 350 bytes"):
        read_image(path, raw=raw, voxel_um=1.0)
    with pytest.raises(PorepipeError, match="give acquire.raw"):
        read_image(path, voxel_um=1.0)
    with pytest.raises(PorepipeError, match="not a NumPy dtype"):
        read_image(path, raw=Raw(dtype="nonsense", shape=(7, 5, 4)), voxel_um=1.0)


def test_hdf5_dataset_with_element_size(tmp_path, volume):
    path = tmp_path / "v.h5"
    with h5py.File(path, "w") as f:
        dset = f.create_dataset("scan/grey", data=volume, chunks=(4, 5, 4))
        dset.attrs["element_size_um"] = [2.0, 2.0, 3.0]
        f.create_dataset("other/vector", data=np.arange(3))
    img = read_image(path)
    np.testing.assert_array_equal(img.data[...], volume)
    assert img.spacing_um == (2.0, 2.0, 3.0)
    np.testing.assert_array_equal(read_image(path, dataset="scan/grey").data[1:3], volume[1:3])
    with pytest.raises(PorepipeError, match="no dataset 'nope'"):
        read_image(path, dataset="nope")


def test_npy_memory_mapped(tmp_path, volume):
    path = tmp_path / "v.npy"
    np.save(path, volume)
    img = read_image(path)
    assert img.spacing_um is None  # .npy has no metadata: the caller must give the voxel size
    np.testing.assert_array_equal(img.data, volume)
    np.save(tmp_path / "s.npy", volume[:, :, 0])
    assert read_image(tmp_path / "s.npy", voxel_um=1.0).is_2d


def test_unknown_suffix_and_missing_file(tmp_path):
    with pytest.raises(PorepipeError, match="cannot tell the format"):
        read_image(tmp_path / "image.xyz")
    with pytest.raises(PorepipeError, match="does not exist"):
        read_image(tmp_path / "missing.npy")
