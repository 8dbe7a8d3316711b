"""Hard cases of the acquisition stage: degenerate images give finite statistics or a clear PorepipeError."""

import h5py
import numpy as np
import pytest
import xarray as xr

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import read_attrs
from porepipe.acquire._api import acquire, write_binary
from porepipe.acquire._calibrate import calibrated_scene, fit_radius_distribution
from porepipe.acquire._prepare import denoise, grey_histogram, segment_phases
from porepipe.acquire._run import run_calibrate
from porepipe.acquire._settings import Calibration, Family, Segmentation, Settings
from porepipe.cli import main


def _finite(ds: xr.Dataset, names):
    for name in names:
        assert np.all(np.isfinite(ds[name].values)), name


def test_one_grey_value_otsu_is_a_clear_error(tmp_path):
    np.save(tmp_path / "flat.npy", np.full((12, 12, 12), 77, np.uint8))
    settings = Settings(image=tmp_path / "flat.npy", voxel_um=1.0)
    with pytest.raises(
        PorepipeError, match=r"1 populated grey value\(s\) \[77.0\].*use acquire.segmentation.method"
    ):
        acquire(settings, tmp_path / "s.h5")
    assert not (tmp_path / "s.h5").exists()  # nothing half-written


def test_one_grey_value_with_thresholds_is_all_matrix(tmp_path):
    np.save(tmp_path / "flat.npy", np.full((12, 12, 12), 77, np.uint8))
    settings = Settings.model_validate(
        {
            "image": str(tmp_path / "flat.npy"),
            "voxel_um": 1.0,
            "segmentation": {"method": "thresholds", "thresholds": [50]},
        }
    )
    ds = acquire(settings, tmp_path / "s.h5")[None]
    assert float(ds.porosity) == 0.0
    _finite(ds, ["S_V_per_mm", "K_V_per_mm2", "T_V_per_mm3", "connected_porosity", "grains_per_mm3"])
    assert float(ds.S_V_per_mm) == 0.0
    assert ds.sizes["grain"] == 1  # the whole box is one grain


def test_all_pore_after_segmentation(tmp_path):
    rng = np.random.default_rng(0)
    np.save(tmp_path / "dark.npy", rng.integers(0, 40, (16, 16, 16)).astype(np.uint8))
    settings = Settings.model_validate(
        {
            "image": str(tmp_path / "dark.npy"),
            "voxel_um": 2.0,
            "segmentation": {"method": "thresholds", "thresholds": [100]},
        }
    )
    ds = acquire(settings, tmp_path / "s.h5")[None]
    assert float(ds.porosity) == 1.0
    assert ds.sizes["grain"] == 0 and float(ds.grains_per_mm3) == 0.0
    assert float(ds.S_V_per_mm) == 0.0
    np.testing.assert_allclose(ds.connected_porosity.values, 1.0)
    _finite(ds, ["S_V_per_mm", "K_V_per_mm2", "T_V_per_mm3", "two_point"])
    # no chords are complete in an all-pore image: mean chord is NaN by definition, counts are zero
    assert int(ds.chord_count.sum()) == 0
    with pytest.raises(PorepipeError, match="no grains"):
        calibrated_scene(ds, Calibration(), name="x")
    assert write_binary(tmp_path / "s.h5", tmp_path / "b.h5", 2.0) == 1.0


def test_2d_section_where_3d_is_needed(tmp_path):
    rng = np.random.default_rng(1)
    np.save(tmp_path / "sem.npy", np.where(rng.random((40, 30)) < 0.3, 40, 200).astype(np.uint8))
    ds = acquire(Settings(image=tmp_path / "sem.npy", voxel_um=0.5), tmp_path / "s.h5")[None]
    assert read_attrs(tmp_path / "s.h5")["is_2d"] == 1
    assert (
        "S_V_per_mm" not in ds and ds.attrs["skipped_2d"]
    )  # the 3-D-only statistics are left out, and said so
    assert np.isnan(float(ds.S_V_chord_per_mm.sel(axis="z")))  # no lines along z in a section
    with pytest.raises(PorepipeError, match="2-D section.*need a 3-D image"):
        write_binary(tmp_path / "s.h5", tmp_path / "b.h5", 0.5)
    # before: "the statistics have no grains (image all pore, or acquire.statistics.grains: false)"
    with pytest.raises(PorepipeError, match=r"s.h5 comes from a 2-D section; the calibration needs grains"):
        run_calibrate(tmp_path / "s.h5", tmp_path / "model.yaml")
    assert not (tmp_path / "model.yaml").exists()


def test_nan_in_float_image(tmp_path):
    data = np.random.default_rng(2).random((10, 10, 10)).astype(np.float32)
    data[3, 4, 5] = np.nan
    data[7, 0, 0] = np.inf
    np.save(tmp_path / "f.npy", data)
    with pytest.raises(PorepipeError, match=r"2 NaN/Inf voxel\(s\).*first at \(3, 4, 5\)"):
        acquire(Settings(image=tmp_path / "f.npy", voxel_um=1.0), tmp_path / "s.h5")
    # cropping the bad voxels away is the documented remedy
    ok = Settings.model_validate(
        {"image": str(tmp_path / "f.npy"), "voxel_um": 1.0, "crop": {"start": [0, 5, 0], "size": [10, 5, 10]}}
    )
    assert np.isfinite(float(acquire(ok, tmp_path / "s.h5")[None].porosity))


def test_missing_voxel_size_is_an_error_never_one(tmp_path):
    np.save(tmp_path / "v.npy", np.zeros((8, 8, 8), np.uint8))
    with pytest.raises(PorepipeError, match="no voxel size"):
        acquire(Settings(image=tmp_path / "v.npy"), tmp_path / "s.h5")


def test_wrong_resolution_for_the_binary(tmp_path):
    rng = np.random.default_rng(3)
    np.save(tmp_path / "v.npy", np.where(rng.random((12, 12, 12)) < 0.4, 30, 220).astype(np.uint8))
    acquire(Settings(image=tmp_path / "v.npy", voxel_um=3.0), tmp_path / "s.h5")
    with pytest.raises(PorepipeError, match=r"voxels of 3.0 µm; allowed: whole multiples of 3 µm"):
        write_binary(tmp_path / "s.h5", tmp_path / "b.h5", 2.0)


def test_radius_fit_degenerate_samples():
    with pytest.raises(PorepipeError, match="at least 2 grain radii"):
        fit_radius_distribution([5.0], [Family.uniform])
    fit = fit_radius_distribution([4.0, 4.0, 4.0], [Family.uniform, Family.exponential])
    assert fit.spec == {"dist": "uniform", "min_um": 4.0, "max_um": 4.0}


def test_cli_reports_bad_raw_clearly(tmp_path, capsys):
    (tmp_path / "v.raw").write_bytes(bytes(100))
    code = main(
        [
            "acquire",
            str(tmp_path / "v.raw"),
            "--voxel-um",
            "1",
            "--raw-shape",
            "5",
            "5",
            "5",
            "-o",
            str(tmp_path / "s.h5"),
        ]
    )
    assert code == 2
    assert "has 100 bytes" in capsys.readouterr().err


def test_signed_8_bit_image_spanning_more_than_127_grey_levels(tmp_path):
    # before: the histogram's offsets from the minimum wrapped round in int8 (100 - (-100) = -56) and numpy's
    # bincount raised "'list' argument must have no negative elements"
    pore = np.random.default_rng(4).random((12, 12, 12)) < 0.4
    np.save(tmp_path / "i8.npy", np.where(pore, -100, 100).astype(np.int8))
    ds = acquire(Settings(image=tmp_path / "i8.npy", voxel_um=1.0), tmp_path / "s.h5")[None]
    assert float(ds.porosity) == pore.mean()  # exact: both are count / 1728 in float64
    assert int(ds.grey_count.sum()) == pore.size and int(ds.grey_count[0]) == pore.sum()


@pytest.mark.parametrize(
    "statistics, match",
    [
        # before: "grain segmentation needs a 3-D image ... got shape (1, 1, 1) (a 2-D section ...)" of an 8³ image
        ({"grain_max_voxels": 1}, r"grain_max_voxels = 1 leaves a grain window of 1x1x1 voxels of the 8x8x8"),
        # before: MemoryError, the watershed's peak search asked for a (2 000 001)³ footprint (6.9 EiB)
        ({"grain_min_distance_um": 1e6}, r"grain_min_distance_um = 1000000.0 µm .* give at most 8 µm"),
    ],
)
def test_grain_window_and_marker_distance_that_cannot_work(statistics, match, tmp_path):
    rng = np.random.default_rng(5)
    np.save(tmp_path / "v.npy", np.where(rng.random((8, 8, 8)) < 0.4, 30, 220).astype(np.uint8))
    settings = Settings.model_validate(
        {"image": str(tmp_path / "v.npy"), "voxel_um": 1.0, "statistics": statistics}
    )
    with pytest.raises(PorepipeError, match=match):
        acquire(settings, tmp_path / "s.h5")
    assert not (tmp_path / "s.h5").exists()


@pytest.mark.parametrize("bad", [np.nan, -1.0, np.inf, 0.0])
def test_radius_fit_refuses_radii_that_are_not_positive_and_finite(bad):
    # before: dropped silently, the fit made from the rest
    with pytest.raises(PorepipeError, match=r"radii_um\[1\] = .*; allowed: positive, finite radii"):
        fit_radius_distribution([4.0, bad, 5.0, 6.0], [Family.uniform])


@pytest.mark.parametrize("shape", [(1, 8, 8), (1, 8, 1), (8, 1, 1)])
def test_nl_means_of_an_image_one_voxel_thick(shape):
    # before: (1, 8, 8) "Mean of empty slice" (a NaN noise level) and an (8, 8) result; the others an IndexError
    grey = np.random.default_rng(6).integers(0, 200, shape).astype(np.uint8)
    out = denoise(grey, "nl_means")
    assert out.shape == shape and out.dtype == np.uint8
    flat = np.full(shape, 50, np.uint8)
    np.testing.assert_array_equal(denoise(flat, "nl_means"), flat)  # a constant image stays as it is


def test_denoise_refuses_an_image_that_is_not_x_y_z():
    with pytest.raises(PorepipeError, match=r"denoise needs an \(X, Y, Z\) image"):  # before: IndexError
        denoise(np.zeros((4, 4), np.uint8), "median")
    with pytest.raises(PorepipeError, match="2 voxels or more"):  # before: "Mean of empty slice", NaN noise
        denoise(np.zeros((1, 1, 1), np.float32), "nl_means")


@pytest.mark.parametrize(
    "grey, match",
    [
        (np.array([-1e308, 1e308, 0.0]), "wider than the largest float64"),  # before: overflow warning
        (
            np.array([-3e38, 3e38, 0.0], np.float32),
            "wider than the largest float32",
        ),  # before: overflow, IndexError
        (np.array([np.nan, 1.0, 2.0]), "finite grey values"),  # before: numpy's "range of [nan, nan]"
        (np.zeros((0, 3, 3), np.float32), "non-empty image"),  # before: numpy's zero-size ValueError
        # before: numpy's "Too many bins for data range. Cannot create 256 finite-sized bins."
        (np.array([1.0, 1.0 + 1e-15]), r"span 1.0 to 1.000000000000001, too narrow for 256 bins at float64"),
        (np.array([1.0, 1.0000003], np.float32), "too narrow for 256 bins at float32 precision"),
    ],
)
def test_grey_histogram_refuses_values_it_cannot_bin(grey, match):
    with pytest.raises(PorepipeError, match=match):
        grey_histogram(grey)


@pytest.mark.parametrize("a", ["nan", "inf"])
def test_acquire_binary_refuses_a_resolution_that_is_not_finite(tmp_path, capsys, a):
    # before: int(round(a / voxel)) raised a raw ValueError (NaN) or OverflowError (inf) and exit code 1
    rng = np.random.default_rng(3)
    np.save(tmp_path / "v.npy", np.where(rng.random((8, 8, 8)) < 0.4, 30, 220).astype(np.uint8))
    acquire(Settings(image=tmp_path / "v.npy", voxel_um=2.0), tmp_path / "s.h5")
    capsys.readouterr()
    out = tmp_path / "b.h5"
    assert main(["acquire-binary", str(tmp_path / "s.h5"), "--a", a, "-o", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"porepipe acquire-binary: error: resolution a = {a} µm requested")
    # the value came from --a (the workflow fills it from resolutions_um): both are named
    assert line.endswith(
        "allowed: whole multiples of 2 µm (e.g. --a 4, or the scene's resolutions_um: [2, 4])"
    )
    assert not out.exists()


def test_acquire_binary_resolution_beyond_the_image_is_refused_compactly(tmp_path, capsys):
    # before: coarsen_pore refused a = 1e300 µm but printed the coarsening factor as a 300-digit integer
    rng = np.random.default_rng(3)
    np.save(tmp_path / "v.npy", np.where(rng.random((8, 8, 8)) < 0.4, 30, 220).astype(np.uint8))
    acquire(Settings(image=tmp_path / "v.npy", voxel_um=2.0), tmp_path / "s.h5")
    capsys.readouterr()
    out = tmp_path / "b.h5"
    assert main(["acquire-binary", str(tmp_path / "s.h5"), "--a", "1e300", "-o", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line == (
        "porepipe acquire-binary: error: resolution a = 1e+300 µm is 5e+299 voxels of 2 µm, more than the "
        "image's shortest edge of 8 voxels; allowed: whole multiples of 2 µm up to 16 µm"
    )
    assert not out.exists()


def test_grain_marker_distance_far_beyond_the_image_is_named_compactly(tmp_path):
    # before: the message gave the marker distance in voxels as a 300-digit integer
    rng = np.random.default_rng(5)
    np.save(tmp_path / "v.npy", np.where(rng.random((8, 8, 8)) < 0.4, 30, 220).astype(np.uint8))
    settings = Settings.model_validate(
        {"image": str(tmp_path / "v.npy"), "voxel_um": 1.0, "statistics": {"grain_min_distance_um": 1e300}}
    )
    with pytest.raises(PorepipeError) as err:
        acquire(settings, tmp_path / "s.h5")
    assert len(str(err.value)) < 200 and "is 1e+300 voxels" in str(err.value)
    assert not (tmp_path / "s.h5").exists()


def test_two_point_lag_beyond_the_image_stops_at_the_longest_axis(tmp_path):
    # before: max_lag_um = 1e300 asked numpy for a (3, 5e299) table: a raw ValueError, exit code 1
    rng = np.random.default_rng(6)
    np.save(tmp_path / "v.npy", np.where(rng.random((6, 8, 5)) < 0.4, 30, 220).astype(np.uint8))
    settings = Settings.model_validate(
        {
            "image": str(tmp_path / "v.npy"),
            "voxel_um": 2.0,
            "statistics": {"max_lag_um": 1e300, "grains": False},
        }
    )
    ds = acquire(settings, tmp_path / "s.h5")[None]
    assert ds.sizes["lag"] == 8  # lags 0..7 along y, the longest axis
    assert np.isfinite(float(ds.two_point.sel(axis="y").isel(lag=-1)))
    np.testing.assert_allclose(float(ds.two_point.sel(axis="x", lag=0)), float(ds.porosity), rtol=1e-12)


@pytest.mark.parametrize(
    ("option", "kind"),
    [
        (["--dataset", "image"], "hdf5"),
        (["--raw-dtype", "uint16"], "raw"),
        (["--raw-byte-order", "big"], "raw"),
        (["--raw-shape", "8", "8", "8"], "raw"),
    ],
)
def test_hdf5_and_raw_options_for_a_npy_image_are_refused(tmp_path, capsys, option, kind):
    # before: a .npy image was read as it is and these options were dropped without a word
    np.save(
        tmp_path / "v.npy",
        np.where(np.random.default_rng(7).random((8, 8, 8)) < 0.4, 30, 220).astype(np.uint8),
    )
    out = tmp_path / "s.h5"
    code = main(
        ["acquire", str(tmp_path / "v.npy"), *option, "--voxel-um", "1", "--no-grains", "-o", str(out)]
    )
    assert code == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert f"{option[0]} applies to {kind} images, but {tmp_path / 'v.npy'} is read as npy" in line
    assert not out.exists()


def test_raw_options_on_the_command_line_keep_the_scenes_other_raw_keys(tmp_path, capsys):
    # before: --raw-shape replaced the scene's whole acquire.raw, so its dtype uint16 fell back to uint8 and the
    # file was refused as twice the expected size
    grey = np.where(np.random.default_rng(8).random((6, 7, 8)) < 0.4, 3000, 60000).astype("<u2")
    (tmp_path / "v.raw").write_bytes(grey.tobytes(order="F"))
    (tmp_path / "scene.yaml").write_text(
        "name: raw16\nresolutions_um: [1]\nacquire:\n  image: v.raw\n  voxel_um: 1\n"
        "  raw: {dtype: uint16, shape: [1, 1, 1]}\n  statistics: {grains: false}\n"
    )
    out = tmp_path / "s.h5"
    assert (
        main(
            ["acquire", "--scene", str(tmp_path / "scene.yaml"), "--raw-shape", "6", "7", "8", "-o", str(out)]
        )
        == 0
    )
    assert read_attrs(out)["porosity"] == pytest.approx(np.mean(grey == 3000), abs=1e-12)
    capsys.readouterr()
    # a RAW option without any shape read the file as 1 x 1 x 1 voxels (or was dropped): it now asks for one
    code = main(
        ["acquire", str(tmp_path / "v.raw"), "--raw-dtype", "uint16", "--voxel-um", "1", "-o", str(out) + "2"]
    )
    assert code == 2
    assert "--raw-dtype needs the RAW image's shape: give --raw-shape NX NY NZ too" in capsys.readouterr().err


def _small_grain_statistics(r_lo: float, r_hi: float, spheres: int, porosity: float) -> xr.Dataset:
    """Statistics of a 32³ image of 2 µm voxels: 80 uncut grains of radii uniform in [r_lo, r_hi] µm, ``spheres``
    grains per (64 µm)³ box and the given porosity (what calibrated_scene reads)."""
    rng = np.random.default_rng(2)
    n = 80
    return xr.Dataset(
        {
            "inscribed_radius_um": ("grain", rng.uniform(r_lo, r_hi, n)),
            "cut": ("grain", np.zeros(n, np.int8)),
            "elongation": ("grain", rng.uniform(0.1, 0.5, n)),
            "grains_per_mm3": ((), spheres / 0.064**3),
            "porosity": ((), porosity),
        },
        attrs={"voxel_um": 2.0, "shape": np.array([32, 32, 32])},
    )


def test_calibrated_packing_of_small_grains_settles():
    # before: the calibrated stage had dt = 0.25 for grains of any size, unstable below r ~ 10 µm: grains of 3-6 µm
    # (an image of 2 µm voxels, or one whose grey phases were swapped so that the pores became the "grains")
    # boiled for all 400 steps (kinetic energy 4e3, overlaps 0.74 where 0.1 is allowed, 16 of 150 converged)
    from porepipe.packing import pack_spheres
    from porepipe.scene import parse_scene

    stats = _small_grain_statistics(3.0, 6.0, spheres=150, porosity=0.4)
    scene = calibrated_scene(stats, Calibration(decoration=False), name="small")
    stage = scene["packing"]["stages"][0]
    assert stage["dt"] * stage["damping"]["grain"] == pytest.approx(0.05, rel=1e-2)  # C- = 0.975 at any dt
    model = parse_scene({k: v for k, v in scene.items() if not k.startswith("_")})
    history = pack_spheres(model.packing, np.asarray(model.domain.size_um), True, seed=0).history
    # settled: kinetic energy per sphere below 2 % of a bond's depth k/4 (energy scales with k, which now follows
    # sigma_max): the boiling run had 4e3 / (150 k/4) = 0.27 at k = 400, the settled one 5540 / (150 k/4) = 0.014 at
    # k = 10 900, dt = 0.0109, after converging every sphere (largest overlap 0.0994) in 48 steps
    k = stage["k"]["grain"]
    assert history["kinetic_energy"][-1] < 0.02 * 150 * k / 4
    assert history["max_overlap"][-1] <= 0.1
    assert history["converged"][-1] == 150
    # grains of r >= 10.5 µm (σ = 0.1) are past the per-µm limit: 0.25 sqrt(400 / k) (ω dt as at k = 400, dt = 0.25;
    # ω ∝ sqrt(k)), or less where the core's push on a sphere inserted onto a neighbour, sqrt(k) (1 + k/4) / dx_eq,
    # would move it more than dx_eq / 2 in its first step: dt <= dx_eq / sqrt(sqrt(k) (1 + k/4)), binding here
    # (r_min = 12.2 µm, k = 10 900: 0.0436 against 0.0479)
    large = stats.assign(inscribed_radius_um=stats.inscribed_radius_um * 4)
    large_stage = calibrated_scene(large, Calibration(decoration=False), name="large")["packing"]["stages"][0]
    k_large, dx_eq = large_stage["k"]["grain"], 4 * stats.inscribed_radius_um.values.min() * (2.0 - 0.1)
    push_limit = dx_eq / np.sqrt(np.sqrt(k_large) * (1.0 + k_large / 4.0))
    assert large_stage["dt"] == pytest.approx(min(0.25 * np.sqrt(400.0 / k_large), push_limit), rel=5e-3)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_calibrated_packing_of_twice_the_grains_does_not_run_away(seed):
    # before: at k = 10 900 (sigma_max 0.1) the step 0.0139 let a sphere inserted onto a neighbour be pushed 26 µm in
    # one step (the core's force grows as k^1.5, dt² only as 1/k): 300 spheres of r 3-6 µm in the 64 µm box ran
    # away (PorepipeError) with seeds 1 and 2, as porosity matching of a dense image asks for such counts
    from porepipe.packing import pack_spheres
    from porepipe.scene import parse_scene

    rng = np.random.default_rng(2)
    n = 80
    stats = xr.Dataset(
        {
            "inscribed_radius_um": ("grain", rng.uniform(3.0, 6.0, n)),
            "cut": ("grain", np.zeros(n, np.int8)),
            "elongation": ("grain", rng.uniform(0.1, 0.5, n)),
            "grains_per_mm3": ((), 300 / 0.064**3),
            "porosity": ((), 0.3),
        },
        attrs={"voxel_um": 2.0, "shape": np.array([32, 32, 32])},
    )
    scene = calibrated_scene(stats, Calibration(decoration=False), name="dense-small")
    assert scene["packing"]["types"][0]["count"] == 300
    model = parse_scene({k: v for k, v in scene.items() if not k.startswith("_")})
    packing = pack_spheres(model.packing, np.asarray(model.domain.size_um), True, seed=seed)
    # and it packs: at most 5 % of the spheres left unconverged and deleted (the matching's MIN_KEPT)
    assert packing.radii_um.size >= 0.95 * 300 and packing.all_converged


def test_calibrating_an_image_looser_than_granular_media_warns_of_swapped_phases(tmp_path, capsys):
    # before: an image whose pores are bright (porosity 0.2 read as 0.8) was calibrated without a word, its pore
    # bodies taken for grains
    rng = np.random.default_rng(9)
    x = np.indices((32, 32, 32)).reshape(3, -1).T
    solid = np.zeros(x.shape[0], bool)
    for centre, radius in zip(rng.random((70, 3)) * 32, rng.uniform(4, 6, 70)):
        d = np.abs(x - centre)
        solid |= (np.minimum(d, 32 - d) ** 2).sum(axis=1) < radius**2
    bright_pores = np.where(solid.reshape(32, 32, 32), 60, 190).astype(np.uint8)
    np.save(tmp_path / "v.npy", bright_pores)
    statistics = tmp_path / "s.h5"
    acquire(Settings(image=tmp_path / "v.npy", voxel_um=10.0), statistics)
    assert float(read_attrs(statistics)["porosity"]) > 0.6
    capsys.readouterr()
    out = tmp_path / "model.yaml"
    assert main(["acquire-calibrate", str(statistics), "-o", str(out)]) == 0
    # one warning (other lines, e.g. a first run's "compiling kernels" notice, are not this test's)
    (warning,) = [line for line in capsys.readouterr().err.splitlines() if "warning:" in line]
    assert warning.startswith(f"porepipe acquire-calibrate: warning: {statistics} has porosity 0.")
    assert warning.endswith("set acquire.segmentation.invert: true and rerun acquire")
    assert out.exists()  # a warning, not a refusal: loose granular media exist


@pytest.mark.parametrize("scale", [1.0, 1e-200, 1e150, 1e300])
def test_otsu_threshold_does_not_depend_on_the_grey_scale(scale):
    # before: at 1e150 and more Otsu's between-class variance overflowed to inf and the first bin won: threshold
    # 6.1 (x scale) instead of 19.6, the 15-grey phase counted as matrix
    rng = np.random.default_rng(10)
    grey = np.concatenate([rng.normal(10, 1, 3000), rng.normal(15, 1, 3000), rng.normal(100, 1, 4000)])
    with np.errstate(over="raise", invalid="raise"):
        phases = segment_phases((grey * scale).reshape(20, 50, 10), Segmentation())
    # 18.5: the unscaled image's threshold (a bin centre between the 15 and 100 phases)
    assert phases.thresholds[0] / scale == pytest.approx(18.51, abs=0.01)
    assert phases.pore().mean() == pytest.approx(0.5997, abs=1e-12)  # 3 of the 15-grey voxels lie above it


@pytest.mark.parametrize("method", [[], ["--method", "thresholds", "--thresholds", "50"]])
def test_image_without_voxels_is_refused_as_such(tmp_path, capsys, method):
    # before: "the image has 0 populated grey value(s) []: otsu cannot split it", or with thresholds the
    # Minkowski check's "(a 2-D section: stack serial sections ...)" after NaN warnings from the chord lengths
    np.save(tmp_path / "v.npy", np.zeros((0, 20, 20), np.uint8))
    out = tmp_path / "s.h5"
    assert main(["acquire", str(tmp_path / "v.npy"), "--voxel-um", "1", *method, "-o", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line == f"porepipe acquire: error: image {tmp_path / 'v.npy'} has shape (0, 20, 20): no voxels"
    assert not out.exists()


def test_raw_image_one_voxel_thick_is_a_section(tmp_path):
    # before: a RAW section (--raw-shape NX NY 1) was refused as a volume too thin for S_V/K_V/T_V, with the advice
    # to stack serial sections, where the same pixels as a 2-D file were measured as a section
    rng = np.random.default_rng(11)
    section = np.where(rng.random((20, 16)) < 0.4, 10, 200).astype(np.uint8)
    (tmp_path / "sec.raw").write_bytes(np.asfortranarray(section).tobytes(order="F"))
    np.save(tmp_path / "sec.npy", section)
    raw = Settings.model_validate(
        {"image": str(tmp_path / "sec.raw"), "voxel_um": 0.5, "raw": {"shape": [20, 16, 1]}}
    )
    from_raw = acquire(raw, tmp_path / "raw.h5")[None]
    from_npy = acquire(Settings(image=tmp_path / "sec.npy", voxel_um=0.5), tmp_path / "npy.h5")[None]
    assert read_attrs(tmp_path / "raw.h5")["is_2d"] == 1
    assert float(from_raw.porosity) == pytest.approx(np.mean(section == 10), abs=1e-12)
    xr.testing.assert_identical(from_raw.drop_attrs(), from_npy.drop_attrs())


def test_image_on_the_command_line_is_relative_to_the_working_directory(tmp_path, monkeypatch, capsys):
    # before: IMAGE with --scene was looked for beside the scene file ("image file sub/v.npy does not exist")
    np.save(
        tmp_path / "v.npy",
        np.where(np.random.default_rng(12).random((8, 8, 8)) < 0.4, 30, 220).astype(np.uint8),
    )
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "scene.yaml").write_text(
        "name: rel\nresolutions_um: [1]\nacquire:\n  voxel_um: 1\n  statistics: {grains: false}\n"
    )
    monkeypatch.chdir(tmp_path)
    assert main(["acquire", "v.npy", "--scene", "sub/scene.yaml", "-o", "s.h5"]) == 0
    assert read_attrs(tmp_path / "s.h5")["source"] == "v.npy"


def test_section_spacing_whose_cubic_resampling_cannot_fit_is_refused(tmp_path):
    # before: the resampled shape 20 x 20 x 2e301 overflowed int64 to a negative size ("negative dimensions are not
    # allowed"), and smaller excesses died in numpy's allocation error
    np.save(
        tmp_path / "v.npy",
        np.where(np.random.default_rng(13).random((20, 20, 20)) < 0.4, 30, 220).astype(np.uint8),
    )
    settings = Settings(image=tmp_path / "v.npy", voxel_um=1.0, section_um=1e300)
    with pytest.raises(PorepipeError) as err:
        acquire(settings, tmp_path / "s.h5")
    assert str(err.value).startswith(
        "voxels of 1 x 1 x 1e+300 µm resampled to cubes of 1 µm make 20 x 20 x 2e+301 voxels ("
    )
    assert str(err.value).endswith("check acquire.voxel_um and acquire.section_um (--voxel-um, --section-um)")
    assert not (tmp_path / "s.h5").exists()


@pytest.mark.parametrize("voxel", [1e-100, 1e-20, 1e20, 1e100])
def test_extreme_voxel_sizes_give_scaled_minkowski_numbers_or_one_line(tmp_path, capsys, voxel):
    """``acquire --voxel-um 1e100`` died with scipy's 'Rank of input points must be at least 3' and 1e-100 with 'SVD
    did not converge' (the Crofton weights); now S_V, K_V are those at 1 µm times a^-1, a^-2, and a T_V that is
    representable per µm³ but not per mm³ (1e-100 µm: ~1e307 µm⁻³) is one line, with no file, instead of -inf."""
    pore = (np.random.default_rng(1).random((12, 12, 12)) < 0.5).astype(np.uint8)
    np.save(tmp_path / "v.npy", pore * 200)
    assert main(["acquire", str(tmp_path / "v.npy"), "--voxel-um", "1", "-o", str(tmp_path / "ref.h5")]) == 0
    capsys.readouterr()
    out = tmp_path / "s.h5"
    code = main(["acquire", str(tmp_path / "v.npy"), "--voxel-um", repr(voxel), "-o", str(out)])
    if voxel == 1e-100:
        assert code == 2 and not out.exists()
        (line,) = capsys.readouterr().err.splitlines()
        assert "voxel_um = 1e-100 µm: T_V_per_mm3 is beyond the float64 range" in line
        return
    assert code == 0
    with (
        xr.open_dataset(tmp_path / "ref.h5", engine="h5netcdf") as ref,
        xr.open_dataset(out, engine="h5netcdf") as got,
    ):
        for name, k in (("phi_minkowski", 0), ("S_V_per_mm", -1), ("K_V_per_mm2", -2), ("T_V_per_mm3", -3)):
            assert float(got[name]) == pytest.approx(float(ref[name]) * voxel**k, rel=1e-12), name


def _images(tmp_path):
    grey = np.where(np.random.default_rng(9).random((8, 8, 8)) < 0.4, 30, 220).astype(np.uint8)
    grey.tofile(tmp_path / "v.xyz")
    grey.tofile(tmp_path / "v.raw")
    np.save(tmp_path / "v.npy", grey)
    np.save(tmp_path / "flat.npy", np.full((8, 8, 8), 7, np.uint8))
    with h5py.File(tmp_path / "v.h5", "w") as f:
        f["a"], f["b"] = grey, grey


@pytest.mark.parametrize(
    ("image", "options", "option_text", "key_text"),
    [
        ("v.xyz", [], "give it with --format (one of", "give it with acquire.format (one of"),
        ("v.h5", [], "give the image's dataset with --dataset (one of", "with acquire.dataset (one of"),
        (
            "v.raw",
            [],
            "give --raw-shape NX NY NZ (and --raw-dtype",
            "give acquire.raw (dtype, shape",
        ),
        ("v.raw", ["--raw-shape", "8", "8", "9"], "check --raw-shape, --raw-dtype, --raw-header", None),
        ("v.raw", ["--raw-shape", "8", "8", "8", "--raw-dtype", "bad"], "--raw-dtype = 'bad' is not", None),
        ("v.npy", ["--crop", "9", "2", "2"], "--crop = (9, 2, 2) exceeds the image shape", None),
        (
            "flat.npy",
            [],
            "use --method thresholds with --thresholds to say",
            "use acquire.segmentation.method",
        ),
    ],
)
def test_messages_name_the_option_on_the_command_line_and_the_key_in_a_scene(
    tmp_path, capsys, image, options, option_text, key_text
):
    # before: `porepipe acquire v.xyz` said "set acquire.format", a scene key, where the option is --format (and
    # likewise acquire.dataset, acquire.raw, acquire.crop.size, acquire.segmentation.method for their options)
    _images(tmp_path)
    out = tmp_path / "s.h5"
    assert main(["acquire", str(tmp_path / image), *options, "--voxel-um", "1", "-o", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert option_text in line and "acquire." not in line.replace("porepipe acquire: error: ", "")
    assert not out.exists()
    if key_text is None:
        return
    # the same image named by a scene (the workflow's way) is told in scene keys
    (tmp_path / "scene.yaml").write_text(
        f"name: s\nresolutions_um: [1]\nacquire:\n  image: {image}\n  voxel_um: 1\n"
    )
    assert main(["acquire", "--scene", str(tmp_path / "scene.yaml"), "-o", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert key_text in line and " --" not in line
    assert not out.exists()


def test_matching_a_dense_image_whose_first_packing_runs_away_raises_sigma_max():
    # before: a dense image (solid fraction 0.75: 280 spheres of r 4-7 µm in a 64 µm box) asked the first round for
    # more spheres than sigma_max 0.1 holds; inserted onto each other at k = 9 000 they were pushed apart so hard that
    # the packer stopped ("runaway sphere ... dt too large for k", seed 1) and acquire-calibrate ended with that error,
    # naming a dt and k the user never set. A run that runs away is a round that did not converge: sigma_max goes up.
    from porepipe.acquire._matching import match_statistics

    stats = _small_grain_statistics(4.0, 7.0, spheres=280, porosity=0.25)
    scene = calibrated_scene(stats, Calibration(decoration=False), name="dense", seed=1)
    rounds = match_statistics(scene, 0.25, None, 3)
    assert rounds[0]["packed"] is False and "runaway sphere" in rounds[0]["ran_away"]
    assert rounds[1]["max_overlap"] == pytest.approx(
        0.2
    )  # raised by one step of 0.1, as for a round not converged
    assert any(r["packed"] for r in rounds) and scene["_calibration"]["matched"]["converged"] is True
