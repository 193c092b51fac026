"""Honest output on real recordings: bounded damping-law sampling, baselines with their
support, and CLI text that prints every number it names with digits the interval supports.

Fast: synthetic windows and hand-built summaries; the sampler cases use one small simulated
viscous decay (20 s at 100 Hz) with deliberately hard laws or tiny budgets.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from dampfit.estimators import baselines
from dampfit.output import text as render
from dampfit.output.format import interval
from dampfit.analysis import _baselines_summary
from dampfit.inference.law_sampler import (MIN_BUDGET_STEPS, STEP_FACTOR, Budget,
                                    conditioning, sample_emcee, sample_laplace)
from tests._support.summaries import summary

# -- a minimal summary the text renderer accepts --------------------------------------------

def nonviscous(mass: bool = True) -> dict:
    """A summary whose chosen law is Coulomb (the catch/rattle cantilever's numbers)."""
    ceq = {"model": "coulomb", "amplitude_m": 0.0042,
           "c": ({"q05": 0.0017, "q50": 0.0057, "q95": 0.026} if mass else None),
           "zeta": {"q05": 0.019, "q50": 0.062, "q95": 0.28}}
    mc = {"preferred_model": "coulomb",
          "amplitude_dependence": {"detected": True, "p_viscous": 1e-9}}
    dm = {"models": {"coulomb": {"posterior": {
        "method": "emcee", "converged": False, "ill_conditioned": False,
        "stop_reason": "step budget reached (2000 steps = max(3 x the viscous sampler's 300 "
                       "steps, 2000))"}}}}
    s = summary(model_checks=mc, c_equivalent=ceq, damping_models=dm)
    if not mass:
        s["mass"] = {"value": None, "sd": None, "unit": "kg"}
    return s


# -- baselines: support and agreement --------------------------------------------------------


def decay(f_d=1.72, zeta=0.004, fs=100.0, duration=7.0, noise=0.0, seed=0):
    omega_n = 2 * math.pi * f_d / math.sqrt(1 - zeta**2)
    t = np.arange(int(duration * fs)) / fs
    a = 3.0 * np.exp(-zeta * omega_n * t) * np.cos(2 * math.pi * f_d * t + 0.3)
    return t, a + noise * np.random.default_rng(seed).standard_normal(t.size), zeta * omega_n


def test_short_support_log_decrement_is_flagged_and_printed_as_such():
    t, a, _ = decay(duration=7.0)  # 12 cycles in the window
    r = baselines.log_decrement(t, a, 100.0, (1.15, 2.58), mass=0.23, n_cycles=2)
    s = r.summary()
    assert s["n_cycles_used"] == 2 and s["n_cycles_window"] == pytest.approx(12.0, abs=0.1)
    assert s["supported"] is False and "2 cycles" in s["support_reason"]
    line = next(x for x in render.text(summary()).splitlines() if "log decrement" in x)
    assert "(only 2 of 12 cycles — not reliable)" in line


def test_a_long_clean_decay_is_supported_with_a_small_expected_spread():
    t, a, p = decay(f_d=1.72, zeta=0.003, fs=200.0, duration=60.0, noise=0.01)
    for fn in (baselines.log_decrement, baselines.envelope_pipeline):
        s = fn(t, a, 200.0, (1.2, 2.4)).summary()
        assert s["supported"] is True and s["support_reason"] is None, s
        assert baselines.REL_SD_FLOOR <= s["expected_rel_sd"] < 0.05
        assert abs(s["p"] / p - 1) < 3 * s["expected_rel_sd"]


def test_a_log_decrement_ending_in_the_noise_is_not_supported():
    """10 Hz, ζ = 0.02 over 10 s: the last peaks are noise peaks, δ measures the noise floor."""
    t, a, p = decay(f_d=10.0, zeta=0.02, fs=200.0, duration=10.0, noise=0.03)
    r = baselines.log_decrement(t, a, 200.0, (7.0, 14.0))
    assert abs(r.p / p - 1) > 0.3  # badly wrong ...
    assert r.supported is False and "noise" in r.support_reason  # ... and says so


def test_a_disagreeing_baseline_is_noted_in_the_summary_and_the_text():
    t, a, p = decay(duration=20.0, fs=100.0)
    res = {"log_decrement": baselines.log_decrement(t, a, 100.0, (1.15, 2.58), mass=0.23),
           "envelope_pipeline": None}
    post = {"q50": res["log_decrement"].p / 9.0, "sd": 0.02 * res["log_decrement"].p / 9.0}
    out = _baselines_summary(res, post)
    ld = out["log_decrement"]
    assert ld["agrees_with_posterior"] is False and "9x the posterior median" in ld["note"]
    assert out["envelope_pipeline"] is None
    # within the expected spread: agrees, no note
    near = _baselines_summary(res, {"q50": res["log_decrement"].p * 1.01, "sd": 1e-4})
    assert near["log_decrement"]["agrees_with_posterior"] is True
    assert near["log_decrement"]["note"] is None
    # no posterior of p (no sampling): unknown, not "agrees"
    assert _baselines_summary(res, None)["log_decrement"]["agrees_with_posterior"] is None
    s = summary()
    s["baselines"]["log_decrement"].update(supported=True, n_cycles_used=20.0)
    line = next(x for x in render.text(s).splitlines() if "log decrement" in x)
    assert "(disagrees with the posterior beyond its expected spread)" in line
    assert "not reliable" not in line


def test_an_agreeing_supported_baseline_carries_no_caveat():
    line = next(x for x in render.text(summary()).splitlines() if "envelope (seed paper baseline)" in x)
    assert "reliable" not in line and "disagrees" not in line


# -- CLI text --------------------------------------------------------------------------------


def test_digits_adapt_to_the_interval():
    text = render.text(summary())
    fn = next(x for x in text.splitlines() if x.strip().startswith("f_n"))
    assert "1.72031" in fn and "1.71992" in fn and "1.72068" in fn
    assert "[1.72, 1.72]" not in fn.replace(" ", "")
    assert interval(1.72031, 1.71992, 1.72068) == ("1.72031", "1.71992", "1.72068")
    # a wide interval does not pretend to six digits
    assert interval(0.0623456, 0.0191234, 0.2812345) == ("0.06", "0.02", "0.28")
    # tiny and huge values keep the interval's precision in scientific notation
    assert interval(1.234e-7, 1.1e-7, 1.3e-7) == ("1.23e-07", "1.10e-07", "1.30e-07")
    assert interval(3.2e9, 3.1e9, 3.35e9) == ("3.20e+09", "3.10e+09", "3.35e+09")
    # a point estimate takes the digits of its posterior interval, a baseline those of its
    # own expected spread (log decrement ± 30 %: two digits, not six)
    s = summary(least_squares={"c": 0.0201, "f_n": 1.7203117, "converged": True})
    text = render.text(s)
    assert "f_n = 1.72031" in text and "f_n = 1.72," not in text
    s["baselines"]["log_decrement"]["c"] = 0.1834567
    assert "c = 0.18," in render.text(s)
    # a width always shows at least two significant digits
    for lo, hi in ((0.99, 1.01), (619.1, 628.4), (0.004997, 0.005731)):
        _, a, b = interval((lo + hi) / 2, lo, hi)
        width = float(b) - float(a)
        assert width == pytest.approx(hi - lo, rel=0.1)


def test_small_numbers_get_their_own_exponent():
    """A median ten times smaller than its upper bound is 4e-06, not 0.4e-05 (one exponent
    per number; the interval's absolute precision, at least one significant digit)."""
    assert interval(4e-6, 1e-7, 2e-5) == ("4e-06", "1e-07", "2.0e-05")
    assert interval(9.96e-6, 0.0, 2e-5) == ("1e-05", "0", "2.0e-05")  # rounds up
    s = summary(c_equivalent={"model": "coulomb", "amplitude_m": 0.004,
                              "c": {"q05": 1e-7, "q50": 4e-6, "q95": 2e-5}})
    s["model_checks"] = {"verdict": "amplitude-dependent", "verdict_law": "coulomb",
                         "amplitude_dependence": {"p_viscous": 1e-9}}
    line = next(x for x in render.text(s).splitlines() if "c_equivalent" in x)
    assert "4e-06 [1e-07, 2.0e-05] N s/m" in line and "0.4e-05" not in line
    for text in interval(-4e-6, -2e-5, 1e-5):
        assert not text.lstrip("-").startswith("0.") or text == "0"


def test_a_baseline_caveat_gives_the_baselines_own_reason():
    s = summary()
    ld = s["baselines"]["log_decrement"]
    why = "the measured decay ln(a0/an) = 0.02 is within 2 expected sd (0.03) of the noise"
    ld.update(n_cycles_used=10.0, support_reason=why)
    line = next(x for x in render.text(s).splitlines() if "log decrement" in x)
    assert f"(not reliable: {why})" in line and "cycles — not reliable" not in line
    ld.update(n_cycles_used=2.0, support_reason="rests on only 2 cycles (fewer than 5); " + why)
    line = next(x for x in render.text(s).splitlines() if "log decrement" in x)
    assert f"(only 2 of 12 cycles — not reliable; {why})" in line


def test_c_equivalent_absent_or_extrapolated_is_said_in_the_table():
    s = nonviscous(True)
    s["model_checks"].update(verdict="misfit", verdict_law=None)
    s["c_equivalent"] = None
    s["missing"] = {"c_equivalent": "the verdict is misfit: no damping law describes this "
                                    "waveform, so the coulomb law's equivalent viscous c means "
                                    "nothing"}
    text = render.text(s)
    assert "c_equivalent    not given: the verdict is misfit" in text
    s = nonviscous(True)
    s["c_equivalent"].update(amplitude_m=1.0, extrapolated=True,
                             recorded_amplitude_range_m=[0.002, 0.02])
    line = next(x for x in render.text(s).splitlines() if x.strip().startswith("c_equivalent"))
    assert "coulomb law at 1 m displacement amplitude, EXTRAPOLATED beyond the recorded " \
           "0.002–0.02 m" in line


@pytest.mark.parametrize("odd", [5, "x", [1], [None, "a"], {"a": 1}, None, True])
def test_edited_new_fields_render_without_a_crash(odd):
    """The issue-19 fields of an edited summary.json (end_reason, missing, extrapolated,
    reaches_zero, verdict_reasons) of any type: the table renders, nothing raises."""
    s = nonviscous(True)
    s["window"]["end_reason"] = odd
    s["missing"] = odd if not isinstance(odd, dict) else {"c_equivalent": odd}
    s["c_equivalent"].update(extrapolated=True, recorded_amplitude_range_m=odd)
    s["model_checks"].update(verdict="inconclusive", verdict_reasons=odd, verdict_law=odd)
    s["parameters"]["p"]["reaches_zero"] = odd
    assert "c_equivalent" in render.text(s)


def test_mass_without_sd_says_so_instead_of_plus_minus_zero():
    text = render.text(summary())
    assert "mass 0.23 kg (sd not given)" in text and "± 0 kg" not in text
    s = summary(mass={"value": 0.23, "sd": 0.001, "unit": "kg"})
    assert "mass 0.23 ± 0.001 kg" in render.text(s)


@pytest.mark.parametrize("mass", [True, False])
def test_zeta_eq_is_printed_with_its_value_for_a_non_viscous_law(mass):
    text = render.text(nonviscous(mass))
    z = next(x for x in text.splitlines() if x.strip().startswith("zeta_eq"))
    assert "0.06 [0.02, 0.28]" in z
    ceq = [x for x in text.splitlines() if x.strip().startswith("c_equivalent")]
    if mass:
        assert len(ceq) == 1 and "[0.002, 0.026]" in ceq[0] and "N s/m" in ceq[0]
        assert "coulomb law at 0.0042 m" in ceq[0] and "NOT converged" in ceq[0]
    else:
        assert not ceq and "coulomb law at 0.0042 m" in z and "NOT converged" in z


# -- bounded work of the damping-law sampler -------------------------------------------------


@pytest.fixture(scope="module")
def viscous_case():
    """Least-squares + Laplace fits of every law to a clean simulated viscous decay."""
    from dampfit.signal import prepare as preprocess
    from dampfit.damping import assess
    from dampfit.damping import Settings
    from dampfit.inference.law_fit import Data
    from tests._support.reference_sim import noisy_recording, reference_decay

    m, f = 0.5, 3.0
    t = np.arange(0, 20.0, 0.01)
    a = reference_decay(t, m, m * (2 * np.pi * f) ** 2, 0.02, c=0.06)[2]
    rec = noisy_recording(t, a, 0.02 * np.max(np.abs(a)), seed=1, lead=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = preprocess.prepare(rec)
        fd = preprocess.fit_data(prep)
        res = assess(prep, fd, None, None, mass=m, settings=Settings("laplace"))
    return prep, Data.from_fit_data(fd), res


def test_budget_is_tied_to_the_viscous_sampler_in_steps_only():
    b = Budget.from_viscous(1000, 4.0)
    assert b.max_steps == STEP_FACTOR * 1000
    assert b.max_seconds is None  # the same seed, the same draws under any load (issue 34)
    assert Budget.from_viscous(200, None).max_steps == MIN_BUDGET_STEPS
    assert Budget.from_viscous().max_seconds is None  # no reference: reproducible steps only


def test_the_law_sampler_stops_at_its_step_budget_and_is_flagged(viscous_case):
    """A power law on a viscous decay with a step budget far below what it needs."""
    prep, data, res = viscous_case
    post = sample_emcee(res.fits["power"], data, prep.band, seed=1, min_ess=5000,
                        budget=Budget(max_steps=150, basis="test"))
    assert post.method == "emcee" and post.n_steps == 150 and not post.converged
    assert post.stop_reason.startswith("step budget reached")
    assert any("NOT converged" in w and "step budget reached" in w for w in post.warnings)
    d = post.diagnostics()
    assert d["converged"] is False and d["stop_reason"].startswith("step budget reached")
    assert d["budget"]["max_steps"] == 150 and d["ill_conditioned"] is False
    assert len(post.a0) > 0  # the draws made so far are still returned


def test_the_law_sampler_stops_at_its_wall_time_budget(viscous_case):
    prep, data, res = viscous_case
    post = sample_emcee(res.fits["power"], data, prep.band, seed=1, min_ess=1e6,
                        budget=Budget(max_steps=100000, max_seconds=0.0, basis="test"))
    assert not post.converged and post.stop_reason.startswith("wall-time budget reached")
    assert post.n_steps < 1000  # stopped after its first block, not after 100,000 steps


def test_an_ill_conditioned_law_is_flagged_not_sampled(viscous_case):
    """Friction or drag on a viscous decay: an optimum on the bound (fraction 0) is flagged."""
    prep, data, res = viscous_case
    law = next(m for m in ("coulomb", "quadratic") if res.fits[m].theta[1] <= 1e-9)
    mf = res.fits[law]
    why = conditioning(mf)
    assert why is not None and "prior bound" in why
    post = sample_emcee(mf, data, prep.band, seed=1)
    assert post.ill_conditioned and post.method == "laplace" and post.n_steps == 0
    assert not post.converged and "prior bound" in post.ill_conditioned_reason
    assert any("ill-conditioned" in w for w in post.warnings)
    # a law that only gets the Laplace approximation carries the flag in its entry too
    assert sample_laplace(mf, data, n_draws=50).ill_conditioned
    assert not sample_laplace(res.fits["viscous"], data, n_draws=50).ill_conditioned
    assert conditioning(res.fits["viscous"]) is None
    bad = type(mf)(**{**mf.__dict__, "cov": np.full((mf.k, mf.k), np.nan)})
    assert "not positive definite" in conditioning(bad)


# -- the whole pipeline's summary carries the new fields ---------------------------------------


def test_analysis_summary_passes_support_and_sampling_facts_through(analysed):
    an, _ = analysed
    s = an.summary()
    for name, b in s["baselines"].items():
        if b is None:
            continue
        assert {"n_cycles", "n_cycles_used", "n_cycles_window", "supported",
                "support_reason", "expected_rel_sd", "agrees_with_posterior",
                "note"} <= set(b), name
        assert b["agrees_with_posterior"] in (True, False)
    if s["damping_models"] is not None:
        for law, entry in s["damping_models"]["models"].items():
            assert "ill_conditioned" in entry["posterior"] and "stop_reason" in entry["posterior"]
    text = render.text(s)
    assert "log decrement" in text and "± 0.05 kg" in text
