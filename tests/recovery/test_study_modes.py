"""A two-mode study through the real runner: the several-mode estimators recover both modes of
a clear second mode near their bounds (per-mode rows, aggregates, ranking, summary, figures),
and a second mode too weak to be found is a failed row of that mode, not a crash."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from dampfit.study import config as sconfig
from dampfit.study.runner import run_study
from tests._support.modes import SECOND_MODE
from tests._support.study import AVAILABLE

CLEAR, WEAK = list(SECOND_MODE), [8.91, 0.012, 0.002, 0.5]  # amplitude ratios 0.25 and 0.002
STUDY = {
    "study": {"name": "two modes", "replicates": 2, "seed": 5,
              "estimators": ["modes_least_squares", "modes_pencil", "modes_bayes",
                             "least_squares"],
              "max_replicates": {"modes_bayes": 1}, "max_modes": 2},
    "grid": {"modes": [[CLEAR], [WEAK]]},
    "fixed": {"f_n": 3.3, "zeta": 0.006, "u0": 0.004, "duration": 20.0, "sample_rate": 100.0,
              "noise_density": 300.0},
}


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    cfg = sconfig.parse(STUDY, AVAILABLE)
    out = tmp_path_factory.mktemp("modes") / "s"
    result = run_study(cfg, out, workers=1, quiet=True)
    return cfg, out, result


@pytest.mark.heavy
def test_rows_per_estimator_and_true_mode(study):
    cfg, out, result = study
    runs = pd.read_csv(out / "runs.csv")
    clear, weak = (sid for sid, _ in cfg.scenarios())
    per_run = runs.groupby(["scenario", "replicate"])["estimator"].apply(list)
    assert per_run[(clear, 0)] == ["modes_least_squares"] * 2 + ["modes_pencil"] * 2 + \
        ["modes_bayes"] * 2 + ["least_squares"]
    assert per_run[(clear, 1)] == ["modes_least_squares"] * 2 + ["modes_pencil"] * 2 + \
        ["least_squares"]
    assert set(runs.loc[runs["estimator"] == "least_squares", "mode"]) == {1}
    c = runs[runs["scenario"] == clear]
    assert c["ok"].all(), c.loc[~c["ok"], "message"].tolist()
    assert np.allclose(c["err_zeta"], c["est_zeta"] - c["true_zeta"])
    assert set(c.loc[c["mode"] == 2, "true_f_n"]) == {8.91}
    assert (c["crlb_zeta"] > 0).all() and (c.loc[c["mode"] == 2, "true_c"].isna()).all()
    # both modes found, each within a few bounds of the truth
    assert (c.loc[c["estimator"] != "least_squares", "n_modes"] == 2).all()
    assert (c["err_zeta"].abs() < 5 * c["crlb_zeta"]).all()


@pytest.mark.heavy
def test_a_mode_too_weak_to_find_is_a_failed_row_of_that_mode(study):
    cfg, out, _ = study
    runs = pd.read_csv(out / "runs.csv")
    weak = cfg.scenarios()[1][0]
    w = runs[(runs["scenario"] == weak) & (runs["estimator"] == "modes_least_squares")]
    first, second = w[w["mode"] == 1], w[w["mode"] == 2]
    assert first["ok"].all() and (first["n_modes"] == 1).all()
    assert not second["ok"].any() and second["est_zeta"].isna().all()
    assert set(second["message"]) == {"mode 2 not found: K = 1"}
    assert (second["crlb_zeta"] > 0).all()  # the bound of the mode it missed is still there


@pytest.mark.heavy
def test_aggregate_ranking_summary_and_figures_per_mode(study):
    cfg, out, result = study
    agg = pd.read_csv(out / "aggregate.csv")
    assert set(agg["quantity"]) == {"zeta"}
    clear = agg[agg["label"] == agg["label"].iloc[0]].set_index(["estimator", "mode"])
    for est in ("modes_least_squares", "modes_pencil", "modes_bayes"):
        for mode in (1, 2):
            ratio = clear.loc[(est, mode), "rmse_crlb"]
            assert math.isfinite(ratio) and 0.05 < ratio < 5, (est, mode, ratio)
    assert clear.loc[("modes_least_squares", 2), "n_intervals"] == 2
    assert ("least_squares", 2) not in clear.index
    weak = agg[agg["label"] != agg["label"].iloc[0]].set_index(["estimator", "mode"])
    assert weak.loc[("modes_least_squares", 2), "n_failed"] == 2
    rank = pd.read_csv(out / "ranking.csv")
    assert list(rank.columns[:3]) == ["rank", "estimator", "mode"]
    assert list(rank["mode"]) == sorted(rank["mode"]) and set(rank["mode"]) == {1, 2}
    assert list(rank.loc[rank["mode"] == 2, "rank"]) == [1, 2, 3]
    summary = (out / "summary.md").read_text()
    assert "Several modes: `mode` numbers the simulated modes" in summary
    assert "| label | estimator | mode |" in summary
    assert (out / "ranking.png").stat().st_size > 0 and (out / "coverage.png").stat().st_size > 0
    pd.testing.assert_frame_equal(result["ranking"].reset_index(drop=True), rank,
                                  check_dtype=False)
