"""Spheres read from a file at the start of a stage (PackDEM ``init = file``): xyzr, dat and packing.h5 load the same
spheres; a stage started from a saved primary packing fills it; every bad file is refused with a message naming it."""

import numpy as np
import pytest

from porepipe._shared.errors import PorepipeError
from porepipe._shared.store import ResultWriter
from porepipe.packing import Settings, pack_spheres, sphere_overlaps
from porepipe.packing._io import write_packing
from porepipe.packing._settings import SphereFile
from porepipe.packing._setup import read_sphere_file

BOX = np.array([200.0, 200.0, 200.0])
TYPES = [
    {"name": "grain", "count": 12, "max_overlap": 0.3, "radius_um": {"min_um": 20, "max_um": 30}},
    {"name": "fines", "count": 60, "max_overlap": 0.25, "radius_um": {"min_um": 4, "max_um": 6}},
]
PRIMARY = {
    "name": "primary",
    "insert": ["grain"],
    "steps": 300,
    "dt": 0.25,
    "k": {"grain": 400},
    "damping": {"grain": 4},
    "stochastic_forces": {"step_size": 0.05},
}


def _settings(*stages):
    return Settings.model_validate({"types": TYPES, "stages": list(stages), "parallel_min_spheres": 10**9})


@pytest.fixture(scope="module")
def primary(tmp_path_factory):
    """A converged primary packing of the grains, saved as packing.h5, xyzr and dat."""
    d = tmp_path_factory.mktemp("primary")
    p = pack_spheres(_settings(PRIMARY), BOX, True, seed=3)
    assert p.all_converged
    with ResultWriter(d / "primary.h5", stage="pack") as w:
        write_packing(w, p)
    np.savetxt(d / "primary.xyzr", np.column_stack([p.centres_um, p.radii_um]), fmt="%.17g")
    rows = np.column_stack([np.arange(p.radii_um.size), p.types + 1, p.centres_um, p.radii_um])
    np.savetxt(d / "primary.dat", rows, fmt=["%d", "%d", "%.17g", "%.17g", "%.17g", "%.17g"])
    return d, p


@pytest.mark.parametrize(
    "name, extra", [("primary.h5", {}), ("primary.dat", {}), ("primary.xyzr", {"type": "grain"})]
)
def test_every_format_loads_the_same_spheres(primary, name, extra):
    d, p = primary
    spec = SphereFile(path=d / name, **extra)
    centres, radii, types = read_sphere_file(spec, _settings(PRIMARY), BOX, np.ones(3, bool))
    np.testing.assert_array_equal(centres, p.centres_um)  # %.17g text round-trips float64 exactly
    np.testing.assert_array_equal(radii, p.radii_um)
    np.testing.assert_array_equal(types, p.types)


def test_a_fill_stage_started_from_the_saved_primary_packing(primary):
    """Stage 1 reads the grains from the file (frozen) and adds fines: the grains are exactly those of the file,
    and every sphere kept satisfies 0 < max sigma <= sigma_max (checked independently of the engine's flags)."""
    d, p = primary
    fill = {
        "name": "fill",
        "insert_file": {"path": str(d / "primary.h5")},
        "insert": ["fines"],
        "steps": 400,
        "dt": 0.25,
        "frozen_types": ["grain"],
        "k": {"grain": 50, "fines": 20},
        "damping": {"fines": 2},
        "stochastic_forces": {"step_size": 0.05},
        "delete_unconverged": ["fines"],
    }
    out = pack_spheres(_settings(fill), BOX, True, seed=5)
    grains = out.types == 0
    np.testing.assert_array_equal(out.centres_um[grains], p.centres_um)
    np.testing.assert_array_equal(out.radii_um[grains], p.radii_um)
    assert (out.types == 1).sum() > 0
    sig, conv = sphere_overlaps(out.centres_um, out.radii_um, out.types, BOX, [True] * 3, [0.3, 0.25])
    assert conv.all() and out.all_converged
    assert (sig > 0).all() and (sig[grains] <= 0.3).all() and (sig[~grains] <= 0.25).all()


def test_relative_paths_are_read_from_the_scene_directory(primary):
    d, p = primary
    centres, _, _ = read_sphere_file(
        SphereFile(path="primary.h5"), _settings(PRIMARY), BOX, np.ones(3, bool), base_dir=d
    )
    np.testing.assert_array_equal(centres, p.centres_um)


def test_periodic_coordinates_are_wrapped_into_the_box(tmp_path):
    f = tmp_path / "s.xyzr"
    f.write_text("-10 210 100 25\n")
    centres, _, _ = read_sphere_file(
        SphereFile(path=f, type="grain"), _settings(PRIMARY), BOX, np.ones(3, bool)
    )
    np.testing.assert_allclose(centres, [[190.0, 10.0, 100.0]])


@pytest.mark.parametrize(
    "text, fmt, kind, message",
    [
        (None, "xyzr", None, "does not exist"),
        ("10 10 10 25\n", "xyzr", None, "has no types; set insert_file.type"),
        ("0 3 10 10 10 25\n", "dat", None, "type number 3"),
        ("0 1 10 10 10\n", "dat", None, "expected 6 columns"),
        ("10 10 10 50\n", "xyzr", "grain", r"r = 50.0 µm outside \[20.0, 30.0\]"),
        ("10 10 250 25\n", "xyzr", "grain", "outside the box"),
    ],
)
def test_bad_files_are_refused_naming_the_problem(tmp_path, text, fmt, kind, message):
    f = tmp_path / f"s.{fmt}"
    if text is not None:
        f.write_text(text)
    periodic = np.array([True, True, False])
    with pytest.raises(PorepipeError, match=message):
        read_sphere_file(SphereFile(path=f, type=kind), _settings(PRIMARY), BOX, periodic)


def test_a_packing_file_with_unknown_type_names_is_refused(primary):
    d, _ = primary
    other = Settings.model_validate(
        {
            "types": [{"name": "sand", "count": 1, "radius_um": {"min_um": 1, "max_um": 99}}],
            "stages": [{"insert": ["sand"]}],
        }
    )
    with pytest.raises(PorepipeError, match=r"type\(s\) \['grain'\] are not types of this scene"):
        read_sphere_file(SphereFile(path=d / "primary.h5"), other, BOX, np.ones(3, bool))


def test_an_unknown_type_name_in_insert_file_is_a_settings_error():
    with pytest.raises(ValueError, match=r"insert_file.type names unknown type"):
        _settings({"insert_file": {"path": "x.xyzr", "type": "gravel"}})
