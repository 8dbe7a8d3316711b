"""Reaction studies (thesis Tables 4.2-4.4): one run per (w, w', w_follow) set, the selectivity against the same
system without the follow-up, and the report rows that put them beside the thesis's published numbers.

Truths: a set's η is the single run's η (the study adds bookkeeping, not physics); with common random numbers a
follow-up so improbable that it never fires gives S = 1 exactly; S falls as w_follow grows; the report's thesis
columns are the digest's Tables 4.2-4.4 (§6.5) and its porepipe column the study's own numbers, never the thesis's.
"""

import numpy as np
import pytest
from pydantic import ValidationError

from porepipe._shared.store import ResultWriter
from porepipe.diffusion import ReactionSettings, Settings, rough_capillary, square_capillary
from porepipe.diffusion._edmd import reactive_pore
from porepipe.diffusion._reaction_study import reaction_study, study_result
from porepipe.diffusion._run import _dataset
from porepipe.diffusion._settings import ReactionSet
from porepipe.report._reaction_tables import THESIS, parts, study_rows

CHANNEL = square_capillary(4, 16).pore
COMMON = dict(wall_law="isotropic", particles=1600, batches=8, seed=3)


def test_study_sets_equal_single_runs_and_selectivity_behaves():
    sets = [
        ReactionSet(w=0.1),
        ReactionSet(w=0.1, w_follow=1e-12),
        ReactionSet(w=0.1, w_follow=0.05),
        ReactionSet(w=0.1, w_follow=0.3),
        ReactionSet(w=0.1),  # a repeated set runs once
    ]
    study = reaction_study(CHANNEL, 2, sets, **COMMON)
    assert study["runs"] == 4
    single = reactive_pore(CHANNEL, 2, 0.1, **COMMON)
    assert study["series_eta"][0] == single["eta"] and study["series_eta"][4] == single["eta"]
    assert study["series_eta_err"][0] == single["eta_err"]
    s, s_err = study["series_selectivity"], study["series_selectivity_err"]
    assert np.isnan(s[0]) and np.isnan(s[4])  # no follow-up: no selectivity
    assert s[1] == 1.0  # common random numbers, no follow-up reaction fired
    assert 1.0 > s[2] > s[3] > 0.0 and np.all(s_err[1:4] > 0)


def test_series_in_settings_runs_the_study_and_bad_sets_are_refused():
    settings = Settings(
        setup="reaction",
        wall_law="isotropic",
        batches=8,
        reactions={"particles": 800, "series": [{"w": 0.5}, {"w": 0.01, "w_reverse": 0.01}]},
    )
    result = study_result(CHANNEL, settings, 2, 1.0, (False, False, False), seed=1)
    np.testing.assert_array_equal(result.arrays["series_w_reverse"], [0.0, 0.01])
    assert result.arrays["series_eta"][0] < result.arrays["series_eta"][1]  # η falls with w
    for bad, key in (({"w": 0.0}, "w"), ({"w": 0.1, "w_follow": 2}, "w_follow"), ({"w": 0.1, "v": 1}, "v")):
        with pytest.raises(ValidationError, match=key):
            ReactionSettings(series=[bad])


@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    """A real (small) study of a rough capillary written as the diffusion stage writes it."""
    settings = Settings(
        setup="reaction",
        wall_law="isotropic",
        batches=8,
        geometry={"kind": "rough", "a": 4, "length": 16},
        reactions={"particles": 800, "series": [{"w": 0.5}, {"w": 0.01, "w_follow": 0.01}, {"w": 0.3}]},
    )
    pore = rough_capillary(4, 16, 0.3, seed=1).pore
    result = study_result(pore, settings, 2, 1.0, (False, False, False), seed=2)
    folder = tmp_path_factory.mktemp("scene") / "diffusion"
    folder.mkdir()
    with ResultWriter(folder / "diffusion_a1_z.h5", stage="diffusion", scene="t") as w:
        w.write_table(_dataset(result, settings))
    return folder, result


def test_report_rows_put_porepipe_beside_the_published_tables(study_file, tmp_path):
    folder, result = study_file
    rows = study_rows(folder / "diffusion_a1_z.h5")
    # w = 0.3 is in no thesis table; w = 0.01 without follow-up was not run, so only two rows
    assert [(r["table"], r["w"], r["w_follow"]) for r in rows] == [("4.2", 0.5, 0.0), ("4.4", 0.01, 0.01)]
    eta, sel = rows
    assert (eta["thesis_A"], eta["thesis_B"], eta["thesis_C"]) == (0.17, 0.15, 0.15)  # digest §6.5, Table 4.2
    assert (sel["thesis_A"], sel["thesis_B"], sel["thesis_C"]) == (0.77, 0.72, 0.81)  # Table 4.4 set (1)
    assert eta["porepipe"] == result.arrays["series_eta"][0]
    assert sel["porepipe"] == result.arrays["series_selectivity"][1]
    assert eta["analogue"] == "C" and eta["porepipe"] != eta["thesis_C"]
    html = "".join(parts(folder, tmp_path))
    assert "Tables 4.2-4.4" in html and "0.17 ◀" not in html and "0.15 ◀" in html
    assert f"{eta['porepipe'] - 0.15:+.3f}" in html
    assert (tmp_path / "reactions.csv").read_text().count("\n") == 3


def test_thesis_tables_are_complete_and_without_a_study_there_is_no_section(tmp_path):
    """Digest §6.5: Table 4.2 has 5 w; Table 4.3 9 rows, whose 'no reverse' rows at w = 0.01 and 0.1 repeat Table
    4.2 (0.47/0.67/0.78, 0.30/0.30/0.35) and are kept once; Table 4.4 4 sets."""
    counts = {t: sum(1 for k in THESIS if k[0] == t) for t in ("4.2", "4.3", "4.4")}
    assert counts == {"4.2": 5, "4.3": 7, "4.4": 4}
    assert THESIS[("4.2", 0.01, 0.0, 0.0)] == (0.47, 0.67, 0.78)
    assert THESIS[("4.2", 0.1, 0.0, 0.0)] == (0.30, 0.30, 0.35)
    assert THESIS[("4.3", 0.2, 0.0, 0.0)] == (0.25, 0.23, 0.24)
    assert parts(tmp_path / "nothing", tmp_path) == []
