"""Campaign studies (``dampfit study`` with a [campaign] table, issue 12 item 4): validation of
the table, seeds and fingerprints, the scoring and the coverage tables, a tiny study through
the CLI on a local Dask cluster, and the same record from the same seed."""

from __future__ import annotations

import copy
import hashlib
import json
import math

import pandas as pd
import pytest

from dampfit.cli import main
from dampfit.errors import InputError
from dampfit.study import campaign as scampaign
from dampfit.study import config as sconfig
from dampfit.study import tables
from dampfit.study.runner import write_outputs
from dampfit.study.task import run_task
from tests._support.hostile import one_error_line
from tests._support.study import _DELETE, AVAILABLE, with_overrides

# 2 scenarios × 2 replicates of 2-test campaigns, 10 s at 50 Hz, a short sampler: fast, not
# converged (the tables count that), but every number is the analysis' own.
TINY = """
[study]
name = "tiny campaign"
replicates = 2
seed = 11
mass = 1.0

[grid]
c_spread = [0.0, 0.1]

[campaign]
tests = 2
max_steps = 200
min_ess = 20

[fixed]
f_n = 3.0
zeta = 0.02
duration = 10
sample_rate = 50
noise_density = 300
"""


def cbase(**over) -> dict:
    """A valid campaign study table; ``table__key=value`` overrides, ``_DELETE`` removes."""
    return with_overrides(
        {"study": {"replicates": 2, "mass": 1.0, "seed": 1},
         "grid": {"c_spread": [0.0, 0.1]},
         "campaign": {"tests": 3, "max_steps": 200, "min_ess": 20},
         "fixed": {"f_n": 3.0, "zeta": 0.02, "duration": 10.0, "sample_rate": 50.0}}, over)


# -- configuration ------------------------------------------------------------------------

@pytest.mark.parametrize("over, match", [
    ({"campaign__colour": 1}, r"unknown key \[campaign\] colour; known: tests, c_spread"),
    ({"campaign__tests": 1}, r"\[campaign\] tests must be an integer from 2 to 100"),
    ({"campaign__tests": 101}, r"\[campaign\] tests must be an integer from 2 to 100"),
    ({"campaign__tests": 3.0}, r"\[campaign\] tests must be an integer"),
    ({"campaign__tests": True}, r"\[campaign\] tests must be an integer"),
    ({"campaign__tests": "4"}, r"\[campaign\] tests must be an integer"),
    ({"campaign__tests": _DELETE}, r"tests is missing; give \[campaign\] tests"),
    ({"grid__tests": [2, 1]}, r"\[grid\] tests must be an integer from 2 to 100 \(recordings per campaign\), got 1"),
    ({"grid__tests": 3}, r"\[grid\] tests must be a list.*put single values in \[campaign\]"),
    ({"grid__tests": [2, 3]}, r"tests is in both \[grid\] and \[campaign\]"),
    ({"grid__c_spread": [-0.1]}, r"\[grid\] c_spread must be in \[0, 2\]"),
    ({"grid__c_spread": [0.0, 2.5]}, r"\[grid\] c_spread must be in \[0, 2\]"),
    ({"grid__c_spread": ["wide"]}, r"\[grid\] c_spread must be a finite number"),
    ({"campaign__c_spread": 0.1}, r"c_spread is in both \[grid\] and \[campaign\]"),
    ({"campaign__added_mass_fraction": 0.0}, r"added_mass_fraction must be in \(0, 100\]"),
    ({"campaign__added_mass_fraction": -1.0}, r"added_mass_fraction must be in \(0, 100\]"),
    ({"campaign__added_mass": [0.0, 0.5, 1.0], "campaign__added_mass_fraction": 1.0},
     r"added_mass \(one mass per test \[kg\]\) or added_mass_fraction, not both"),
    ({"campaign__added_mass": [0.0, 0.5]}, r"added_mass gives 2 value\(s\) for 3 tests"),
    ({"campaign__added_mass": [0.0, -0.5, 1.0]}, r"added_mass values must be in \[0, 1e\+06\] kg"),
    ({"campaign__added_mass": [0.5, 0.5, 0.5]}, r"added_mass needs at least 2 different masses"),
    ({"campaign__added_mass": "heavy"}, r"added_mass must be a list of numbers \[kg\]"),
    ({"campaign__added_mass": [0.0] * 101}, r"added_mass gives 101 values; a campaign has at most 100"),
    ({"campaign__tests": _DELETE, "campaign__amplitudes": [0.04]},
     r"amplitudes gives 1 value: a campaign needs at least 2 tests"),
    ({"campaign__amplitudes": [0.01, 0.02, 0.03], "fixed__u0": 0.04},
     r"u0 is set in \[grid\] or \[fixed\] and \[campaign\] amplitudes"),
    ({"campaign__amplitudes": [0.01, 0.02, 200.0]}, r"amplitudes values must be in \[0, 100\] m"),
    ({"campaign__tests": _DELETE, "grid__tests": [2, 3], "campaign__amplitudes": [0.01, 0.02]},
     r"amplitudes gives one value per test, so tests cannot be a \[grid\] axis"),
    ({"campaign__mass_sd": 0.1, "study__mass": _DELETE}, r"mass_sd cannot be used: .*not given"),
    ({"campaign__mass_sd": 0.1, "campaign__added_mass_fraction": 1.0},
     r"mass_sd cannot be used: the added-mass design estimates the mass itself"),
    ({"campaign__mass_sd": 0.6}, r"mass_sd 0.6 kg is more than half the mass 1 kg"),
    ({"campaign__mass_sd": -0.1}, r"\[campaign\] mass_sd must be a number of kilograms"),
    ({"campaign__added_mass_sd": 0.01}, r"added_mass_sd needs added masses"),
    ({"campaign__max_steps": 10}, r"\[campaign\] max_steps must be an integer from 100 to 1,000,000"),
    ({"campaign__max_steps": 10**9}, r"\[campaign\] max_steps must be an integer from 100"),
    ({"campaign__max_steps": 500.5}, r"\[campaign\] max_steps must be an integer"),
    ({"campaign__min_ess": 0}, r"\[campaign\] min_ess must be a number from 1 to 1e\+06"),
    ({"campaign__min_ess": math.inf}, r"\[campaign\] min_ess must be a finite number"),
    ({"study__estimators": ["hilbert"]}, r"\[study\] estimators is not used by a campaign study"),
    ({"study__max_replicates": {"bayes": 1}}, r"\[study\] max_replicates is not used by a campaign"),
    ({"fixed__tests": 3}, r"\[fixed\] tests is a campaign setting; put it in \[campaign\]"),
    ({"grid__max_steps": [100, 200]}, r"\[grid\] max_steps cannot be a \[grid\] axis; set it in "
                                      r"\[campaign\] \(axes: tests, c_spread, added_mass_fraction\)"),
    ({"fixed__c_spread": 0.1}, r"\[fixed\] c_spread is a campaign setting"),
    # 2 × 2 scenarios × 300 replicates = 1200 campaigns of 100 tests: 120,000 recordings
    ({"campaign__tests": 100, "study__replicates": 300, "grid__zeta": [0.01, 0.02],
      "fixed__zeta": _DELETE}, r"would simulate 120,000 recordings .* limit of 100,000"),
    # all tests together beyond the simulator's sample limit, or a test beyond its mass limit
    ({"campaign__tests": 100, "fixed__duration": 1e4, "fixed__sample_rate": 100.0},
     r"scenario c_spread=0.0: 100 tests of 10000 s at 100 Hz would be 1e\+08 samples"),
    ({"campaign__added_mass": [0.0, 1.0, 2e6]}, r"added_mass values must be in \[0, 1e\+06\] kg"),
    ({"campaign__added_mass_fraction": 100.0, "study__mass": 2e4},
     r"c_spread=0.0: test 2: mass = 1.02e\+06 kg is beyond the limit"),
])
def test_campaign_table_errors_name_the_key(over, match):
    with pytest.raises(InputError, match=match):
        sconfig.parse(cbase(**over), AVAILABLE)


def test_campaign_table_structure_errors():
    with pytest.raises(InputError, match=r"campaign must be a table \(\[campaign\]\)"):
        sconfig.parse({**cbase(), "campaign": 3}, AVAILABLE)
    no_campaign = cbase()
    no_campaign.pop("campaign")
    with pytest.raises(InputError, match=r"\[grid\] c_spread is a campaign setting; it needs a "
                                         r"\[campaign\] table"):
        sconfig.parse(no_campaign, AVAILABLE)
    with pytest.raises(InputError, match=r"unknown table\(s\) \[campaigns\]"):
        sconfig.parse({**cbase(), "campaigns": {}}, AVAILABLE)


def test_campaign_config_scenarios_tasks_and_fingerprint():
    cfg = sconfig.parse(cbase(), AVAILABLE)
    assert cfg.is_campaign and cfg.estimators == ("campaign",) and cfg.target == "c"
    assert cfg.varying == ["c_spread"] and cfg.n_runs == 4 and cfg.n_recordings == 12
    scen = cfg.scenarios()
    assert [p["c_spread"] for _, p in scen] == [0.0, 0.1] and all(p["tests"] == 3 for _, p in scen)
    tasks = cfg.tasks()
    assert all(t.mass_known and t.campaign == {"mass_sd": 0.0, "added_mass_sd": 0.0,
                                               "max_steps": 200, "min_ess": 20.0} for t in tasks)
    # the analysis settings are in the fingerprint (a stored study is not resumed with others)
    other = sconfig.parse(cbase(campaign__max_steps=300), AVAILABLE)
    assert other.fingerprint() != cfg.fingerprint()
    assert {t.key: t.seed for t in other.tasks()} == {t.key: t.seed for t in tasks}
    # an axis of tests: runs × tests recordings counted exactly
    axis = sconfig.parse(cbase(campaign__tests=_DELETE, grid__tests=[2, 5]), AVAILABLE)
    assert axis.n_runs == 8 and axis.n_recordings == 2 * 2 * (2 + 5)
    # added masses: the mass is the simulated bare mass, not given to the analysis
    added = sconfig.parse(cbase(campaign__added_mass_fraction=0.5, study__mass=2.0), AVAILABLE)
    assert added.added_mass_design and not added.mass_known and added.target == "c"
    params = added.scenarios()[0][1]
    assert scampaign.per_test(params, 2.0) == (3, 0.0, [0.0, 0.5, 1.0], None)
    listed = sconfig.parse(cbase(campaign__tests=_DELETE, campaign__added_mass=[0, 1, 3]),
                           AVAILABLE)
    assert listed.campaign["tests"] == 3 and listed.scenarios()[0][1]["added_mass"] == [0, 1, 3]
    # without a mass and without added masses the analysis reports ζ
    assert sconfig.parse(cbase(study__mass=_DELETE), AVAILABLE).target == "zeta"


def test_a_study_without_campaign_keeps_its_fingerprint():
    """Adding [campaign] support changed nothing for estimator studies: same fingerprint
    formula (no "campaign" key), same tasks."""
    d = {"study": {"replicates": 2, "estimators": ["hilbert"], "mass": 1.0},
         "grid": {"zeta": [0.01]}, "fixed": {"f_n": 2.0, "duration": 10.0}}
    cfg = sconfig.parse(d, AVAILABLE)
    core = {"seed": 0, "estimators": ["hilbert"], "mass": 1.0,
            "scenarios": sorted(sid for sid, _ in cfg.scenarios())}
    want = hashlib.sha256(json.dumps(core, sort_keys=True, separators=(",", ":")).encode())
    assert cfg.fingerprint() == want.hexdigest()[:16]
    assert not cfg.is_campaign and all(t.campaign is None for t in cfg.tasks())


def test_example_campaign_study_is_valid():
    from pathlib import Path

    cfg = sconfig.load(Path(__file__).parents[2] / "examples" / "study_campaign.toml", AVAILABLE)
    assert cfg.is_campaign and cfg.n_runs == 40 and cfg.n_recordings == 10 * 2 * (3 + 6)


def test_streams_are_separate_from_the_recordings_and_deterministic():
    a, z = scampaign.streams(123)
    assert (a, z) == scampaign.streams(123) and (a, z) != scampaign.streams(124)
    assert isinstance(a, int) and a >= 0 and math.isfinite(z)


# -- scoring and tables ------------------------------------------------------------------------

def _summary(c=(0.9, 1.0, 1.1), k=(95.0, 100.0, 105.0), zeta=(0.04, 0.05, 0.06),
             pred=(0.5, 1.0, 2.0), spread=(0.01, 0.05, 0.2), zero=True, converged=True):
    q = lambda t: {"q05": t[0], "q50": t[1], "q95": t[2]}  # noqa: E731
    return {"parameters": {"c": q(c), "k": q(k), "zeta": q(zeta), "f_n": None},
            "population": {"spread": {"p": q(spread)}, "spread_consistent_with_zero": zero,
                           "predictive": {"c": q(pred), "zeta": None}},
            "diagnostics": {"converged": converged, "n_steps": 400, "max_r_hat": 1.001,
                            "min_ess_bulk": 900.0, "importance_ess_fraction": 0.9,
                            "warnings": [] if converged else ["campaign posterior NOT converged"]},
            "checks": {"verdict": "consistent"}}


def test_score_flags_follow_the_truth():
    true = {"c": 1.05, "k": 100.0, "m0": None, "zeta": 0.07}
    row = scampaign.empty_row(3, False, true, c_spread=0.0, z_new=0.3)
    assert row["true_new_c"] == pytest.approx(1.05) and row["ok"] is False
    r = scampaign.score(_summary(), row)
    assert json.loads(json.dumps(r, allow_nan=False)) == r  # JSON-safe
    assert r["covers_c"] is True and r["covers_k"] is True and r["covers_zeta"] is False
    assert r["covers_m0"] is None and r["true_m0"] is None
    assert r["err_c"] == pytest.approx(1.0 - 1.05) and r["est_k"] == 100.0
    assert r["covers_predictive_c"] is True and r["covers_predictive_zeta"] is None
    # zero true spread: no spread interval to check, but "consistent with zero" is scored
    assert r["covers_spread"] is None and r["spread_zero_ok"] is True
    assert r["ok"] is True and r["converged"] is True and r["message"] == ""
    # a true spread: the spread interval is checked, zero-spread recognition is not
    row = scampaign.empty_row(3, False, true, c_spread=0.1, z_new=2.0)
    assert row["true_new_c"] == pytest.approx(1.05 * math.exp(0.2))
    r = scampaign.score(_summary(zero=False, converged=False), row)
    assert r["covers_spread"] is True and r["spread_zero_ok"] is None
    assert r["spread_zero_consistent"] is False and r["converged"] is False
    assert "NOT converged" in r["message"]


def _record(sid, rep, row, seed=1):
    return {"scenario": sid, "replicate": rep, "seed": seed, "pid": 1, "host": "h",
            "started": 0.0, "crlb_note": "", "rows": [row], "elapsed": 1.0}


def test_campaign_tables_count_coverage_refusals_and_failures(tmp_path):
    cfg = sconfig.parse(cbase(study__replicates=3), AVAILABLE)
    (s0, _), (s1, _) = cfg.scenarios()
    true = {"c": 1.05, "k": 100.0, "m0": None, "zeta": 0.05}
    zero = scampaign.empty_row(3, False, true, 0.0, 0.0)
    spread = scampaign.empty_row(3, False, true, 0.1, 0.0)
    records = [
        _record(s0, 0, {**scampaign.score(_summary(), zero), "runtime_s": 2.0}),
        _record(s0, 1, {**scampaign.score(_summary(c=(1.1, 1.2, 1.3), zero=False,
                                                   converged=False), zero), "runtime_s": 4.0}),
        _record(s0, 2, {**zero, "refused": "the recordings are not of one system",
                        "message": "the recordings are not of one system"}),
        _record(s1, 0, {**scampaign.score(_summary(), spread), "runtime_s": 3.0}),
        _record(s1, 1, {**scampaign.score(_summary(spread=(0.2, 0.3, 0.4)), spread),
                        "runtime_s": 3.0}),
        _record(s1, 2, {**spread, "message": "run failed: RuntimeError: boom"}),
    ]
    records = json.loads(json.dumps(records, allow_nan=False))  # as stored in runs.jsonl
    res = write_outputs(cfg, copy.deepcopy(records), tmp_path, figures=True, version="test")
    agg = res["aggregate"].set_index("label")
    a, b = agg.loc["c_spread=0"], agg.loc["c_spread=0.1"]
    assert (a["n"], a["n_refused"], a["n_failed"], a["n_not_converged"]) == (3, 1, 0, 1)
    assert (b["n"], b["n_refused"], b["n_failed"], b["n_not_converged"]) == (3, 0, 1, 0)
    assert (a["cover_c"], a["n_cover_c"]) == (0.5, 2)          # 1.05 in [0.9, 1.1], not [1.1, 1.3]
    assert (a["zero_spread_ok"], a["n_zero_spread_ok"]) == (0.5, 2)
    assert a["n_cover_spread"] == 0 and math.isnan(a["cover_spread"])
    assert (b["cover_spread"], b["n_cover_spread"]) == (0.5, 2)  # 0.1 in [0.01, 0.2], not [0.2, 0.4]
    assert b["n_zero_spread_ok"] == 0 and b["n_cover_m0"] == 0
    assert a["bias"] == pytest.approx(((1.0 - 1.05) + (1.2 - 1.05)) / 2)
    assert a["median_runtime_s"] == pytest.approx(3.0)
    pooled = res["ranking"]
    assert len(pooled) == 1 and pooled.loc[0, "label"] == "all" and pooled.loc[0, "n"] == 6
    assert (pooled.loc[0, "cover_c"], pooled.loc[0, "n_cover_c"]) == (0.75, 4)
    view = tables.coverage_view(pooled)
    assert view.loc[0, "c"] == "3/4 (0.75)" and view.loc[0, "zero_spread_ok"] == "1/2 (0.50)"
    assert "m0" not in view.columns  # no run defines it
    names = {p.name for p in tmp_path.iterdir()}
    assert {"runs.csv", "aggregate.csv", "ranking.csv", "summary.md", "coverage.png"} <= names
    assert "ranking.png" not in names  # no bound: no efficiency figure
    summary = (tmp_path / "summary.md").read_text()
    assert "# Campaign study: " in summary and "| all | 6 | 1 | 1 | 1 |" in summary
    runs = pd.read_csv(tmp_path / "runs.csv")
    assert len(runs) == 6 and set(runs["estimator"]) == {"campaign"}
    assert list(runs["c_spread"]) == [0.0] * 3 + [0.1] * 3


def test_campaign_figure_without_any_analysed_campaign(tmp_path):
    from dampfit.study.figures import save_campaign_figures

    cfg = sconfig.parse(cbase(), AVAILABLE)
    sid = cfg.scenarios()[0][0]
    row = scampaign.empty_row(3, False, {"c": 1.0, "k": 1.0, "m0": None, "zeta": 0.1}, 0.0, 0.0)
    runs = tables.runs_frame(cfg, [_record(sid, 0, {**row, "refused": "no"})])
    agg = tables.campaign_aggregate(runs, "c", keys=cfg.varying)
    assert agg.loc[0, "n_refused"] == 1 and agg.loc[0, "n_cover_c"] == 0
    assert save_campaign_figures(agg, tmp_path, "$x$") == [tmp_path / "coverage.png"]


# -- whole studies -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def tiny_study(tmp_path_factory):
    """The TINY campaign study, run once through the CLI on a local cluster of 1 worker."""
    d = tmp_path_factory.mktemp("campaign_study")
    cfg = d / "tiny.toml"
    cfg.write_text(TINY)
    out = d / "out"
    rc = main(["study", str(cfg), "--out", str(out), "--workers", "1", "--quiet"])
    return cfg, out, rc


@pytest.mark.heavy
def test_campaign_study_through_the_cli_writes_the_coverage_table(tiny_study, capsys):
    cfg, out, rc = tiny_study
    assert rc == 0
    names = {p.name for p in out.iterdir()}
    assert {"study.json", "runs.jsonl", "runs.csv", "aggregate.csv", "ranking.csv",
            "summary.md", "coverage.png"} <= names and "ranking.png" not in names
    runs = pd.read_csv(out / "runs.csv")
    assert len(runs) == 4 and set(runs["estimator"]) == {"campaign"}
    assert runs["ok"].all(), runs["message"].tolist()
    assert set(runs["design"]) == {"hierarchical"} and (runs["n_tests"] == 2).all()
    assert (runs["true_c"] > 0).all() and runs["est_c"].notna().all()
    assert runs["covers_c"].notna().all() and runs["covers_k"].notna().all()
    assert runs["covers_m0"].isna().all()
    # zero spread is scored only where the truth has none, the spread interval only where it has
    zero = runs["c_spread"] == 0.0
    assert runs.loc[zero, "spread_zero_ok"].notna().all() and runs.loc[~zero, "spread_zero_ok"].isna().all()
    assert runs.loc[zero, "covers_spread"].isna().all() and runs.loc[~zero, "covers_spread"].notna().all()
    agg = pd.read_csv(out / "aggregate.csv")
    assert list(agg["label"]) == ["c_spread=0", "c_spread=0.1"] and (agg["n"] == 2).all()
    for col in ("cover_c", "cover_k", "cover_predictive_c", "zero_spread_ok", "n_refused",
                "n_not_converged"):
        assert col in agg.columns
    assert (agg["n_cover_c"] == 2).all() and agg["cover_c"].between(0, 1).all()
    pooled = pd.read_csv(out / "ranking.csv")
    assert pooled.loc[0, "n"] == 4 and pooled.loc[0, "n_zero_spread_ok"] == 2
    summary = (out / "summary.md").read_text()
    assert "# Campaign study: tiny campaign" in summary and "## Coverage, all scenarios" in summary
    # rerunning the finished study recomputes nothing and prints the pooled coverage
    capsys.readouterr()
    assert main(["study", str(cfg), "--out", str(out), "--workers", "1"]) == 0
    printed = capsys.readouterr()
    assert "4 already stored" in printed.err and "(0 new)" in printed.out
    assert "predictive_c" in printed.out and "zero_spread_ok" in printed.out


@pytest.mark.heavy
def test_same_seed_gives_the_same_record(tiny_study):
    """A task run again here (another process than the study's worker) gives the record the
    study stored, but for timings and provenance."""
    cfg_path, out, _ = tiny_study
    cfg = sconfig.load(cfg_path, AVAILABLE)
    task = cfg.tasks()[-1]  # the second replicate of the scenario with spread
    stored = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    (want,) = [r for r in stored if (r["scenario"], r["replicate"]) == task.key]
    got = run_task(task)
    assert got["seed"] == want["seed"] == task.seed
    strip = lambda rows: [{k: v for k, v in r.items() if k != "runtime_s"} for r in rows]  # noqa: E731
    assert strip(got["rows"]) == strip(want["rows"])


def test_hostile_campaign_tables_exit_2_with_one_line(tmp_path, capsys):
    cases = [
        ("tests = 2", "tests = 1000", "[campaign] tests must be an integer from 2 to 100"),
        ("tests = 2", "tests = -3", "[campaign] tests must be an integer from 2 to 100"),
        ("tests = 2", "tests = 2\nwobble = 1", "unknown key [campaign] wobble"),
        ("min_ess = 20", "min_ess = \"many\"", "[campaign] min_ess must be a finite number"),
        ("c_spread = [0.0, 0.1]", "c_spread = [0.0, -0.1]", "[grid] c_spread must be in [0, 2]"),
        ("[campaign]", "[study.campaign]", "unknown key [study] campaign"),
    ]
    for old, new, message in cases:
        cfg = tmp_path / "bad.toml"
        cfg.write_text(TINY.replace(old, new, 1))
        out = tmp_path / "out"
        assert main(["study", str(cfg), "--out", str(out), "--quiet"]) == 2, message
        line = one_error_line(capsys)
        assert message in line, line
        assert not out.exists()


@pytest.mark.slow
def test_added_mass_campaign_run_scores_m0():
    """An added-mass campaign (3 tests, added masses 0 … 1.0·m0) with the default sampler:
    the analysis estimates m0 itself, and its interval and the others are scored."""
    cfg = sconfig.parse(cbase(grid__c_spread=[0.05], campaign__added_mass_fraction=1.0,
                              campaign__added_mass_sd=0.002, campaign__max_steps=20000,
                              campaign__min_ess=400, fixed__duration=20.0,
                              fixed__sample_rate=100.0), AVAILABLE)
    task = cfg.tasks()[0]
    assert not task.mass_known and task.params["added_mass_fraction"] == 1.0
    (row,) = run_task(task)["rows"]
    assert row["ok"], row["message"]
    assert row["design"] == "added-mass" and row["true_m0"] == 1.0
    assert row["est_m0"] == pytest.approx(1.0, rel=0.2)
    for flag in ("covers_c", "covers_k", "covers_m0", "covers_zeta", "covers_predictive_c",
                 "covers_spread"):
        assert row[flag] in (True, False), flag
    assert row["covers_predictive_zeta"] is None and row["spread_zero_ok"] is None
