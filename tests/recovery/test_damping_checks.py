"""Which damper? Recovery, false alarms and real recordings for dampfit.damping.assess.

Default run: one simulated recording per law (Coulomb friction, quadratic drag, viscous) from
the exact reference ODE plus white noise — the right law is preferred, its coefficients are
recovered, a viscous recording raises no alarm — and the summary, checks, figure and input
validation. Slow (``-m slow``): the false-alarm rate over 60 realistic viscous phone
recordings, interval coverage over replicates, and the real recordings of SOURCES.md whose
damping depends on amplitude.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import replace

import numpy as np
import pytest

import dampfit
from dampfit.output import figures as plots
from dampfit.signal import prepare as preprocess
from dampfit import simulate as sim
from dampfit.damping import assess, checks
from dampfit.damping import Settings
from dampfit.model import laws as models
from tests._support.reference_sim import noisy_recording, reference_decay
from dampfit.inference.law_sampler import sample_emcee, sample_laplace
from dampfit.errors import InputError
from dampfit.physics import Mass

from tests._support.requirements import REAL

M, F = 0.5, 3.0  # [kg], [Hz]
K = M * (2 * np.pi * F) ** 2
U0 = 0.02  # [m]
FS = 100.0  # [Hz]
CASES = {  # law → (duration [s], coefficients of the reference ODE)
    "coulomb": (20.0, dict(c=0.01, F_c=0.02)),
    "quadratic": (40.0, dict(c=0.06, c2=0.3)),
    "power": (40.0, dict(c_alpha=0.02, alpha=0.5)),
    "viscous": (40.0, dict(c=0.06)),
}
KEYS = {"coulomb": ("c", "F_c"), "quadratic": ("c", "c2"), "power": ("c_alpha", "alpha"),
        "viscous": ("c",)}


def clean_accel(law: str):
    duration, kw = CASES[law]
    t = np.arange(0, duration, 1 / FS)
    return t, reference_decay(t, M, K, U0, **kw)[2]


def prepared(t, a, seed: int, noise_frac: float = 0.02):
    rec = noisy_recording(t, a, noise_frac * np.max(np.abs(a)), seed=seed, lead=1.0)
    prep = preprocess.prepare(rec)
    return prep, preprocess.fit_data(prep)


@pytest.fixture(scope="module")
def cases():
    out = {}
    for law in ("coulomb", "quadratic", "viscous"):
        t, a = clean_accel(law)
        prep, fd = prepared(t, a, seed=1)
        out[law] = (prep, fd, assess(prep, fd, None, None, mass=M, settings=Settings("laplace")))
    return out


def within(summary: dict, truth: float, n_sd: float = 3.0) -> bool:
    return (summary["q05"] <= truth <= summary["q95"]
            or abs(summary["q50"] - truth) <= n_sd * summary["sd"])


@pytest.mark.parametrize("law", ["coulomb", "quadratic"])
def test_nonlinear_law_is_preferred_and_recovered(cases, law):
    _, _, res = cases[law]
    assert res.preferred == law and res.amplitude_dependent
    assert res.verdict["p_viscous"] < 1e-6
    params = res.summary()["damping_models"]["models"][law]["parameters"]
    for key in KEYS[law]:
        truth = CASES[law][1][key]
        assert params[key]["q05"] <= truth <= params[key]["q95"], (key, params[key], truth)
    main = KEYS[law][1]  # the nonlinear coefficient is pinned down to a few %
    assert abs(params[main]["q50"] / CASES[law][1][main] - 1) < 0.05
    text = next(w for w in res.warnings if w.startswith("damping depends on amplitude"))
    assert law in text and "N·s/m" in text and "for FEM use" in text


def test_viscous_recording_raises_no_alarm(cases):
    _, _, res = cases["viscous"]
    s = res.summary()
    mc = s["model_checks"]
    assert res.preferred == "viscous" and not res.amplitude_dependent
    assert mc["single_viscous_c_adequate"] and mc["warning"] is None
    assert res.verdict["p_viscous"] > 0.5
    c = s["damping_models"]["c_report"]["c"]
    assert s["damping_models"]["c_report"]["model"] == "viscous"
    assert within(c, CASES["viscous"][1]["c"])
    slope = mc["amplitude_dependence"]["slope_ln_p_vs_ln_amplitude"]
    assert slope["q05"] < 0 < slope["q95"]  # α − 1 of the power law contains 0


def test_window_curve_sees_damping_fall_with_amplitude(cases):
    """Drag: local ζ falls as the amplitude falls; the windowed slope of ln p on ln a is > 0."""
    _, _, res = cases["quadratic"]
    curve = res.summary()["amplitude_curve"]
    wins = curve["windows"]
    assert len(wins) >= 8
    amp = np.array([w["amplitude_m"] for w in wins])
    zeta = np.array([w["zeta"] for w in wins])
    assert np.all(np.diff(amp) < 0)  # the decay runs down in amplitude
    assert zeta[0] > 1.5 * zeta[-1]
    assert curve["slope"]["s_q05"] > 0.2  # truth: 0 < d ln ρ/d ln a < 1 for viscous + drag
    # the chosen law's curve follows the windows (posterior band vs local estimates)
    z_model = np.interp(np.log(amp), np.log(curve["amplitude_grid_m"]),
                        curve["models"]["quadratic"]["zeta_eq"])
    sd = np.array([w["zeta_sd"] for w in wins])
    assert np.median(np.abs(zeta - z_model) / sd) < 2.0


def test_summary_is_plain_json_with_a_comparison_table(cases):
    _, _, res = cases["coulomb"]
    s = res.summary()
    json.dumps(s, allow_nan=False)
    assert set(s) == {"model_checks", "damping_models", "amplitude_curve"}
    table = s["damping_models"]["comparison"]
    assert [r["model"] for r in table][0] == "coulomb"
    assert sum(r["weight"] for r in table) == pytest.approx(1.0)
    assert {"model", "ln_evidence", "d_ln_evidence", "dse", "weight"} <= set(table[0])
    assert table[0]["d_ln_evidence"] == 0 and all(r["d_ln_evidence"] <= 0 for r in table)
    rep = s["damping_models"]["c_report"]
    assert rep["model"] == "coulomb" and rep["amplitude_m"] > 0 and rep["c"]["unit"] == "N s/m"
    # c_eq at the reference amplitude matches the law's coefficients (Jacobsen / eq. K2)
    pars = s["damping_models"]["models"]["coulomb"]["parameters"]
    w = 2 * np.pi * pars["f_n"]["q50"]
    expect = pars["c"]["q50"] + 4 * pars["F_c"]["q50"] / (np.pi * w * rep["amplitude_m"])
    assert rep["c"]["q50"] == pytest.approx(expect, rel=0.02)
    white = s["model_checks"]["residual_whiteness"]["ljung_box_at_f0"]
    assert white["viscous"]["p_value"] < 1e-6 < white["coulomb"]["p_value"]


def test_a_requested_law_is_reported_with_a_warning(cases):
    prep, fd, _ = cases["quadratic"]
    res = assess(prep, fd, None, None, mass=M, model="viscous", settings=Settings("laplace"), amplitude=0.01)
    assert res.chosen == "viscous" and res.preferred == "quadratic"
    assert any("viscous damping law was requested" in w for w in res.warnings)
    rep = res.c_report()
    assert rep["model"] == "viscous" and rep["amplitude_m"] == 0.01


def test_c_equivalent_is_absent_where_it_means_nothing(cases):
    """Under "misfit", or from a law whose posterior did not converge or is ill-conditioned,
    no c_equivalent: the reason is under "missing" (summary.json, table and report)."""
    from dataclasses import replace
    from types import SimpleNamespace

    from dampfit.analysis import Analysis

    _, _, res = cases["quadratic"]
    ok = Analysis._damping_summary(SimpleNamespace(damping=res))
    assert ok["c_equivalent"]["model"] == "quadratic" and "missing" not in ok
    assert ok["c_equivalent"]["c"]["q50"] > 0 and ok["c_equivalent"]["extrapolated"] is False
    misfit = replace(res, adequacy={**res.adequacy, "verdict": "misfit"})
    out = Analysis._damping_summary(SimpleNamespace(damping=misfit))
    assert out["c_equivalent"] is None
    assert out["missing"]["c_equivalent"].startswith("the verdict is misfit")
    rep = out["damping_models"]["c_report"]  # the per-law section says the same
    assert rep["c"] is None and rep["missing"] == out["missing"]["c_equivalent"]
    post = replace(res.posteriors["quadratic"], converged=False,
                   stop_reason="step budget reached (2000 steps)")
    stuck = replace(res, posteriors={**res.posteriors, "quadratic": post})
    why = Analysis._damping_summary(SimpleNamespace(damping=stuck))["missing"]["c_equivalent"]
    assert "did not converge (step budget reached (2000 steps))" in why
    ill = replace(post, converged=True, ill_conditioned=True,
                  ill_conditioned_reason="drag_fraction = 1 is on its prior bound [0, 1]")
    bad = replace(res, posteriors={**res.posteriors, "quadratic": ill})
    assert "ill-conditioned (drag_fraction = 1" in bad.c_missing()


def test_an_amplitude_outside_the_recorded_range_is_an_extrapolation(cases):
    prep, fd, res = cases["quadratic"]
    lo, hi = res.recorded_amplitudes
    assert 0 < lo < hi <= 1.01 * U0
    far = assess(prep, fd, None, None, mass=M, settings=Settings("laplace"), amplitude=50 * hi)
    rep = far.c_report()
    assert rep["extrapolated"] is True and rep["recorded_amplitude_range_m"] == [lo, hi]
    assert "extrapolated" in rep["note"]
    warn = next(w for w in far.warnings if w.startswith("--amplitude"))
    assert f"outside the recorded displacement amplitudes {lo:.3g}–{hi:.3g} m" in warn
    near = assess(prep, fd, None, None, mass=M, settings=Settings("laplace"), amplitude=(lo * hi) ** 0.5)
    assert near.c_report()["extrapolated"] is False
    assert not any(w.startswith("--amplitude") for w in near.warnings)


def test_emcee_posterior_agrees_with_laplace(cases):
    """The nested Laplace approximation of (L3) against emcee on the same tempered likelihood."""
    prep, fd, res = cases["quadratic"]
    from dampfit.inference.law_fit import Data

    mf, data = res.fits["quadratic"], Data.from_fit_data(fd)
    em = sample_emcee(mf, data, prep.band, seed=3, min_ess=300, max_steps=6000)
    la = sample_laplace(mf, data, seed=3)
    assert em.converged
    for i in range(3):
        m_e, s_e = np.mean(em.theta[:, i]), np.std(em.theta[:, i])
        m_l, s_l = np.mean(la.theta[:, i]), np.std(la.theta[:, i])
        assert abs(m_e - m_l) < 0.25 * s_e and 0.75 < s_l / s_e < 1.33, (i, m_e, m_l, s_e, s_l)
    assert np.median(em.a0) == pytest.approx(np.median(la.a0), rel=0.01)


@pytest.mark.parametrize("law", ["coulomb", "quadratic"])
def test_the_evidence_grid_stops_in_the_tail_without_changing_z(cases, law, monkeypatch):
    """(L3) marched to the end of the support and with the tail cut-off (TAIL_DROP): the same
    ln Z to double precision, the same Laplace draws, fewer nodes fitted."""
    from dampfit.inference import law_fit
    from dampfit.inference.law_fit import Data

    prep, fd, res = cases[law]
    mf, data = res.fits[law], Data.from_fit_data(fd)
    cut = law_fit.laplace(replace(mf, grid=None), data, mf.temper, prep.band)
    monkeypatch.setattr(law_fit, "TAIL_DROP", np.inf)
    full = law_fit.laplace(replace(mf, grid=None), data, mf.temper, prep.band)
    assert np.isfinite(cut.ln_evidence)
    assert cut.ln_evidence == pytest.approx(full.ln_evidence, rel=1e-13, abs=1e-10)
    fitted = np.isfinite(cut.grid.log_density).sum()
    assert fitted < np.isfinite(full.grid.log_density).sum()
    np.testing.assert_array_equal(sample_laplace(cut, data, seed=3).theta,
                                  sample_laplace(full, data, seed=3).theta)


@pytest.mark.heavy
def test_emcee_draws_depend_on_the_seed_only(cases):
    """Same seed → same draws, whatever NumPy's global random state (a fresh process's)."""
    prep, fd, res = cases["quadratic"]
    from dampfit.inference.law_fit import Data

    mf, data = res.fits["quadratic"], Data.from_fit_data(fd)
    draws = []
    for glob in (1, 2):
        np.random.seed(glob)
        draws.append(sample_emcee(mf, data, prep.band, seed=5, min_ess=200, max_steps=400).theta)
    np.testing.assert_array_equal(draws[0], draws[1])


def test_from_analysis_uses_the_pipeline_stages(cases):
    """from_analysis takes prepared data, the viscous fit (start values), noise, mass and seed."""
    from types import SimpleNamespace

    from dampfit.damping import from_analysis
    from dampfit.inference.noise import NoiseModel

    prep, fd, res = cases["coulomb"]
    visc = res.fits["viscous"]
    an = SimpleNamespace(prepared=prep, fit_data=fd,
                         least_squares=SimpleNamespace(p=visc.p0, omega_d=visc.omega),
                         noise=NoiseModel(0.1, 2.5, 2.5, 0.0, fd.fs, "test"), mass=M, mass_sd=0.0,
                         seed=4)
    out = from_analysis(an, posterior="laplace")
    assert out.preferred == "coulomb" and out.mass == M
    assert out.summary()["model_checks"]["residual_whiteness"]["psd_ratio_viscous_pipeline"] == 2.5


def test_input_errors(cases):
    prep, fd, _ = cases["viscous"]
    for kw, msg in ((dict(model="maxwell"), "unknown damping model"),
                    (dict(amplitude=-0.01), "reference amplitude"),
                    (dict(mass=0.0), "mass must be"),
                    (dict(mass=1.0, mass_sd=-1.0), "standard deviation"),
                    (dict(posterior="nuts"), "posterior must be"),
                    (dict(window_cycles=1.0), "at least 2 cycles")):
        with pytest.raises(InputError, match=msg):
            if "mass_sd" in kw:  # a mass and its sd are one Mass, checked where it is made
                kw = {**kw, "mass": Mass(kw["mass"], kw.pop("mass_sd"))}
            if "posterior" in kw or "window_cycles" in kw:  # how it runs: one Settings
                kw = {**kw}
                kw["settings"] = Settings(kw.pop("posterior", "chosen"),
                                          kw.pop("window_cycles", None))
            assess(prep, fd, None, None, **kw)


def test_ljung_box_separates_white_from_structured_residuals():
    rng = np.random.default_rng(0)
    white = rng.standard_normal(400)
    ar = np.zeros(400)
    for i in range(1, 400):
        ar[i] = 0.5 * ar[i - 1] + white[i]
    assert checks.ljung_box(white, 10)[1] > 0.01
    assert checks.ljung_box(ar, 10)[1] < 1e-6
    tau = np.arange(2000) / 20.0  # 2 Hz carrier, 20 Hz sampling, 200 cycles
    w = 2 * np.pi * 2.0
    assert checks.envelope_whiteness(tau, rng.standard_normal(tau.size), w)["p_value"] > 0.01
    misfit = np.exp(-tau / 30) * np.cos(w * tau) + rng.standard_normal(tau.size)
    assert checks.envelope_whiteness(tau, misfit, w)["p_value"] < 1e-6


def test_amplitude_figure_is_written(cases, tmp_path):
    _, _, res = cases["quadratic"]
    path = tmp_path / "amplitude.png"
    fig = plots.amplitude_figure(res.summary()["amplitude_curve"], path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob("*.part"))
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and "ζ" in ax.get_ylabel()


# ----------------------------------------------------------------------------- slow tests
def _phone_viscous(i: int):
    r = np.random.default_rng(1000 + i)
    f_n = float(np.exp(r.uniform(np.log(0.7), np.log(8.0))))
    zeta = float(np.exp(r.uniform(np.log(0.002), np.log(0.03))))
    noise = float(np.exp(r.uniform(np.log(250), np.log(3000))))  # µg/√Hz
    flicker = float(r.choice([0.0, 300.0]))  # 1/f noise in half the replicates
    cfg = sim.from_modal(0.33, f_n, zeta, u0=0.03 / f_n, duration=45.0, sample_rate=100.0,
                         jitter=0.07, gaps=4, noise_density=noise, flicker=flicker,
                         bias=(0.08, -0.12, 0.15), drift=0.02, quantization=0.0024, tilt_deg=12.0,
                         azimuth_deg=60.0, main_axis="z", gravity=True, handheld=4.0, catch=True,
                         seed=i)
    return sim.recording(cfg)[0]


@pytest.mark.slow
def test_false_alarm_rate_on_viscous_recordings():
    """≤ 10 % of 60 realistic viscous phone recordings may report amplitude dependence."""
    n, alarms, window_alarms = 60, 0, 0
    for i in range(n):
        rec = _phone_viscous(i)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            prep = preprocess.prepare(rec)
            fd = preprocess.fit_data(prep)
            res = assess(prep, fd, None, None, settings=Settings("laplace"))
        alarms += res.amplitude_dependent
        sl = res.slope
        window_alarms += bool(sl and (sl["s_q05"] > 0 or sl["s_q95"] < 0))
    rate = alarms / n
    print(f"false-alarm rate {rate:.3f} ({alarms}/{n}); windowed-slope 90 % interval excludes 0 "
          f"in {window_alarms}/{n}")
    assert rate <= 0.10


@pytest.mark.slow
@pytest.mark.parametrize("law", ["coulomb", "quadratic", "power"])
def test_interval_coverage_over_replicates(law):
    """90 % intervals of the law's coefficients cover the truth in ≈ 90 % of 40 noise draws."""
    t, a = clean_accel(law)
    n, hits, right = 40, {k: 0 for k in KEYS[law]}, 0
    for seed in range(n):
        prep, fd = prepared(t, a, seed=100 + seed, noise_frac=0.04)
        res = assess(prep, fd, None, None, mass=M, settings=Settings("laplace"))
        right += res.preferred == law
        params = res.summary()["damping_models"]["models"][law]["parameters"]
        for key in KEYS[law]:
            hits[key] += params[key]["q05"] <= CASES[law][1][key] <= params[key]["q95"]
    cover = {k: v / n for k, v in hits.items()}
    print(f"{law}: preferred in {right}/{n}; 90 % interval coverage {cover}")
    assert right >= 0.8 * n
    assert all(0.75 <= c <= 1.0 for c in cover.values()), cover


REAL_AMPLITUDE_DEPENDENT = sorted(
    [p for p in REAL.rglob("*") if p.suffix in {".csv", ".npy"}
     and any(s in str(p) for s in ("phone-spring", "adxl357", "LSM_accelerometer"))]
    if REAL.is_dir() else [])


@pytest.mark.slow
@pytest.mark.skipif(not REAL_AMPLITUDE_DEPENDENT, reason="../shared/data/real is not present")
@pytest.mark.parametrize("path", REAL_AMPLITUDE_DEPENDENT,
                         ids=[p.parent.name if p.suffix == ".npy" else p.name
                              for p in REAL_AMPLITUDE_DEPENDENT])
def test_real_recordings_show_amplitude_dependence(path):
    """SOURCES.md: the spring's and the cantilevers' decay rate falls as the amplitude falls."""
    rec = dampfit.read(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = preprocess.prepare(rec)
        fd = preprocess.fit_data(prep)
        res = assess(prep, fd, None, None, settings=Settings("laplace"))
    s = res.summary()["model_checks"]
    z = s["amplitude_dependence"]["zeta_at_start_and_end"]
    print(path.name, res.preferred, res.verdict["p_viscous"], z["zeta_eq_start"]["q50"],
          z["zeta_eq_end"]["q50"])
    assert res.amplitude_dependent and res.preferred in models.MODELS[1:]
    assert z["zeta_eq_start"]["q50"] > 1.2 * z["zeta_eq_end"]["q50"]  # falls with amplitude
    assert s["warning"] is not None and not s["single_viscous_c_adequate"]
