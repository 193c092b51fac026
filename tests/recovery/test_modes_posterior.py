"""Posterior of several modes (emcee over 2K parameters) on a simulated 2-mode decay: every
mode in every damping convention, the mode the mass belongs to, Rayleigh α, β from the draws,
the subspace baseline and the plain-data summary with bounds and pairs."""

from __future__ import annotations

import numpy as np
import pytest

from dampfit import physics_modal as pm
from dampfit import stages
from dampfit._options import SamplerSettings
from dampfit._json import jsonable
from dampfit.errors import InputError
from dampfit.estimators.subspace import subspace_modes
from dampfit.inference import modes_posterior as MP
from dampfit.signal import prepare as pp

from tests._support.modes import two_mode_recording

MASS = 0.8


@pytest.fixture(scope="module")
def two_mode_posterior():
    rec, truth = two_mode_recording(MASS)
    prep = pp.prepare(rec)
    stage = stages.modes_stage(prep, max_modes=2, mass=MASS,
                               sampler=SamplerSettings(seed=2, min_ess=400))
    return prep, truth, stage.selection, stage.posterior, stage


@pytest.mark.heavy
def test_each_mode_has_its_posterior_in_every_damping_convention(two_mode_posterior):
    _, truth, sel, post = two_mode_posterior[:4]
    assert sel.n_modes == 2 and post.converged and post.max_r_hat < 1.05
    rows = post.summary()
    assert [r["index"] for r in rows] == [1, 2]
    assert rows[0]["f_n"]["q50"] < rows[1]["f_n"]["q50"]  # ordered by frequency
    zeta, eta, q, delta = (post.draws(n) for n in ("zeta", "eta", "Q", "delta"))
    np.testing.assert_allclose(eta, 2 * zeta)
    np.testing.assert_allclose(q, 1 / (2 * zeta))
    f_d = post.draws("f_d")
    np.testing.assert_allclose(delta, 2 * np.pi * post.draws("p") / (2 * np.pi * f_d))
    for row, mode in zip(rows, truth["modes"]):
        for name in ("f_n", "zeta"):
            s = row[name]
            assert abs(s["q50"] - mode[name]) < 4 * s["sd"], (name, s, mode[name])
            assert s["r_hat"] < 1.05 and s["ess_bulk"] > 100
    # the mass belongs to the dominant mode (mode 1): c and k there only
    assert rows[0]["mass_mode"] and not rows[1]["mass_mode"]
    assert "c" in rows[0] and "k" in rows[0] and "c" not in rows[1]
    assert abs(rows[0]["c"]["q50"] - truth["c"]) < 4 * rows[0]["c"]["sd"]


@pytest.mark.heavy
def test_mode_of_mass_can_be_chosen_and_is_checked(two_mode_posterior):
    _, _, sel, _ = two_mode_posterior[:4]
    post = MP.sample(sel, mass=MASS, mode_of_mass=2, seed=3, min_ess=100, max_steps=400)
    rows = post.summary()
    assert rows[1]["mass_mode"] and "k" in rows[1] and "k" not in rows[0]
    k2 = MASS * (2 * np.pi * rows[1]["f_n"]["q50"]) ** 2
    assert rows[1]["k"]["q50"] == pytest.approx(k2, rel=1e-3)
    with pytest.raises(InputError, match="out of range: the recording has 2 modes"):
        MP.sample(sel, mass=MASS, mode_of_mass=3)


@pytest.mark.heavy
def test_rayleigh_from_the_posterior_draws(two_mode_posterior):
    _, truth, _, post = two_mode_posterior[:4]
    w = 2 * np.pi * post.draws("f_n")
    out = pm.rayleigh_summary(w, post.draws("zeta"))
    assert out["dof"] == 0 and out["statement"].startswith("exact")
    wt = np.array([m["omega_n"] for m in truth["modes"]])
    zt = np.array([m["zeta"] for m in truth["modes"]])
    exact = pm.rayleigh(wt, zt)
    for name in ("alpha", "beta"):
        s = out[name]
        assert abs(s["q50"] - exact[name]) < 4 * s["sd"]
    # (R1) through the two measured ζ
    med = out["zeta_fitted"]
    for i in range(2):
        assert med[i]["q50"] == pytest.approx(out["zeta_measured"][i]["q50"], rel=0.05)


@pytest.mark.heavy
def test_subspace_baseline_finds_both_modes(two_mode_posterior):
    prep, truth, _, _ = two_mode_posterior[:4]
    est = subspace_modes(prep, max_modes=3)
    assert len(est) == 2
    for e, mode in zip(est, truth["modes"]):
        assert e.f_n == pytest.approx(mode["f_n"], rel=1e-2)
        assert e.zeta == pytest.approx(mode["zeta"], rel=0.5)
        assert e.zeta_sd is None


@pytest.mark.heavy
def test_modal_summary_is_plain_data_with_bounds_pairs_and_rayleigh(two_mode_posterior):
    import json

    _, _, sel, post = two_mode_posterior[:4]
    out = MP.modal_summary(sel, post)
    json.dumps(out)  # plain data
    assert out["n_modes"] == 2 and out["mode_of_mass"] == 1 and len(out["modes"]) == 2
    assert len(out["pairs"]) == 1 and not out["pairs"][0]["flagged"]
    assert out["rayleigh"]["dof"] == 0
    assert [r["n_modes"] for r in out["modes_evidence"]["evidence"]] == [1, 2]
    for row in out["modes"]:
        # the posterior sd of a well-separated mode is near its Cramér–Rao bound
        ratio = row["zeta"]["sd"] / row["crlb_sd"]["zeta"]
        assert 0.6 < ratio < 1.7, ratio


@pytest.mark.heavy
def test_the_modes_stage_gives_plain_data_for_every_mode(two_mode_posterior):
    """stages.modes_stage: the selection and posterior it ran, and one JSON-safe summary with
    every mode's quantities, bound, P(K) and reason of every K, the pair and Rayleigh α, β."""
    import json

    _, truth, sel, post, stage = two_mode_posterior
    out = stage.summary
    assert json.loads(json.dumps(out, allow_nan=False)) == out
    assert out == jsonable(MP.modal_summary(sel, post) | {"sampling": out["sampling"]})
    assert out["n_modes"] == 2 and len(out["modes"]) == 2
    for row in out["modes"]:
        for name in ("f_n", "zeta", "p", "eta", "delta", "Q"):
            assert set(row[name]) >= {"mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk"}
            assert row[name]["q05"] <= row[name]["q50"] <= row[name]["q95"]
        assert row["crlb_sd"]["zeta"] > 0
    ev = out["modes_evidence"]["evidence"]
    assert [r["n_modes"] for r in ev] == [1, 2] and ev[0]["reason"] and not ev[1]["reason"]
    assert sum(r["probability"] for r in ev) == pytest.approx(1.0)
    assert out["pairs"][0]["modes"] == [1, 2] and out["pairs"][0]["flagged"] is False
    ray = out["rayleigh"]
    assert ray["alpha"]["q05"] < ray["alpha"]["q95"] and ray["beta"]["unit"] == "s"
    assert out["sampling"]["posterior_converged"] and out["sampling"]["max_r_hat"] < 1.05
    assert stage.seconds > 0
    # an analysis's modal posterior runs within its work budget, recorded with the run
    assert out["sampling"]["stop_reason"] == "converged"
    assert out["sampling"]["budget"]["max_steps"] == 2 * MP.STEPS_PER_MODE
    assert out["sampling"]["n_steps"] <= out["sampling"]["budget"]["max_steps"]


@pytest.mark.heavy
def test_a_step_budget_stops_the_modal_posterior_and_says_so(two_mode_posterior):
    """A budget the run cannot converge in (100 steps, one first block) stops it: not
    converged, the reason and the budget in ``sampling()``, a warning that the intervals are
    not reliable, and the summary carries the warning."""
    from dampfit.inference.law_sampler import Budget

    sel = two_mode_posterior[2]
    tiny = Budget(max_steps=100, basis="a test budget")
    post = MP.sample(sel, mass=MASS, seed=5, min_ess=400, budget=tiny)
    assert not post.converged and post.n_steps == 100
    assert post.stop_reason == "step budget reached (100 steps = a test budget)"
    (warning,) = post.warnings
    assert warning.startswith("modal posterior NOT converged after 100 steps (step budget "
                              "reached (100 steps = a test budget)")
    assert warning.endswith("the intervals of the 2 modes are not reliable")
    facts = post.sampling()
    assert facts["converged"] is False and facts["n_steps"] == 100
    assert facts["budget"] == {"max_steps": 100, "max_seconds": None,
                               "basis": "a test budget"}
    assert facts["wall_time_s"] > 0 and facts["n_walkers"] == 64
    assert warning in MP.modal_summary(sel, post)["warnings"]
    assert all(np.isfinite(row["zeta"]["q50"]) for row in post.summary())


@pytest.mark.heavy
def test_a_wall_time_budget_stops_the_modal_posterior_after_a_block(two_mode_posterior):
    from dampfit.inference.law_sampler import Budget

    sel = two_mode_posterior[2]
    spent = Budget(max_steps=20000, max_seconds=0.0, basis="no time at all")
    post = MP.sample(sel, seed=5, min_ess=400, budget=spent)
    assert not post.converged and post.n_steps == 100  # the first block, then the deadline
    assert post.stop_reason.startswith("wall-time budget reached (")
    assert post.stop_reason.endswith("> 0 s = no time at all) after 100 steps; max_steps 100 "
                                     "reproduces this stop on any machine")
    assert "wall-time budget reached" in post.warnings[0]
