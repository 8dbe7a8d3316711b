"""The report says which diffusion runs a limit stopped before diffusion.target_rel_error.

Truth: the result files' own root attributes (``target_met``, ``stopped_by``, ``rel_error``), written by real runs of
the diffusion stage on a tiny square capillary whose limits are chosen so that the stop is genuine: two rounds against
a target of 1e-6 (max_rounds), one wall hit allowed (max_wall_hits, after one round: no relative error yet) and a
target of 0.9 that two rounds meet. A result written before porepipe recorded the stop is the same file with the three
attributes deleted. The page must mark exactly the rows whose file says target_met = 0, with the limit the file
names, and show the relative error the file stores.
"""

import csv
import html
import math
import re
import shutil

import h5py
import pytest

from porepipe._shared.store import ResultWriter, read_attrs
from porepipe.diffusion import Settings, square_capillary
from porepipe.diffusion._run import run
from porepipe.report import build_report
from porepipe.report._length_series import parts as length_series_parts
from porepipe.report._settings import Settings as ReportSettings
from porepipe.sweep import build_sweep

TINY = {"batches": 4, "batch_particles": 20}
#: a_um -> the run's settings; None: an old-style result (run, then its stop attributes deleted)
RUNS = {
    0.04: Settings(**TINY, max_rounds=2, target_rel_error=1e-6),
    0.02: Settings(**TINY, max_rounds=2, target_rel_error=0.9),
    0.01: Settings(**TINY, max_wall_hits=1, target_rel_error=1e-6),
    0.005: None,
}
STOP_ATTRS = ("target_met", "stopped_by", "rel_error")
MARK = "⚠ stopped by "


def _binary(path, a):
    with ResultWriter(path, stage="segment", scene="t", scene_hash="abc") as w:
        w.write_volume("pore", square_capillary(4, 12).pore, voxel_um=a, periodic=(0, 0, 0))
    return path


def _strip_stop_attrs(path):
    with h5py.File(path, "a") as f:
        for key in STOP_ATTRS:
            del f.attrs[key]


def _report(scene, files):
    sweep = build_sweep(files, exponent="linear")
    with ResultWriter(scene / "sweep" / "sweep.h5", stage="sweep", scene="t") as w:
        w.write_table(sweep)
    return build_report(
        scene / "sweep" / "sweep.h5", scene / "report" / "index.html", settings=ReportSettings(dpi=40)
    ).read_text()


def _table(page, heading):
    """(column headers, rows of cell texts) of the first table under ``<h2>heading</h2>``."""
    part = page.split(f"<h2>{heading}</h2>")[1].split("<h2>")[0]
    table = re.search(r"<table>(.*?)</table>", part, re.S).group(1)
    head = [html.unescape(c) for c in re.findall(r"<th>(.*?)</th>", table)]
    rows = [
        [html.unescape(c) for c in re.findall(r"<td class=l>(.*?)</td>", tr)] for tr in table.split("<tr>")
    ]
    return head, [r for r in rows if r]


def _shown_equals_stored(shown: str, stored: float) -> bool:
    """A number printed to 2 significant digits equals ``stored`` within half a unit of its second digit."""
    if not math.isfinite(stored):
        return shown == "∞"
    return abs(float(shown) - stored) <= 0.5 * 10 ** (math.floor(math.log10(stored)) - 1)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """A scene folder with one diffusion result per entry of RUNS (axis z) and the report built from them."""
    root = tmp_path_factory.mktemp("stops") / "scene"
    files = []
    for a, settings in RUNS.items():
        binary = _binary(root / "segment" / f"binary_a{a:g}.h5", a)
        out = run(
            settings or Settings(**TINY, max_rounds=2), binary, root / "diffusion" / f"diffusion_a{a:g}_z.h5"
        )
        if settings is None:
            _strip_stop_attrs(out)
        files.append(out)
    return root, files, _report(root, files)


def test_the_limits_stop_the_runs_as_designed(scene):
    _, files, _ = scene
    attrs = {a: read_attrs(p) for a, p in zip(RUNS, files)}
    assert (attrs[0.04]["target_met"], attrs[0.04]["stopped_by"]) == (0, "max_rounds")
    assert (attrs[0.02]["target_met"], attrs[0.02]["stopped_by"]) == (1, "target_rel_error")
    assert (attrs[0.01]["target_met"], attrs[0.01]["stopped_by"]) == (0, "max_wall_hits")
    assert math.isfinite(attrs[0.04]["rel_error"]) and attrs[0.01]["rel_error"] == math.inf  # one round only
    assert not set(STOP_ATTRS) & set(attrs[0.005])


def test_report_marks_exactly_the_runs_a_limit_stopped(scene):
    root, files, page = scene
    head, rows = _table(page, "Knudsen diffusion")
    assert head[-2:] == ["rel. error (target)", "stopped before target"]
    by_a = {float(r[1]): r for r in rows if r[1] != "a → 0"}
    assert sorted(by_a) == sorted(RUNS)
    for a, path in zip(RUNS, files):
        attrs = read_attrs(path)
        rel_cell, stop_cell = by_a[a][-2:]
        if "target_met" not in attrs:  # old-style result: nothing extra
            assert rel_cell == "" and stop_cell == "", a
            continue
        assert stop_cell == ("" if attrs["target_met"] else MARK + attrs["stopped_by"]), a
        shown, target = re.fullmatch(r"(\S+) \(target (\S+)\)", rel_cell).groups()
        assert _shown_equals_stored(shown, attrs["rel_error"]), (a, shown, attrs["rel_error"])
        assert float(target) == RUNS[a].target_rel_error  # printed with %g: exact for these targets
    limit_rows = [r for r in rows if r[1] == "a → 0"]
    assert limit_rows and all(r[-2:] == ["", ""] for r in limit_rows)
    assert sum(MARK in cell for r in rows for cell in r) == 2
    assert "⚠ 2 diffusion run(s) ended before diffusion.target_rel_error" in page
    # the CSV carries the stored values exactly (repr), empty for the old-style and the limit rows
    with open(root / "report" / "diffusion.csv", newline="") as fh:
        csv_rows = {float(r["a_um"]): r for r in csv.DictReader(fh)}
    for a, path in zip(RUNS, files):
        attrs = read_attrs(path)
        assert csv_rows[a]["rel_error"] == (
            repr(float(attrs["rel_error"])) if "rel_error" in attrs else ""
        ), a
        assert csv_rows[a]["stopped_by"] == attrs.get("stopped_by", ""), a


def test_old_style_results_render_without_the_stop_columns(scene, tmp_path):
    _, files, _ = scene
    old_scene = tmp_path / "scene"
    old = []
    for path in files:
        copy = old_scene / "diffusion" / path.name
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(path, copy)
        if "target_met" in read_attrs(copy):
            _strip_stop_attrs(copy)
        old.append(copy)
    page = _report(old_scene, old)
    head, rows = _table(page, "Knudsen diffusion")
    assert head == ["", "a [um]", "W", "D_eff [m²/s]", "τ"]
    assert len(rows) == len(RUNS) + 1 and all(len(r) == len(head) for r in rows)
    assert "⚠" not in page


def test_length_series_marks_the_lengths_a_limit_stopped(tmp_path):
    """Two lengths, two rounds each: a first run against 1e-6 gives each length's relative error; a target between
    them lets the shorter tube (more transmitted particles, smaller error) meet it and leaves the longer one cut."""
    binary = _binary(tmp_path / "binary_a0.01.h5", 0.01)
    folder = tmp_path / "diffusion"
    probe = run(
        Settings(**TINY, lengths=[3, 12], max_rounds=2, target_rel_error=1e-6), binary, tmp_path / "p.h5"
    )
    with h5py.File(probe, "r") as f:
        errs = sorted(float(v) for v in f["series_rel_error"][()])
    assert errs[0] < errs[1]
    target = math.sqrt(errs[0] * errs[1])
    out = run(
        Settings(**TINY, lengths=[3, 12], max_rounds=2, target_rel_error=target),
        binary,
        folder / "diffusion_a0.01_z.h5",
    )
    with h5py.File(out, "r") as f:
        met = f["series_target_met"][()].tolist()
        rel = f["series_rel_error"][()].tolist()
        stopped = str(f.attrs["stopped_by"]).split(",")
    assert sorted(met) == [0.0, 1.0]
    html_parts = "".join(length_series_parts(folder, tmp_path))
    head, rows = _table(html_parts, "Length dependence of the Knudsen resistance (Mahler 2001 §3.6.4)")
    w_cells = rows[0][head.index("W ± 1σ")].split(", ")
    for cell, m, by in zip(w_cells, met, stopped):  # lengths [3, 12] are given in increasing order
        assert (MARK in cell) == (m == 0.0) and (m == 1.0 or cell.endswith(MARK + by)), cell
    reached = rows[0][head.index("rel. error of W (target)")]
    shown, shown_target = re.fullmatch(r"(.+) \(target (\S+)\)", reached).groups()
    assert all(_shown_equals_stored(s, r) for s, r in zip(shown.split(", "), rel))
    assert float(shown_target) == pytest.approx(target, rel=1e-5)  # %g: 6 significant digits
