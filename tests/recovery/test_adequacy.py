"""Is one viscous c adequate? The verdict of dampfit.damping.checks.adequacy, calibrated.

The verdict (adequate / amplitude-dependent / misfit / inconclusive) is checked on

* constructed evidence — it is never "adequate" while one criterion is decisive against it,
  and a misfit is never explained by a damping law;
* simulated recordings through the real decision (prepare → fit data → the viscous pipeline's
  least squares → :func:`dampfit.damping.assess` with Laplace posteriors): viscous phone-like
  and lab-like decays (false alarms), amplitude-dependent decays from the exact nonlinear ODE
  (detection when ζ changes by ≥ 1.5× across the window) and distorted-but-viscous decays (a
  2nd harmonic in the fitted band, or pendulum-like softening) that must come out "misfit";
* the noise calibration: r is never below its white-noise value, and the absolute misfit rule.

Default run: a few replicates of each. ``-m slow``: 100 replicates per class (rates printed)
and every real recording in ../shared/data/real.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import dampfit
from dampfit.inference import least_squares as fit
from dampfit.inference import noise
from dampfit.signal import prepare as preprocess
from dampfit import simulate as sim
from dampfit.damping import assess, checks
from dampfit.damping import Settings
from tests._support.reference_sim import noisy_recording, reference_decay
from dampfit.errors import InputError

from tests._support.requirements import REAL


# ----------------------------------------------------------------------------- generators
def phone_viscous(i: int):
    """A realistic viscous phone recording (phone preset options, random f, ζ, noise, 1/f)."""
    r = np.random.default_rng(5000 + i)
    f_n = float(np.exp(r.uniform(np.log(0.7), np.log(8.0))))
    zeta = float(np.exp(r.uniform(np.log(0.002), np.log(0.03))))
    cfg = sim.preset("phone", k=0.33 * (2 * np.pi * f_n) ** 2, u0=0.03 / f_n,
                     c=2 * zeta * 0.33 * 2 * np.pi * f_n,
                     duration=float(r.uniform(30, 60)),
                     noise_density=float(np.exp(r.uniform(np.log(250), np.log(3000)))),
                     flicker=float(r.choice([0.0, 300.0])), seed=i)
    return sim.recording(cfg)[0]


def lab_viscous(i: int):
    """The paper's lab set-up (5.3 kg, 500 Hz) with random f, ζ, noise and duration."""
    r = np.random.default_rng(6000 + i)
    m, f_n = 5.3, float(r.uniform(1.0, 5.0))
    zeta = float(np.exp(r.uniform(np.log(0.002), np.log(0.02))))
    cfg = sim.preset("paper", k=m * (2 * np.pi * f_n) ** 2, c=2 * zeta * m * 2 * np.pi * f_n,
                     duration=float(r.uniform(20, 60)),
                     noise_density=float(np.exp(r.uniform(np.log(100), np.log(2000)))), seed=i)
    return sim.recording(cfg)[0]


def amplitude_dependent(i: int):
    """Quadratic drag or Coulomb friction plus a dashpot (exact ODE), white noise.

    Returns the recording and ``zeta_ratio(window)``: the true ζ_eq at the window's largest
    over its smallest displacement amplitude (energy-equivalent c of each law)."""
    r = np.random.default_rng(7000 + i)
    law = ("quadratic", "coulomb")[i % 2]
    f = float(np.exp(r.uniform(np.log(1.0), np.log(6.0))))
    m, u0, fs = 0.5, 0.02, 100.0
    w = 2 * np.pi * f
    z_lin = float(np.exp(r.uniform(np.log(0.003), np.log(0.01))))
    ratio = float(r.uniform(1.8, 4.0))
    c = 2 * m * w * z_lin
    kw = (dict(c=c, c2=(ratio - 1) * c / (8 / (3 * np.pi) * w * u0)) if law == "quadratic"
          else dict(c=c, F_c=0.3 * (ratio - 1) * c * np.pi * w * u0 / 4))
    t = np.arange(0, float(r.uniform(25, 45)), 1 / fs)
    u, _, a = reference_decay(t, m, m * w * w, u0, **kw)
    noise_sd = float(np.exp(r.uniform(np.log(0.003), np.log(0.03)))) * np.max(np.abs(a))
    rec = noisy_recording(t, a, noise_sd, seed=i, lead=1.0)

    def zeta_eq(amp):
        ce = (kw["c"] + 8 / (3 * np.pi) * kw.get("c2", 0.0) * w * amp
              + 4 * kw.get("F_c", 0.0) / (np.pi * w * amp))
        return ce / (2 * m * w)

    def zeta_ratio(window):
        def amp(tc):
            sel = (t >= tc - 1 / f) & (t <= tc + 1 / f)
            return float(np.max(np.abs(u[sel])))
        z = zeta_eq(np.array([amp(max(window[0], 1 / f)), amp(min(window[1], t[-1] - 1 / f))]))
        return float(z.max() / z.min())

    return rec, zeta_ratio


def _window_ratio(t, u, f, law_ratio):
    """``zeta_ratio(window)``: the true ζ change across a window from the displacement
    envelope ``u`` at times ``t`` [s] (frequency ``f`` [Hz]) and ``law_ratio(a_hi, a_lo)``."""
    def zeta_ratio(window):
        def amp(tc):
            sel = (t >= tc - 1 / f) & (t <= tc + 1 / f)
            return float(np.max(np.abs(u[sel])))
        a1, a2 = amp(max(window[0], 1 / f)), amp(min(window[1], t[-1] - 1 / f))
        return float(law_ratio(max(a1, a2), max(min(a1, a2), 1e-300)))
    return zeta_ratio


def power_dependent(i: int):
    """A power-law damper F = c_α·|u̇|^α·sgn(u̇) (exact ODE), α ∈ {0.3, 0.5, 1.6, 2.0}: ζ_eq
    ∝ a^(α−1). Returns the recording and ``zeta_ratio(window)``."""
    from dampfit.model.laws import lam

    r = np.random.default_rng(9000 + i)
    f = float(np.exp(r.uniform(np.log(1.0), np.log(6.0))))
    m, u0, fs = 0.5, 0.02, 100.0
    w = 2 * np.pi * f
    alpha = float(r.choice([0.3, 0.5, 1.6, 2.0]))
    z0 = float(np.exp(r.uniform(np.log(0.004), np.log(0.015))))  # ζ_eq at u0, roughly
    c_alpha = 2 * m * w * z0 / ((w * u0) ** (alpha - 1) * float(lam(alpha)) / np.pi)
    t = np.arange(0, float(r.uniform(25, 45)), 1 / fs)
    u, _, a = reference_decay(t, m, m * w * w, u0, c_alpha=c_alpha, alpha=alpha)
    noise_sd = float(np.exp(r.uniform(np.log(0.003), np.log(0.03)))) * np.max(np.abs(a))
    rec = noisy_recording(t, a, noise_sd, seed=i, lead=1.0)
    return rec, _window_ratio(t, u, f, lambda hi, lo: (hi / lo) ** abs(alpha - 1))


def moderate_dependent(i: int):
    """As :func:`amplitude_dependent` with a smaller dependence (ζ_eq at u0 1.15–1.8× the
    dashpot's): some decays change ζ by 1.25× or more across their window, some less."""
    r = np.random.default_rng(11000 + i)
    law = ("quadratic", "coulomb")[i % 2]
    f = float(np.exp(r.uniform(np.log(1.0), np.log(6.0))))
    m, u0, fs = 0.5, 0.02, 100.0
    w = 2 * np.pi * f
    z_lin = float(np.exp(r.uniform(np.log(0.003), np.log(0.01))))
    ratio = float(r.uniform(1.15, 1.8))
    c = 2 * m * w * z_lin
    kw = (dict(c=c, c2=(ratio - 1) * c / (8 / (3 * np.pi) * w * u0)) if law == "quadratic"
          else dict(c=c, F_c=0.3 * (ratio - 1) * c * np.pi * w * u0 / 4))
    t = np.arange(0, float(r.uniform(25, 45)), 1 / fs)
    u, _, a = reference_decay(t, m, m * w * w, u0, **kw)
    noise_sd = float(np.exp(r.uniform(np.log(0.003), np.log(0.03)))) * np.max(np.abs(a))
    rec = noisy_recording(t, a, noise_sd, seed=i, lead=1.0)

    def zeta_eq(amp):
        return (kw["c"] + 8 / (3 * np.pi) * kw.get("c2", 0.0) * w * amp
                + 4 * kw.get("F_c", 0.0) / (np.pi * w * amp))

    return rec, _window_ratio(t, u, f, lambda hi, lo: max(zeta_eq(hi), zeta_eq(lo))
                              / min(zeta_eq(hi), zeta_eq(lo)))


def distorted_viscous(i: int):
    """A viscous decay the linear model cannot describe: a 6–10 % 2nd harmonic of the
    acceleration (on the raw path, so that it reaches the fit), or pendulum-like softening
    ω(a) = ω₀·(1 − θ₀²/16·(a/a₀)²) for a 40–70° release."""
    r = np.random.default_rng(8000 + i)
    kind = ("harmonic", "softening")[i % 2]
    f = float(np.exp(r.uniform(np.log(0.8), np.log(6.0))))
    w = 2 * np.pi * f
    zeta = float(np.exp(r.uniform(np.log(0.002), np.log(0.01))))
    fs = float(r.uniform(6.6, 8.7)) * f if kind == "harmonic" else 100.0
    t = np.arange(0, float(r.uniform(25, 45)), 1 / fs)
    env = 5.0 * np.exp(-zeta * w * t)
    if kind == "harmonic":
        a = -env * np.cos(w * t) + r.uniform(0.06, 0.10) * env * np.cos(
            2 * w * t + r.uniform(0, 2 * np.pi))
        noise_frac = float(np.exp(r.uniform(np.log(0.002), np.log(0.006))))
    else:
        kappa = np.radians(r.uniform(40, 70)) ** 2 / 16
        a = -env * np.cos(np.cumsum(w * (1 - kappa * (env / env[0]) ** 2)) / fs)
        noise_frac = float(np.exp(r.uniform(np.log(0.003), np.log(0.02))))
    return noisy_recording(t, a, noise_frac * 5.0, seed=i, lead=1.0), kind


def verdict_of(rec):
    """The adequacy verdict through the real decision (no emcee)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = preprocess.prepare(rec)
        fd = preprocess.fit_data(prep)
        ls = fit.least_squares(fd, float("nan"), prep.f0)
        return assess(prep, fd, ls, None, settings=Settings("laplace")), prep


# ----------------------------------------------------------------------------- the rule
CLEAN = {"ljung_box_p": 0.4, "r_excess": 1.1, "resid_fraction": 0.01, "noise_excess": 1.0}
MISFIT = {"ljung_box_p": 1e-30, "r_excess": 8.0, "resid_fraction": 0.15, "noise_excess": 40.0}
SLOPE_NULL = {"s": 0.01, "s_sd": 0.02, "s_q05": -0.03, "s_q95": 0.05, "n_windows": 8,
              "chi2_per_dof": 1.0}
SLOPE_DECISIVE = {"s": 0.3, "s_sd": 0.05, "s_q05": 0.2, "s_q95": 0.4, "n_windows": 8,
                  "chi2_per_dof": 2.0}
FREQ_FLAT = {"g": 0.0, "g_sd": 1e-4, "rel_change": 0.0, "rel_change_sd": 1e-4, "n_windows": 8}
FREQ_DRIFT = {"g": -0.02, "g_sd": 1e-3, "rel_change": -0.016, "rel_change_sd": 1e-3,
              "n_windows": 8}


def rule(**kw):
    base = dict(n_cycles=100.0, slope=SLOPE_NULL, amplitude_span=3.0, freq=FREQ_FLAT,
                p_viscous=0.9, best_nonlinear="power", viscous=CLEAN, best=CLEAN,
                best_model="power", pipeline=CLEAN)
    base.update(kw)
    laws = checks.LawEvidence(*(base.pop(k, None) for k in checks.LawEvidence._fields))
    fits = checks.FitChecks(*(base.pop(k) for k in checks.FitChecks._fields))
    return checks.adequacy(**base, laws=laws, fits=fits)


def test_clean_viscous_evidence_is_adequate():
    out = rule()
    assert out["verdict"] == "adequate" and out["law"] is None
    assert any("P(one viscous c) = 0.9" in r for r in out["reasons"])


@pytest.mark.parametrize("kw, verdict", [
    (dict(slope=SLOPE_DECISIVE), "amplitude-dependent"),  # the windows alone
    (dict(p_viscous=1e-5, slope=None, n_cycles=60.0), "amplitude-dependent"),  # the evidence
    (dict(p_viscous=1e-5, slope=SLOPE_DECISIVE, viscous=MISFIT, pipeline=MISFIT),
     "amplitude-dependent"),  # the law explains the viscous misfit
    (dict(pipeline=MISFIT), "misfit"),  # the reported (constant-frequency) fit is off
    (dict(viscous=MISFIT, best=MISFIT, pipeline=MISFIT, p_viscous=1e-9,
          slope=SLOPE_DECISIVE), "misfit"),  # the best law misfits too: no law is named
    (dict(freq=FREQ_DRIFT), "misfit"),
    (dict(pipeline=MISFIT, p_viscous=1e-5, slope=SLOPE_DECISIVE),
     "misfit"),  # only the constant-frequency fit is off: the frequency drifts, not ζ
    (dict(p_viscous=1e-5), "inconclusive"),  # law evidence the windows contradict
    (dict(p_viscous=0.3), "inconclusive"),
    (dict(slope={**SLOPE_DECISIVE, "s_sd": 0.12, "s_q05": 0.08, "s_q95": 0.52}),
     "inconclusive"),  # 90 % interval excludes 0, 99 % does not
    (dict(n_cycles=8.0, slope=None), "inconclusive"),
])
def test_never_adequate_while_a_criterion_is_decisive(kw, verdict):
    out = rule(**kw)
    assert out["verdict"] == verdict, out
    assert (out["law"] is not None) == (verdict == "amplitude-dependent")
    text = checks.verdict_warning(out)
    assert text and verdict.split("-")[0] in text.replace("model misfit", "misfit")


def test_frequency_drift_is_named_as_the_cause():
    out = rule(freq=FREQ_DRIFT, p_viscous=1e-6, slope=SLOPE_DECISIVE)
    assert out["verdict"] == "misfit" and out["law"] is None
    assert out["reasons"][0].startswith("frequency drifts with amplitude: f_d changes -1.6 %")
    assert "frequency drifts" in checks.verdict_warning(out)


def test_small_slope_does_not_matter_even_if_precise():
    """A 99 %-significant slope that changes ζ by < 25 % over the amplitudes is not decisive."""
    tiny = {**SLOPE_DECISIVE, "s": 0.05, "s_sd": 0.005, "s_q05": 0.042, "s_q95": 0.058}
    assert rule(slope=tiny, amplitude_span=2.0)["verdict"] == "adequate"
    assert rule(slope=tiny, amplitude_span=200.0)["verdict"] == "amplitude-dependent"


# ------------------------------------------------------------- evidence both ways (issue 19)
def test_adequate_needs_a_bound_on_the_dependence_and_a_white_residual():
    """The two false "adequate" verdicts of issue 19: an uninformative windowed slope and a
    residual structured at f0 (not enough to be a misfit) — inconclusive, with both reasons."""
    for slope, span, lb in (({"s": 0.33, "s_sd": 0.45, "s_q05": -0.45, "s_q95": 1.1}, 5.0, 0.004),
                            ({"s": -0.15, "s_sd": 2.1, "s_q05": -4.0, "s_q95": 3.7}, 2.65, 3e-4)):
        sl = {**slope, "n_windows": 8, "chi2_per_dof": 1.0}
        out = rule(slope=sl, amplitude_span=span, viscous={**CLEAN, "ljung_box_p": lb})
        assert out["verdict"] == "inconclusive", out
        assert out["reasons"][0].startswith("the amplitudes span too little to tell (zeta could "
                                            f"change up to {span ** max(map(abs, (sl['s_q05'], sl['s_q95']))):.3g}x"
                                            f" over the recorded {span:.3g}x amplitude range")
        assert out["reasons"][1].startswith(f"the residual is structured at f0 (Ljung-Box p = {lb:.2g}")
        assert not out["criteria"]["dependence_bounded"] and not out["criteria"]["white_at_f0"]
        assert "inconclusive" in checks.verdict_warning(out)
    # each condition alone keeps it open; both together give "adequate"
    assert rule(viscous={**CLEAN, "ljung_box_p": 0.004})["verdict"] == "inconclusive"
    wide = {**SLOPE_NULL, "s_q05": -0.4, "s_q95": 0.45}
    assert rule(slope=wide)["verdict"] == "inconclusive"
    good = rule()
    assert good["verdict"] == "adequate" and good["reasons"][0].startswith(
        "no amplitude dependence: zeta changes less than 5.6 % over the recorded 3x")


def test_a_tiny_bound_reads_as_a_percentage_not_1x():
    """A bound of ζ changing by 0.5 % is printed as such, never rounded to "less than 1x"."""
    tiny = {**SLOPE_NULL, "s_q05": -0.004, "s_q95": 0.0045}
    reason = rule(slope=tiny)["reasons"][0]
    assert "less than 0.5 % over" in reason and "1x" not in reason


def test_the_power_law_slope_can_bound_the_dependence():
    """Wide windows, but the power law fitted to the whole decay pins α − 1 near 0: adequate —
    unless that law is on a prior bound or ill-conditioned."""
    wide = {**SLOPE_NULL, "s_q05": -0.4, "s_q95": 0.45}
    tight = {"q05": -0.05, "q50": 0.0, "q95": 0.06}
    out = rule(slope=wide, power_slope=tight)
    assert out["verdict"] == "adequate" and "power law alpha - 1" in out["reasons"][0]
    laws = {"power": {"weight": 0.1, "issue": None, "zeta_ratio": 1.0}}
    assert rule(slope=wide, power_slope=tight, laws=laws)["verdict"] == "adequate"
    # the caller passes no power slope for an unusable power law: the windows decide
    assert rule(slope=wide, power_slope=None)["verdict"] == "inconclusive"


FLAT = {"s": 0.06, "s_sd": 0.45, "s_q05": -0.75, "s_q95": 0.87, "n_windows": 8,
        "chi2_per_dof": 1.0}


def test_law_evidence_against_flat_windows_is_not_amplitude_dependent():
    """Issue 19: zeta changes 5 % across the windows, slope [-0.75, 0.87], P(viscous) tiny."""
    out = rule(slope=FLAT, amplitude_span=1.3, p_viscous=1e-6)
    assert out["verdict"] == "inconclusive" and out["law"] is None
    assert out["criteria"]["law_evidence"] and not out["criteria"]["law_decisive"]
    assert "windows do not show the dependence" in out["reasons"][0]
    # windows that show the law's dependence (90 %, its side) make it decisive
    shown = {**FLAT, "s": 0.5, "s_q05": 0.1, "s_q95": 0.9}
    laws = {"power": {"weight": 0.9, "issue": None, "zeta_ratio": 1.4}}
    assert rule(slope=shown, amplitude_span=1.5, p_viscous=1e-6, laws=laws)["verdict"] == \
        "amplitude-dependent"
    # ... but not when they show the opposite side
    laws["power"]["zeta_ratio"] = 0.7
    assert rule(slope=shown, amplitude_span=1.5, p_viscous=1e-6, laws=laws)["verdict"] == \
        "inconclusive"


def test_a_law_on_its_prior_bound_cannot_carry_the_verdict():
    bound = "alpha = 3 is on its prior bound [0, 3]: the power law degenerates there"
    laws = {"power": {"weight": 0.98, "issue": bound, "zeta_ratio": 3.0},
            "coulomb": {"weight": 0.01, "issue": None, "zeta_ratio": 0.5},
            "quadratic": {"weight": 0.0, "issue": "drag_fraction = 0 is on its prior bound"}}
    shown = {**FLAT, "s": 0.5, "s_q05": 0.1, "s_q95": 0.9}
    out = rule(slope=shown, amplitude_span=1.5, p_viscous=1e-6, laws=laws)
    assert out["verdict"] == "inconclusive" and not out["criteria"]["law_usable"]
    assert "cannot carry the verdict: " + bound in " ".join(out["reasons"])
    # decisive windows carry it alone; the law named is the most probable usable one
    out = rule(slope=SLOPE_DECISIVE, p_viscous=1e-6, laws=laws)
    assert out["verdict"] == "amplitude-dependent" and out["law"] == "coulomb"
    laws["coulomb"]["issue"] = "condition number 1e+12"
    out = rule(slope=SLOPE_DECISIVE, p_viscous=1e-6, laws=laws)
    assert out["verdict"] == "amplitude-dependent" and out["law"] is None
    assert out["reasons"][0].startswith("no damping law describes the dependence")
    assert "no damping law describes it reliably" in checks.verdict_warning(out)


def test_no_decay_is_said_first():
    out = rule(decay={"z": 0.4, "resolved": False})
    assert out["verdict"] == "inconclusive" and out["criteria"]["no_decay"]
    assert out["reasons"][0].startswith("no decay measured: forced or self-sustained vibration?")
    warn = checks.verdict_warning(out)
    assert warn.startswith("no decay measured") and "reach 0" in warn
    assert rule(decay={"z": 40.0, "resolved": True})["verdict"] == "adequate"


def test_r_below_its_white_value_is_not_shown_as_evidence():
    out = rule(viscous={**CLEAN, "r_excess": 0.42})
    line = next(r for r in out["reasons"] if r.startswith("viscous:"))
    assert "r/r_white < 1 (no excess near f0" in line and "0.42" not in line


def steady_sine(seed: int = 0, zeta: float = 0.0, f: float = 3.0, duration: float = 30.0,
                fs: float = 50.0, noise: float = 0.02):
    """A sine of unit amplitude that does not decay (ζ = 0), or decays at ``zeta``."""
    t = np.arange(0.0, duration, 1 / fs)
    w = 2 * np.pi * f
    a = -np.exp(-zeta * w * t) * np.cos(w * np.sqrt(1 - zeta**2) * t)
    return noisy_recording(t, a, noise, seed=seed, lead=1.0)


@pytest.mark.heavy
def test_a_steady_sine_is_no_decay_and_its_zeta_interval_reaches_zero():
    """Forced or self-sustained vibration: the warning says so, the verdict is not
    "adequate", and ζ, p, c, δ reach 0 instead of stopping at the prior's floor."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        an = dampfit.analyze(steady_sine(), mass=0.5, window=(1.0, 29.0), max_steps=3000,
                             min_ess=300)
    s = an.summary()
    mc = s["model_checks"]
    assert mc["verdict"] == "inconclusive" and mc["decay"]["resolved"] is False
    assert mc["verdict_reasons"][0].startswith("no decay measured: forced or self-sustained")
    assert any(w.startswith("no decay measured") for w in s["diagnostics"]["warnings"])
    for name in ("zeta", "p", "c", "delta"):
        q = s["parameters"][name]
        assert q["q05"] == 0.0 and q["reaches_zero"] is True and q["q95"] > q["q50"] > 0
    # the upper bound is set by the data (a prior uniform in p), far above the floor 1e-6
    assert 1e-5 < s["parameters"]["zeta"]["q95"] < 1e-3
    assert s["parameters"]["Q"]["q95"] is None and s["parameters"]["Q"]["q05"] > 0
    from dampfit.output import text as render

    assert "reaches 0: no decay measured" in render.text(s)


@pytest.mark.heavy
def test_a_tiny_real_decay_is_measured():
    """ζ = 1e-5 over 4000 cycles: resolved, not "no decay" (the decay test sees it)."""
    rec = steady_sine(zeta=1e-5, f=20.0, duration=200.0, fs=100.0, noise=0.01)
    try:
        res, _ = verdict_of(rec)
    except InputError as exc:  # the window refusal another change fixes ("0.0 cycles")
        pytest.skip(f"refused before the decay test: {exc}")
    assert res.decay["resolved"] is True and res.decay["z"] > 5
    assert not res.adequacy["criteria"]["no_decay"]
    assert not any("no decay measured" in w for w in res.warnings)


# ----------------------------------------------------------------------------- noise
def test_r_is_never_below_its_white_value():
    """Residual power away from f₀ (here a strong 1/f-like wander) pulls the raw r far below
    the white value; the r used to temper the likelihood stays at r_white."""
    rng = np.random.default_rng(3)
    fs, f0 = 20.0, 2.0
    wander = np.cumsum(rng.standard_normal(4000)) * 0.2
    res = rng.standard_normal(4000) + wander - np.convolve(wander, np.ones(200) / 200, "same")
    for white in (1.0, 4.0):
        nm = noise.estimate(res, fs, f0, 0.5, 4, white=white)
        assert nm.psd_ratio_raw < white
        assert nm.psd_ratio == pytest.approx(white) and nm.white == white
        assert nm.excess == pytest.approx(nm.psd_ratio_raw / white)


def test_absolute_misfit_rule():
    ok = noise.misfit_check(1.2, 1.0, resid_rms=0.02, signal_rms=1.0, sigma_expected=0.02)
    assert not ok["misfit"] and ok["reasons"] == []
    # 15 % residual, 20x the sensor noise: misfit even though r/r_white is only 2
    bad = noise.misfit_check(10.0, 5.0, resid_rms=0.15, signal_rms=1.0, sigma_expected=0.0075)
    assert bad["misfit"] and bad["noise_excess"] == pytest.approx(20.0)
    # 15 % residual that the sensor noise explains (low SNR): not a misfit
    assert not noise.misfit_check(1.0, 1.0, 0.15, 1.0, 0.1)["misfit"]
    # r/r_white above 3: misfit warning on the absolute scale
    assert noise.misfit_check(15.0, 4.0, 0.01, 1.0, 0.01)["misfit"]


def test_sensor_density_ignores_misfit_at_the_oscillation():
    rng = np.random.default_rng(4)
    fs, f0 = 50.0, 2.0
    t = np.arange(0, 60, 1 / fs)
    white = 0.01 * rng.standard_normal(t.size)
    misfit = 0.2 * np.cos(2 * np.pi * f0 * 1.003 * t) + 0.1 * np.cos(4 * np.pi * f0 * t)
    d = noise.sensor_density(white + misfit, fs, f0, 0.9 * fs / 2)
    assert d == pytest.approx(0.01 / np.sqrt(fs / 2), rel=0.15)
    assert noise.expected_sigma(d, fs, 1.0) == pytest.approx(0.01, rel=0.15)


# ----------------------------------------------------------------------------- simulated
def _verdict_or_refusal(rec) -> tuple[str, object]:
    """The verdict, or "refused" when preprocessing finds no decay to analyse (an InputError:
    the user is told, no c is reported — not a verdict about the damping)."""
    try:
        res, prep = verdict_of(rec)
    except InputError:
        return "refused", None
    return res.verdict_name, prep


def _rates(n: int, classes=("phone", "lab", "amp", "pow", "mod", "dist")):
    gens = {"amp": amplitude_dependent, "pow": power_dependent, "mod": moderate_dependent}
    out = {k: [] for k in classes}
    out.update({f"{k}_ratio": [] for k in gens if k in classes})
    for i in range(n):
        if "phone" in classes:
            out["phone"].append(_verdict_or_refusal(phone_viscous(i))[0])
        if "lab" in classes:
            out["lab"].append(_verdict_or_refusal(lab_viscous(i))[0])
        for k in (k for k in gens if k in classes):
            rec, zeta_ratio = gens[k](i)
            v, prep = _verdict_or_refusal(rec)
            out[k].append(v)
            out[f"{k}_ratio"].append(zeta_ratio(prep.window) if prep is not None else np.nan)
        if "dist" in classes:
            rec, kind = distorted_viscous(i)
            out["dist"].append((kind, _verdict_or_refusal(rec)[0]))
    return out


def _report(out) -> dict:
    """Rates over the analysed replicates (refusals counted apart).

    ``false_alarm_*``: a viscous decay called amplitude-dependent or misfit (a claim against
    one viscous c); ``inconclusive_*``: the recording could not tell (short, small amplitude
    span, residual structured at f0); ``detection``: amplitude-dependent or misfit when ζ
    changes ≥ 1.5x across the window (quadratic/Coulomb, power law); ``false_adequate``:
    "adequate" on a decay whose ζ changes ≥ 1.25x across its window (any class)."""
    def rate(vs, ok):
        vs = [v for v in vs if v != "refused"]
        return sum(v in ok for v in vs) / max(len(vs), 1)

    def with_ratio(k, lo):
        return [v for v, z in zip(out.get(k, []), out.get(f"{k}_ratio", [])) if z >= lo]

    big, big_pow = with_ratio("amp", 1.5), with_ratio("pow", 1.5)
    matters = with_ratio("amp", 1.25) + with_ratio("pow", 1.25) + with_ratio("mod", 1.25)
    dist = [v for _, v in out.get("dist", [])]
    alarms = ("amplitude-dependent", "misfit")
    rates = {
        "false_alarm_phone": rate(out.get("phone", []), alarms),
        "false_alarm_lab": rate(out.get("lab", []), alarms),
        "inconclusive_phone": rate(out.get("phone", []), ("inconclusive",)),
        "inconclusive_lab": rate(out.get("lab", []), ("inconclusive",)),
        "detection": rate(big, alarms),
        "named_law": rate(big, ("amplitude-dependent",)),
        "detection_power": rate(big_pow, alarms),
        "false_adequate": rate(matters, ("adequate",)),
        "inconclusive_dependent": rate(matters, ("inconclusive",)),
        "misfit_on_distorted": rate(dist, ("misfit",)),
        "law_on_distorted": rate(dist, ("amplitude-dependent",)),
        "n_detect": len(big), "n_detect_power": len(big_pow), "n_matters": len(matters),
    }
    every = [v for k in ("phone", "lab", "amp", "pow", "mod") for v in out.get(k, [])] + dist
    rates["refused"] = sum(v == "refused" for v in every) / max(len(every), 1)
    print({k: round(v, 3) for k, v in rates.items()})
    return rates


@pytest.mark.heavy
def test_simulated_verdicts_few_replicates():
    """Four replicates of each class (the 100-replicate rates are in the slow test)."""
    rates = _report(_rates(4, ("phone", "lab", "amp", "dist")))
    assert rates["false_alarm_phone"] <= 0.25 and rates["false_alarm_lab"] <= 0.25
    assert rates["inconclusive_phone"] <= 0.5 and rates["inconclusive_lab"] <= 0.25
    assert rates["n_detect"] >= 3 and rates["named_law"] == 1.0
    assert rates["misfit_on_distorted"] >= 0.75 and rates["law_on_distorted"] == 0.0


def test_summary_and_warnings_follow_the_verdict():
    """model_checks carries verdict, reasons and a consistent single_viscous_c_adequate;
    exactly one verdict warning is in the warnings list."""
    for rec, expect in ((distorted_viscous(1)[0], "misfit"), (lab_viscous(0), "adequate")):
        res, _ = verdict_of(rec)
        assert res.verdict_name == expect
        mc = res.summary()["model_checks"]
        assert mc["verdict"] == res.verdict_name in checks.VERDICTS
        assert mc["single_viscous_c_adequate"] == (res.verdict_name == "adequate")
        assert mc["verdict_reasons"] and all(isinstance(r, str) for r in mc["verdict_reasons"])
        assert mc["amplitude_dependence"]["detected"] == (
            res.verdict_name == "amplitude-dependent")
        assert mc["warning"] == res.warning
        if res.verdict_name == "adequate":
            assert res.warning is None
        else:
            assert res.warnings.count(res.warning) == 1
            assert len(set(res.warnings)) == len(res.warnings)
        if expect == "misfit":  # the softening decay: the cause is named
            assert "frequency drifts" in res.warning
    assert mc["verdict"] == "adequate"  # the lab recording
    assert mc["adequacy"]["fit_checks"]["viscous_pipeline"]["r_excess"] < 3


# ----------------------------------------------------------------------------- slow
@pytest.mark.slow
def test_simulated_verdict_rates():
    """100 replicates per class, through the real decision (Laplace posteriors).

    Claims against one viscous c ("amplitude-dependent", "misfit") on viscous phone-like and
    lab-like recordings ≤ 5 % each; "inconclusive" — the recording could not have seen a
    dependence (a short decay or a small amplitude span: ζ could change ≥ 1.25x for all the
    slope says; or a residual structured at f0) — ≤ 30 % of the phone-like and ≤ 15 % of the
    lab-like ones; detection ≥ 90 % when ζ changes ≥ 1.5x across the window (quadratic drag
    or Coulomb friction plus a dashpot, and power-law dampers); "adequate" on ≤ 5 % of the
    decays whose ζ changes ≥ 1.25x across their window; distorted viscous decays come out
    "misfit" (≥ 90 %), never as a damping law (≤ 5 %). Rates are over the analysed
    replicates; a recording preprocessing refuses (no decay found) is counted apart, ≤ 5 %.

    Until issue 19 "inconclusive" counted as a false alarm here (≤ 10 %): "adequate" needed
    nothing against viscous. It now needs evidence that a dependence would have been seen,
    so short or small-span viscous recordings are honestly "inconclusive"; the false alarms
    proper are bounded separately and tighter.
    """
    rates = _report(_rates(100))
    assert rates["refused"] <= 0.05
    assert rates["false_alarm_phone"] <= 0.05 and rates["false_alarm_lab"] <= 0.05
    assert rates["inconclusive_phone"] <= 0.30 and rates["inconclusive_lab"] <= 0.15
    assert rates["n_detect"] >= 80 and rates["detection"] >= 0.90
    assert rates["n_detect_power"] >= 60 and rates["detection_power"] >= 0.90
    assert rates["n_matters"] >= 200 and rates["false_adequate"] <= 0.05
    assert rates["misfit_on_distorted"] >= 0.90 and rates["law_on_distorted"] <= 0.05


REAL_FILES = sorted([p for p in REAL.rglob("*") if p.suffix in {".csv", ".npy"}]
                    if REAL.is_dir() else [])


@pytest.mark.slow
@pytest.mark.skipif(not REAL_FILES, reason="../shared/data/real is not present")
@pytest.mark.parametrize("path", REAL_FILES, ids=[str(p.relative_to(REAL)) if REAL.is_dir()
                                                  else p.name for p in REAL_FILES])
def test_real_recording_verdict_follows_the_evidence(path):
    """The verdict agrees with the windowed ζ(A) evidence, and no misfit passes silently."""
    res, prep = verdict_of(dampfit.read(path))
    ad, mc = res.adequacy, res.summary()["model_checks"]
    crit, fc = ad["criteria"], ad["fit_checks"]
    sl = res.slope
    print(path.name, res.verdict_name, sl and (round(sl["s_q05"], 3), round(sl["s_q95"], 3)),
          {k: (round(v["r_excess"], 2), round(v["resid_fraction"], 3)) for k, v in fc.items()})
    assert mc["single_viscous_c_adequate"] == (res.verdict_name == "adequate")
    if crit["slope_decisive"] or crit["law_decisive"]:  # the windows or the evidence say so
        assert res.verdict_name in ("amplitude-dependent", "misfit")
    if any(crit[k] for k in ("viscous_misfit", "best_law_misfit", "pipeline_misfit",
                             "frequency_drift")):
        assert res.verdict_name != "adequate" and res.warning in res.warnings
    if res.verdict_name != "adequate":
        assert res.warning is not None and res.warnings.count(res.warning) == 1
    # SOURCES.md: the spring's and the cantilevers' ζ falls with amplitude; the large-angle
    # pendulum's frequency drifts with amplitude
    name = str(path)
    if any(s in name for s in ("phone-spring", "adxl357", "LSM_accelerometer")):
        assert res.verdict_name in ("amplitude-dependent", "misfit")
        assert sl is not None and sl["s_q05"] > 0
    if "Theta60" in name or "Theta45" in name:
        assert res.verdict_name == "misfit" and "frequency drifts" in res.warning
