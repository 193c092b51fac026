"""Amplitude-dependent frequency (softening/hardening): the backbone f(A) is estimated and the
damping estimate follows the drift instead of mistaking phase error for damping."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from dampfit.inference import least_squares as fit
from dampfit.signal import prepare as preprocess
from dampfit.output import text as render
from dampfit.damping.assessment import assess
from dampfit.damping import Settings
from tests._support.reference_sim import noisy_recording

F0, ZETA = 1.5, 0.004


def softening(kappa: float, seed: int = 0):
    """A viscous decay whose frequency falls with amplitude like a pendulum's:
    ω(a) = ω₀·(1 − κ·(a/a₀)²); κ = θ₀²/16 for a release at θ₀ [rad]. The displacement
    amplitude decays as e^{−pτ}, p = ζ·ω₀ (averaging: da/dt = −p·a whatever the frequency),
    and the acceleration is −Ω²·u with the instantaneous frequency Ω."""
    fs, w = 100.0, 2 * np.pi * F0
    t = np.arange(0.0, 40.0, 1 / fs)
    env = 0.05 * np.exp(-ZETA * w * t)
    omega = w * (1 - kappa * (env / env[0]) ** 2)
    a = -omega**2 * env * np.cos(np.cumsum(omega) / fs)
    return noisy_recording(t, a, 0.02, seed=seed, lead=1.0)


def summary_of(rec) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = preprocess.prepare(rec)
        fd = preprocess.fit_data(prep)
        ls = fit.least_squares(fd, float("nan"), prep.f0)
        return assess(prep, fd, ls, None, mass=1.0, settings=Settings("laplace")).summary()


@pytest.mark.parametrize("seed", [0, 1])
def test_a_softening_decay_gets_its_backbone_and_an_unbiased_zeta(seed):
    kappa = np.radians(60.0) ** 2 / 16  # a 60° pendulum: ≈ 7 % lower frequency at the start
    s = summary_of(softening(kappa, seed))
    trend = s["amplitude_curve"]["backbone"]["frequency_trend"]
    assert trend["rel_change"] < 0 and trend["rel_change"] + 3 * trend["rel_change_sd"] < 0
    wins = s["amplitude_curve"]["windows"]
    assert all(w["f_d_sd_hz"] > 0 for w in wins)
    big, small = max(wins, key=lambda w: w["amplitude_m"]), min(wins, key=lambda w: w["amplitude_m"])
    assert big["f_d_hz"] < small["f_d_hz"]  # softening: the large swings are slower
    assert s["amplitude_curve"]["backbone"]["phase_terms"] >= 1
    p = s["damping_models"]["models"]["viscous"]["parameters"]["p"]
    p_true = ZETA * 2 * np.pi * F0
    assert p["q05"] <= p_true <= p["q95"] or p["q50"] == pytest.approx(p_true, rel=0.03)
    # what following the drift buys: a constant-frequency fit reads phase error as damping
    rec = softening(kappa, seed)
    prep = preprocess.prepare(rec)
    constant = fit.least_squares(preprocess.fit_data(prep), float("nan"), prep.f0)
    assert constant.p > 1.1 * p_true
    assert s["model_checks"]["verdict"] == "misfit"


def test_the_cli_text_prints_the_backbone_only_when_the_frequency_drifts():
    drifting = summary_of(softening(np.radians(60.0) ** 2 / 16))
    steady = summary_of(softening(0.0))
    lines = render._backbone_lines(drifting)
    assert lines[0].startswith("  backbone") and "softening" in lines[0]
    assert lines[1].startswith("  drift followed (viscous, frequency drift modelled)  zeta = ")
    assert render._backbone_lines(steady) == []
