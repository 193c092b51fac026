"""``dampfit study`` with several modes: the ``modes`` field and ``max_modes``, the per-mode
bound's design, the pairing of found and true modes, rows per mode (a mode not found, a failed
run), tables per mode, and one-mode studies unchanged apart from ``mode``. (A real two-mode
study through the runner: tests/recovery/test_study_modes.py.)"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from dampfit import simulate as sim
from dampfit.cli import main
from dampfit.errors import InputError
from dampfit.inference import crlb
from dampfit.study import config as sconfig
from dampfit.study import modal, registry, tables
from dampfit.study.task import crlb_design, crlb_design_modes, run_task
from tests._support.hostile import one_error_line
from tests._support.modes import SECOND_MODE
from tests._support.study import _DELETE, AVAILABLE, base

#: The columns of a one-mode row before several modes, with ``mode`` second.
ONE_MODE_ROW = ["estimator", "mode"] + [f"{k}_{q}" for q in ("p", "f_n", "zeta", "c")
                                        for k in ("est", "true", "crlb", "err")] + [
    "c_lo", "c_hi", "covers_c", "zeta_lo", "zeta_hi", "covers_zeta", "runtime_s", "ok", "message"]


def modes_base(**over) -> dict:
    """A two-mode study table: 3.3 Hz (the mass's mode) and :data:`SECOND_MODE`, 10 s."""
    return base(**{"study__estimators": ["modes_least_squares", "hilbert"], "fixed__f_n": 3.3,
                   "fixed__modes": [list(SECOND_MODE)], "fixed__sample_rate": 100.0, **over})


# -- configuration ----------------------------------------------------------------------------

@pytest.mark.parametrize("over, match", [
    ({"fixed__modes": 8.91}, r"^\[fixed\] modes must be a list of modes, each \[f_n Hz, zeta, "
                             r"amplitude ratio, phase rad\], got 8.91$"),
    ({"fixed__modes": [[8.91, 0.012, 0.25]]}, r"^\[fixed\] modes: mode 1 must be \[f_n Hz, zeta, "
                                              r"amplitude ratio, phase rad\], got \[8.91, 0.012, 0.25\]$"),
    ({"fixed__modes": [[8.91, 0.012, "x", 0.5]]}, r"^\[fixed\] modes: mode 1 must be a finite number, got 'x'$"),
    ({"fixed__modes": [[8.91, 0.012, 0.25, math.nan]]}, r"mode 1 must be a finite number, got nan"),
    ({"fixed__modes": [[f, 0.01, 0.1, 0.0] for f in range(5, 13)]}, r"lists 8 modes; at most 7 extra"),
    ({"fixed__modes": _DELETE, "grid__modes": [[8.91, 0.012, 0.25, 0.5]]},
     r"^\[grid\] modes: mode 1 must be \[f_n Hz.*got 8.91$"),
    ({"fixed__modes": [[80.0, 0.012, 0.25, 0.5]]},
     r"^scenario the fixed scenario: modes: f_n = 80 Hz must be positive and below the Nyquist"),
    ({"fixed__modes": [[8.91, 1.2, 0.25, 0.5]]}, r"modes: need 0 <= zeta < 1"),
    ({"study__max_modes": 0}, r"^\[study\] max_modes must be an integer from 1 to 8, got 0$"),
    ({"study__max_modes": 2.5}, r"^\[study\] max_modes must be an integer from 1 to 8, got 2.5$"),
    ({"study__max_modes": 3, "study__estimators": ["hilbert"]},
     r"^\[study\] max_modes is used only by the several-mode estimators"),
])
def test_modes_config_errors_are_one_line(over, match):
    with pytest.raises(InputError, match=match):
        sconfig.parse(modes_base(**over), AVAILABLE)


def test_a_bad_modes_field_via_the_cli_is_one_line_and_exit_2(tmp_path, capsys):
    cfg = tmp_path / "m.toml"
    cfg.write_text('[study]\nreplicates = 1\nestimators = ["modes_pencil"]\n[grid]\nzeta = [0.01]\n'
                   '[fixed]\nf_n = 3.3\nmodes = [[8.91, 0.012]]\n')
    assert main(["study", str(cfg), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "[fixed] modes: mode 1 must be [f_n Hz, zeta" in one_error_line(capsys)
    assert not (tmp_path / "o").exists()


def test_a_campaign_study_refuses_extra_modes():
    d = {"study": {"replicates": 1, "mass": 1.0}, "grid": {"zeta": [0.01]},
         "fixed": {"f_n": 2.0, "modes": [[5.0, 0.01, 0.2, 0.0]]}, "campaign": {"tests": 2}}
    with pytest.raises(InputError, match=r"^modes \(extra modes\) cannot be simulated in a campaign"):
        sconfig.parse(d, AVAILABLE)


def test_modes_are_normalised_so_equal_configs_give_equal_ids():
    two = [[9.5, 0.02, 0.1, 1.0], [8.91, 0.012, 0.25, 0.5]]
    a = sconfig.parse(modes_base(fixed__modes=two), AVAILABLE)
    b = sconfig.parse(modes_base(fixed__modes=[[8.91, 0.012, 0.25, 0.5], [9.5, 0.02, 0.1, 1]]),
                      AVAILABLE)
    assert a.scenarios() == b.scenarios() and a.fingerprint() == b.fingerprint()
    assert a.scenarios()[0][1]["modes"] == sorted(two)
    assert a.has_modes and a.target == "zeta"  # c belongs to the mass's mode only
    # [] in a [grid] is the one-mode scenario with the id of a study without the field
    g = sconfig.parse(modes_base(fixed__modes=_DELETE, grid__modes=[[], two]), AVAILABLE)
    plain = sconfig.parse(modes_base(fixed__modes=_DELETE), AVAILABLE)
    assert g.scenarios()[0] == plain.scenarios()[0] and "modes" not in g.scenarios()[0][1]
    assert not plain.has_modes and plain.target == "c"
    # max_modes changes the runs of a several-mode estimator, so the fingerprint
    assert a.max_modes == 3 and all(t.max_modes == 3 for t in a.tasks())
    c = sconfig.parse(modes_base(fixed__modes=two, study__max_modes=2), AVAILABLE)
    assert c.fingerprint() != a.fingerprint() and c.tasks()[0].max_modes == 2
    # a study without several-mode estimators keeps its fingerprint (stored studies resume):
    # the value computed before several modes existed
    assert sconfig.parse(base(), AVAILABLE).fingerprint() == "9dafd70aab655ee2"


# -- the bound and the pairing ----------------------------------------------------------------

def test_crlb_design_modes_is_the_noise_free_simulated_acceleration():
    """Every mode's (p, ω_d, a_cos, a_sin) reproduce the simulated two-mode decay sample by
    sample (jitter, a hand-held start, an extra mode below the mass's)."""
    cfg = sim.from_modal(0.8, 3.3, 0.01, u0=0.004, duration=8.0, sample_rate=100.0, jitter=0.05,
                         noise_density=0.0, handheld=0.77, seed=4,
                         modes=[(8.91, 0.012, 0.25, 0.5), (1.7, 0.02, 0.4, -2.0)])
    rec, truth = sim.recording(cfg)
    d = crlb_design_modes(rec, truth)
    free = rec.time >= truth["t_release"]
    want = rec.axis("y")[free]
    tau = d["times"]
    got = sum(np.exp(-p * tau) * (a * np.cos(w * tau) + b * np.sin(w * tau))
              for p, w, a, b in d["modes"])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())
    assert [round(w / (2 * np.pi), 2) for _, w, _, _ in d["modes"]] == [1.7, 3.3, 8.91]
    assert d["mode_of_mass"] == 1 and d["sigma"] == crlb_design(rec, truth)["sigma"]


def test_a_far_extra_mode_barely_changes_the_mass_modes_bound():
    cfg = sim.from_modal(0.8, 3.3, 0.006, u0=0.004, duration=20.0, sample_rate=100.0,
                         noise_density=300.0, seed=1, modes=[SECOND_MODE])
    rec, truth = sim.recording(cfg)
    d = crlb_design_modes(rec, truth)
    two = crlb.bound_modes(d["times"], d["sigma"], d["modes"], drift_degree=0)
    one = crlb.bound(**crlb_design(rec, truth), drift_degree=0)
    assert two[0]["zeta"]["sd"] == pytest.approx(one["zeta"]["sd"], rel=0.02)
    assert two[1]["zeta"]["sd"] > two[0]["zeta"]["sd"]  # the weaker, more damped mode


def test_match_pairs_modes_one_to_one_by_nearest_frequency():
    assert modal.match([8.8, 3.31], [3.3, 8.91]) == {0: 1, 1: 0}
    assert modal.match([8.8], [3.3, 8.91]) == {1: 0}
    assert modal.match([3.2, 3.4, 9.0], [3.3, 8.91]) in ({0: 0, 1: 2}, {0: 1, 1: 2})
    assert modal.match([math.nan, 3.3], [3.3]) == {0: 1}
    assert modal.match([], [3.3]) == {}


# -- rows ---------------------------------------------------------------------------------------

def _mode_estimate(f_n, zeta, ok=True, message=""):
    p = zeta * 2 * math.pi * f_n
    return registry.Estimate("modes_least_squares", p, f_n, zeta, 2 * p, None, None,
                             zeta * 0.9, zeta * 1.1, ok, message, 0.5)


def test_rows_per_true_mode_a_mode_not_found_and_a_failed_run(monkeypatch):
    cfg = sconfig.parse(modes_base(), AVAILABLE)
    task = cfg.tasks()[0]
    one = registry.Estimate("hilbert", 0.12, 3.3, 0.0058, 0.24, None, None, None, None, True, "", 0.1)
    monkeypatch.setattr(registry, "run", lambda names, rec, mass, seed: [one])
    monkeypatch.setattr(modal, "run", lambda names, rec, mass, seed, max_modes: [
        [_mode_estimate(8.95, 0.0125)]])
    rows = run_task(task)["rows"]
    assert [(r["estimator"], r["mode"]) for r in rows] == [
        ("modes_least_squares", 1), ("modes_least_squares", 2), ("hilbert", 1)]
    miss, found, single = rows
    assert miss["ok"] is False and miss["message"] == "mode 1 not found: K = 1"
    assert miss["est_zeta"] is None and miss["true_zeta"] == pytest.approx(0.01)
    assert miss["crlb_zeta"] > 0 and miss["n_modes"] == 1
    assert found["ok"] and found["est_zeta"] == 0.0125 and found["true_zeta"] == 0.012
    assert found["covers_zeta"] is True and found["true_f_n"] == 8.91
    # c only on the mass's mode: none for the extra mode, even from an estimate that has one
    assert found["est_c"] is None and found["true_c"] is None and found["crlb_c"] is None
    assert single["true_c"] == pytest.approx(2 * 2 * math.pi * 3.3 * 0.01)
    assert single["crlb_c"] > 0 and "n_modes" not in single

    # an estimator that failed: every true mode ok=False with its reason
    monkeypatch.setattr(modal, "run", lambda names, rec, mass, seed, max_modes: [
        [registry.failed_estimate("modes_least_squares", "InputError: too short", 0.3)]])
    rows = run_task(task)["rows"]
    assert [r["message"] for r in rows[:2]] == ["InputError: too short"] * 2
    assert not any(r["ok"] for r in rows[:2]) and rows[0]["runtime_s"] == 0.3

    # a run that failed outright: per true mode, the one-mode estimator on the mass's mode
    low = sconfig.parse(modes_base(fixed__modes=[[1.5, 0.01, 0.3, 0.0]]), AVAILABLE).tasks()[0]

    def explode(*a, **k):
        raise RuntimeError("boom")

    monkeypatch.setattr(modal, "run", explode)
    rows = run_task(low)["rows"]
    assert [(r["estimator"], r["mode"]) for r in rows] == [
        ("modes_least_squares", 1), ("modes_least_squares", 2), ("hilbert", 2)]
    assert {r["message"] for r in rows} == {"run failed: RuntimeError: boom"}
    assert rows[0]["true_f_n"] == 1.5 and rows[2]["true_f_n"] == pytest.approx(3.3)


def test_one_mode_rows_are_unchanged_apart_from_mode():
    """A one-mode run: the old row layout with ``mode`` = 1 and the one-mode bound."""
    cfg = sconfig.parse(base(study__estimators=["hilbert", "log_decrement"]), AVAILABLE)
    task = cfg.tasks()[0]
    rows = run_task(task)["rows"]
    assert [list(r) for r in rows] == [ONE_MODE_ROW] * 2 and [r["mode"] for r in rows] == [1, 1]
    rec, truth = sim.recording(sconfig.sim_config(task.params, task.mass, task.seed))
    b = crlb.bound(**crlb_design(rec, truth), mass=1.0, mass_sd=0.0, drift_degree=0)
    assert rows[0]["crlb_zeta"] == b["zeta"]["sd"] and rows[0]["crlb_c"] == b["c"]["sd"]


# -- tables -------------------------------------------------------------------------------------

def _runs(rows) -> pd.DataFrame:
    return pd.DataFrame([{"scenario": "A", "label": "all", "true_zeta": 0.01, "crlb_zeta": 0.001,
                          "runtime_s": 1.0, **r} for r in rows])


def test_aggregate_and_ranking_per_mode():
    rows = []
    for mode, errs in ((1, [0.001, -0.001]), (2, [0.004, None])):
        for e in errs:
            rows.append({"estimator": "m", "mode": mode, "ok": e is not None,
                         "est_zeta": None if e is None else 0.01 + e, "err_zeta": e,
                         "covers_zeta": e is not None and abs(e) < 0.002})
    rows += [{"estimator": "s", "mode": 1, "ok": True, "est_zeta": 0.0105, "err_zeta": 0.0005,
              "covers_zeta": None}] * 2
    agg = tables.aggregate(_runs(rows), "zeta").set_index(["estimator", "mode"])
    assert list(agg.index) == [("m", 1), ("m", 2), ("s", 1)]
    assert agg.loc[("m", 1), "rmse_crlb"] == pytest.approx(1.0)
    assert agg.loc[("m", 2), "rmse_crlb"] == pytest.approx(4.0)
    assert agg.loc[("m", 2), "n_failed"] == 1 and agg.loc[("m", 2), "coverage"] == 0.0
    assert agg.loc[("m", 1), "coverage"] == 1.0
    rank = tables.ranking(agg.reset_index())
    assert list(zip(rank["rank"], rank["estimator"], rank["mode"])) == [
        (1, "s", 1), (2, "m", 1), (1, "m", 2)]
    assert rank.loc[2, "failed"] == pytest.approx(0.5)


def test_figures_label_modes_and_take_a_full_coverage(tmp_path):
    """Several modes: one column per estimator and mode; a coverage of 6/6 (whose Wilson upper
    end is 1 − ε in floating point) is drawn, not refused for a negative error bar."""
    from dampfit.study.figures import _per_mode, save_figures

    agg = pd.DataFrame([{"scenario": "A", "label": "all", "estimator": e, "mode": m,
                         "quantity": "zeta", "rmse_crlb": 1.2, "coverage": 1.0, "n_intervals": 6}
                        for e in ("a", "b") for m in (1, 2)])
    rank = tables.ranking(agg.assign(n=6, n_failed=0, rel_bias=0.0, median_runtime_s=1.0))
    _, order = _per_mode(agg, rank)
    assert order == ["a · mode 1", "b · mode 1", "a · mode 2", "b · mode 2"]
    paths = save_figures(agg, rank, tmp_path, "t")
    assert all(p.stat().st_size > 0 for p in paths)
