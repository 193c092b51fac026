"""summary.json's ``damper.decay_check``: the recommended law's own free decay against the
recording, made when the recording is analysed so that the headline says what
``dampfit export`` will write (damping/decay_run.py, damping/damper.py, output/damper.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dampfit.damping import damper
from dampfit.output import damper as damper_rows
from tests.cli.test_fem_damper import _band_noise, _saturating_result
from tests._support.fem import write_damper_result


def _check(folder):
    sec = json.loads((folder / "summary.json").read_text())["damper"]
    sig = np.load(folder / "signals.npz")
    return sec, damper.decay_check(sec, sig["t"], sig["accel"])


@pytest.mark.parametrize("law", ["power", "coulomb", "quadratic"])
def test_a_decay_of_the_recommended_law_follows_it(tmp_path, law):
    """A noisy decay of each law, with that law as its headline: its run follows the
    measured envelope (within the scatter), and the headline's FEM row says the deck is the
    law."""
    folder = write_damper_result(tmp_path / law, law)
    _band_noise(folder, 0.01)
    sec, chk = _check(folder)
    assert chk["checked"] is True and chk["follows"] is True, chk
    assert chk["rms"] <= max(chk["scatter"], 0.001) and chk["n_peaks"] > 30
    sec["decay_check"] = chk
    row = dict(damper_rows.rows(sec))["FEM deck"]
    assert row.startswith("this law: its own free decay follows the measured envelope")


def test_a_law_that_misses_the_decay_is_said_to_give_way_to_the_measured_curve(tmp_path):
    """A damping that rises and levels off, headlined by the best quadratic law: the law's
    run misses the envelope by many times the scatter, and the headline says that the deck
    will be the measured curve, with '--law quadratic' for the law — the numbers export's
    own check gives (the same function)."""
    folder, _ = _saturating_result(tmp_path / "s")
    sec, chk = _check(folder)
    assert chk["checked"] is True and chk["follows"] is False
    assert chk["rms"] > 5 * chk["scatter"]
    sec["decay_check"] = chk
    row = dict(damper_rows.rows(sec))["FEM deck"]
    assert row.startswith("the measured force-velocity curve, not this law")
    assert "'--law quadratic' writes the law" in row
    assert f"{100 * chk['rms']:.2g} % rms" in row


def test_no_check_for_a_viscous_law_no_mass_or_too_few_peaks(tmp_path):
    folder = write_damper_result(tmp_path / "p", "power")
    sec, _ = _check(folder)
    sig = np.load(folder / "signals.npz")
    assert damper.decay_check({**sec, "law": "viscous"}, sig["t"], sig["accel"]) is None
    assert damper.decay_check({**sec, "mass": {"value": None}}, sig["t"], sig["accel"]) is None
    assert damper.decay_check({**sec, "status": "none"}, sig["t"], sig["accel"]) is None
    short = damper.decay_check(sec, sig["t"][:400], sig["accel"][:400])
    assert short["checked"] is False and "fewer than 30" in short["reason"]
    row = dict(damper_rows.rows({**sec, "decay_check": short}))["FEM deck"]
    assert row.startswith("this law (not checked against the measured decay:")


@pytest.mark.parametrize("bad", [
    "x", 3, [], {"checked": True}, {"checked": True, "rms": "1", "scatter": None},
    {"checked": "yes", "reason": 7}, {"checked": True, "rms": float("nan"), "scatter": 0.1,
                                      "follows": True}])
def test_an_edited_decay_check_never_breaks_the_headline(tmp_path, bad):
    folder = write_damper_result(tmp_path / "p", "power")
    sec, _ = _check(folder)
    rows = dict(damper_rows.rows({**sec, "decay_check": bad, "law": "<b>" * 30}))
    assert all(isinstance(v, str) for v in rows.values())
    assert len(rows.get("FEM deck", "")) < 600
