"""A campaign of several-mode recordings (issue 21 item 8): the campaign pools the damper's
mode (the one each test's band isolates) and, with ``max_modes`` > 1, lists every test's
modes with the pooled one marked; summary.json, the text table and ``dampfit.load`` carry
them; a one-mode campaign's summary is unchanged (no ``modes``, no ``max_modes`` option)."""

from __future__ import annotations

import json

import pytest

import dampfit
from dampfit.errors import InputError
from dampfit.output import text_campaign
from tests._support.modes import SECOND_MODE, two_mode_recording

MASS = 0.8


def one_mode_recording(seed: int):
    """The same damper (0.8 kg, 3.3 Hz, ζ 0.006) ringing in its one mode only."""
    from dampfit import simulate as sim

    return sim.recording(sim.from_modal(MASS, 3.3, 0.006, seed=seed, u0=0.004, duration=40.0,
                                        sample_rate=100.0, noise_density=300.0))[0]


@pytest.fixture(scope="module")
def campaign():
    """Two two-mode tests and a one-mode test of one damper."""
    recs = [two_mode_recording(MASS, seed=s)[0] for s in (21, 22)] + [one_mode_recording(23)]
    return dampfit.analyze(recs, mass=MASS, mass_sd=0.01, max_modes=3, min_ess=300, seed=4)


@pytest.mark.heavy
def test_each_test_lists_its_modes_with_the_pooled_one_marked(campaign):
    s = campaign.summary()
    assert s["provenance"]["options"]["max_modes"] == 3
    f2 = SECOND_MODE[0]
    for t in s["tests"][:2]:
        m = t["modes"]
        assert m["n_modes"] == 2 and m["pooled_mode"] == 1 and m["reason"] is None
        low, high = m["modes"]
        assert low["pooled"] is True and high["pooled"] is False
        assert low["f_n"]["q05"] < 3.3 < low["f_n"]["q95"]
        assert high["f_n"]["q50"] == pytest.approx(f2, rel=0.01)
        assert high["zeta"]["q05"] < high["zeta"]["q95"]
        assert "c" not in high and "k" not in high  # no modal mass is invented
        assert m["rayleigh"] is not None and m["modes_evidence"]["n_modes"] == 2
    # the pooling is the damper's mode: c = 2·m·ζ·ω_n of the 3.3 Hz, ζ 0.006 mode
    c_true = 2 * MASS * 0.006 * 2 * 3.141592653589793 * 3.3
    c = s["parameters"]["c"]
    assert c["q05"] < c_true < c["q95"]


@pytest.mark.heavy
def test_the_table_shows_the_modes_and_load_reads_them_back(campaign, tmp_path):
    text = campaign.report()
    assert "modes of each test" in text and "mode 1 *" in text and "mode 2" in text
    campaign.save(tmp_path / "c.dampfit", figures=False)
    back = dampfit.load(tmp_path / "c.dampfit")
    assert back.summary()["tests"][1]["modes"] == json.loads(json.dumps(
        campaign.summary()["tests"][1]["modes"]))
    assert text_campaign.text(back.summary()) == text
    # the report lists every test's modes, and re-creating the folder asks for them again
    from dampfit.cli import main

    assert main(["report", str(tmp_path / "c.dampfit"), "--no-redraw"]) == 0
    md = (tmp_path / "c.dampfit" / "report.md").read_text()
    assert "Modes of each test" in md and "1 (pooled)" in md and "Rayleigh α" in md
    assert "--max-modes 3" in md


@pytest.mark.heavy
def test_a_test_without_modes_or_with_a_garbled_entry_still_prints(campaign, tmp_path):
    s = json.loads(json.dumps(campaign.summary()))
    s["tests"][0]["modes"] = {"modes": [], "reason": "too short\nfor 2 modes " + "x" * 400}
    s["tests"][1]["modes"] = {"modes": [3, "a", {"f_n": "x"}]}
    text = text_campaign.text(s)
    assert "not analysed: too short for 2 modes" in text and "x" * 200 not in text
    # a one-mode entry (the screen or the evidence settled it), edited into nonsense
    s["tests"][0]["modes"] = {"n_modes": 1, "modes": [], "modes_evidence": ["x"]}
    s["tests"][1]["modes"] = {"n_modes": True, "modes": [],
                              "modes_evidence": {"reason": "y\n" * 300}}
    text = text_campaign.text(s)
    assert "one mode (the pooled one)" in text and "not analysed: no modes" in text
    from dampfit.output.report import campaign as report_campaign

    _, blocks = report_campaign.build_campaign({"summary": s}, tmp_path, "2026-01-01")
    assert "one mode (the pooled one)" in str(blocks) and "not analysed" in str(blocks)


@pytest.mark.heavy
def test_one_mode_tests_share_one_line_of_the_terminal_table(campaign):
    """A campaign of many one-mode tests does not print a row of reasons for each: they share
    one line naming the tests (reasons stay in the report); a test with several modes keeps
    its rows, and a lone one-mode test its own row."""
    s = json.loads(json.dumps(campaign.summary()))
    multi = s["tests"][1]["modes"]
    assert len(multi["modes"]) >= 2
    one = {"n_modes": 1, "modes": [], "reason": None,
           "modes_evidence": {"reason": "one mode: after the mode at 2.1 Hz no peak stands out"}}
    s["tests"] = [dict(s["tests"][0], modes=dict(one)) for _ in range(5)] + [s["tests"][1]] + [
        dict(s["tests"][0], modes=dict(one))]
    text = text_campaign.text(s)
    assert "tests 1–5, 7: one mode (the pooled one)" in text
    assert "no peak stands out" not in text and "mode 2" in text
    s["tests"] = s["tests"][5:]  # the modal test and one one-mode test: its own row
    text = text_campaign.text(s)
    assert text.count("one mode (the pooled one): one mode: after the mode") == 1


def test_mode_of_mass_is_refused_for_a_campaign():
    recs = [two_mode_recording(MASS, seed=s, duration=10.0)[0] for s in (1, 2)]
    with pytest.raises(InputError, match="mode_of_mass apply to a single recording"):
        dampfit.analyze(recs, mass=MASS, max_modes=3, mode_of_mass=2)
    with pytest.raises(InputError, match="argument --max-modes: must be an integer from 1"):
        dampfit.analyze(recs, mass=MASS, max_modes=0)


@pytest.mark.heavy
def test_each_test_runs_the_same_modes_stage_as_a_single_recording(campaign):
    """The campaign's tests go through the one modes stage of a single recording: every mode
    carries its K-mode least squares (to read when the posterior did not converge), and the
    evidence has the screen that ran first."""
    for t in campaign.summary()["tests"][:2]:
        m = t["modes"]
        assert m["modes_evidence"]["screen"]["passed"] is True
        for row in m["modes"]:
            ls = row["least_squares"]
            assert ls["f_n"]["q05"] <= ls["f_n"]["value"] <= ls["f_n"]["q95"]
            assert row["f_n"]["q50"] == pytest.approx(ls["f_n"]["value"], rel=0.01)


@pytest.mark.heavy
def test_a_one_mode_test_is_screened_and_listed_as_the_pooled_mode(campaign):
    """A test with nothing beside the pooled mode is settled by the screen (no selection, no
    modal posterior) and the table says so instead of "not analysed"."""
    single = campaign.summary()["tests"][2]["modes"]
    assert single["n_modes"] == 1 and single["modes"] == [] and single["reason"] is None
    assert single["modes_evidence"]["screen"]["passed"] is False
    assert "evidence" not in single["modes_evidence"]  # the selection did not run
    assert "one mode (the pooled one)" in campaign.report()
