"""The analysis pipeline: preprocessing choices, least squares, posterior and the summary."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dampfit import pipeline as analysis
from dampfit.signal import prepare as preprocess
from dampfit import simulate as sim
from dampfit.errors import InputError
from dampfit.io.recording import Recording


# ---------------------------------------------------------------- preprocessing
def test_auto_axis_finds_the_tilted_direction():
    rec, truth = sim.recording(sim.preset("paper", duration=15.0, tilt_deg=35.0, azimuth_deg=70.0))
    prep = preprocess.prepare(rec)
    d = np.array([prep.direction[a] for a in ("x", "y", "z")])
    cos = abs(d @ np.asarray(truth["direction"]))
    assert np.degrees(np.arccos(min(cos, 1.0))) < 1.0


def test_window_starts_after_release_and_ends_before_catch():
    rec, truth = sim.recording(sim.preset("phone", seed=3))
    prep = preprocess.prepare(rec)
    # the guard after the envelope peak skips the low-pass ringing of the release step
    assert truth["t_release"] < prep.window[0] < truth["t_release"] + 4.0 / truth["f_n"]
    assert prep.window[1] < truth["t_catch"]


def test_user_window_and_band_are_used():
    rec, _ = sim.recording(sim.preset("paper", duration=15.0))
    prep = preprocess.prepare(rec, window=(5.0, 14.0), band=(1.0, 2.5))
    assert prep.window == (5.0, 14.0) and not prep.window_auto
    assert prep.band == (1.0, 2.5) and not prep.band_auto


@pytest.mark.parametrize("kw,match", [
    ({"window": (8.0, 5.0)}, "must be after its start"),
    ({"window": (-5.0, 5.0)}, "outside the recording"),
    ({"window": (5.0, 5.5)}, "holds only"),
    ({"band": (2.0, 1.0)}, "not a valid pass band"),
    ({"band": (1.0, 400.0)}, "Nyquist"),
    ({"axis": "w"}, "axis 'w' is not in this recording"),
])
def test_bad_options_are_input_errors(kw, match):
    rec, _ = sim.recording(sim.preset("paper", duration=15.0))
    with pytest.raises(InputError, match=match):
        preprocess.prepare(rec, **kw)


def test_no_oscillation_is_an_input_error():
    rec, _ = sim.recording(sim.preset("paper", duration=15.0, u0=0.0))  # hand tremor only
    with pytest.raises(InputError, match="no free.decay"):
        analysis.analyze(rec, mass=5.3)


def test_too_short_recording_is_an_input_error():
    rec, _ = sim.recording(sim.preset("paper", duration=1.0, handheld=0.0))  # 1.7 cycles
    with pytest.raises(InputError, match="too short"):  # "no … peak" or "(too short?)"
        preprocess.prepare(rec)


def test_stale_repeats_are_dropped():
    rec, _ = sim.recording(sim.preset("paper", duration=15.0))
    idx = np.repeat(np.arange(rec.n_samples), 1 + (np.arange(rec.n_samples) % 3 == 0))
    t = rec.time[0] + np.arange(idx.size) * 0.75 / rec.sample_rate  # polled faster than ODR
    stale = Recording(t, rec.accel[idx])
    prep = preprocess.prepare(stale)
    assert prep.n_stale == idx.size - rec.n_samples
    assert "polled faster" in " ".join(prep.notes)


def test_clipped_samples_are_masked():
    rec, _ = sim.recording(sim.preset("paper", duration=15.0, tilt_deg=0.0))
    level = 0.8 * np.max(np.abs(rec.accel[:, 1]))
    clipped = Recording(rec.time, np.clip(rec.accel, -level, level))
    prep = preprocess.prepare(clipped)
    assert prep.n_clipped > 10
    assert not prep.usable.all()
    assert any("clipped" in w for w in prep.warnings)


def test_impact_spikes_are_masked():
    rec, _ = sim.recording(sim.preset("paper", duration=15.0))
    a = rec.accel.copy()
    a[5000, :] += 40.0
    prep = preprocess.prepare(Recording(rec.time, a))
    assert not prep.usable[5000]
    assert prep.n_spikes >= 1


# ---------------------------------------------------------------- fit and posterior
def test_least_squares_recovers_truth(analysed):
    an, truth = analysed
    ls = an.least_squares
    assert ls.converged
    assert ls.p == pytest.approx(truth["p"], rel=0.02)
    assert ls.omega_d == pytest.approx(truth["omega_d"], rel=1e-4)
    u0_true = sim.envelope_at(truth, an.fit_data.t0)
    assert float(ls.u0()) == pytest.approx(u0_true, rel=0.01)


def test_posterior_intervals_contain_truth(analysed):
    an, truth = analysed
    s = an.summary()["parameters"]
    truths = {"c": truth["c"], "k": truth["k"], "zeta": truth["zeta"], "f_n": truth["f_n"],
              "u0": sim.envelope_at(truth, an.summary()["window"]["start_s"])}
    for name, value in truths.items():
        q = s[name]
        # 99.9 % interval from the normal approximation: a test that fails 1 in 1000 runs
        assert abs(q["q50"] - value) < 3.3 * q["sd"] + 1e-12, (name, q, value)


def test_mass_uncertainty_propagates_into_c_and_k(analysed):
    an, truth = analysed
    s = an.summary()["parameters"]
    rel_p = s["p"]["sd"] / s["p"]["q50"]
    rel_m = 0.05 / truth["mass"]
    assert s["c"]["sd"] / s["c"]["q50"] == pytest.approx(np.hypot(rel_p, rel_m), rel=0.1)
    # k's data uncertainty is tiny, so its sd is the mass's
    assert s["k"]["sd"] / s["k"]["q50"] == pytest.approx(rel_m, rel=0.1)


def test_posterior_is_converged_and_diagnosed(analysed):
    an, _ = analysed
    d = an.summary()["diagnostics"]
    assert d["converged"] and d["max_r_hat"] < 1.01 and d["min_ess_bulk"] >= 1000
    assert set(an.posterior.posterior.data_vars) >= {"c", "k", "u0", "zeta", "f_n", "mass", "Q", "c_crit"}
    s = an.summary()["parameters"]
    assert s["c"]["q50"] / s["c_crit"]["q50"] == pytest.approx(s["zeta"]["q50"], rel=0.01)
    assert s["Q"]["q50"] == pytest.approx(0.5 / s["zeta"]["q50"], rel=0.01)


def test_non_convergence_is_flagged_not_raised(short_paper):
    rec, truth = short_paper
    an = analysis.analyze(rec, mass=truth["mass"], max_steps=40, seed=2)  # < 50 τ
    s = an.summary()
    assert s["diagnostics"]["converged"] is False
    assert any("NOT converged" in w for w in s["diagnostics"]["warnings"])


@pytest.mark.heavy
def test_without_mass_reports_identifiable_quantities(short_paper):
    rec, truth = short_paper
    an = analysis.analyze(rec, seed=1)
    s = an.summary()
    assert s["parameters"]["c"] is None and s["parameters"]["k"] is None
    assert "mass" in s["missing"]["c"]
    assert s["parameters"]["zeta"]["q50"] == pytest.approx(truth["zeta"], rel=0.05)
    assert s["least_squares"]["c"] is None
    assert s["mass"]["value"] is None


@pytest.mark.heavy
def test_same_seed_same_posterior(short_paper):
    """--seed makes a run reproducible across processes: NumPy's global random state (seeded
    by the OS in every fresh process, and copied by emcee unless told otherwise) must not
    matter."""
    rec, truth = short_paper
    np.random.seed(1)
    a = analysis.analyze(rec, mass=5.3, seed=11).summary()
    np.random.seed(2)
    b = analysis.analyze(rec, mass=5.3, seed=11).summary()
    assert a["parameters"]["c"] == b["parameters"]["c"]
    assert a["damping_models"] == b["damping_models"]
    np.random.seed(2)
    c = analysis.analyze(rec, mass=5.3, seed=12).summary()
    assert c["parameters"]["c"] != b["parameters"]["c"]


# ---------------------------------------------------------------- summary and files
REQUIRED = {
    "dampfit_version": None,
    "input": {"path", "format", "n_samples", "sample_rate_hz", "axis", "duration_s"},
    "window": {"start_s", "end_s"},
    "mass": {"value", "sd"},
    "parameters": {"c", "k", "u0", "zeta", "f_n"},
    "least_squares": {"c", "k", "u0", "zeta", "f_n", "converged"},
    "baselines": {"log_decrement", "envelope_pipeline"},
    "diagnostics": {"converged", "max_r_hat", "min_ess_bulk", "warnings"},
}


def test_summary_schema_and_json(analysed, tmp_path):
    an, _ = analysed
    s = json.loads(an.to_json(tmp_path / "s.json").read_text())
    for key, sub in REQUIRED.items():
        assert key in s
        if sub:
            assert sub <= set(s[key]), (key, sub - set(s[key]))
    for name in ("c", "k", "u0", "zeta", "f_n"):
        assert {"unit", "mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk"} <= set(s["parameters"][name])
    assert s["parameters"]["c"]["unit"] == "N s/m"
    assert {"c", "zeta", "n_cycles"} <= set(s["baselines"]["log_decrement"])
    assert {"c", "zeta"} <= set(s["baselines"]["envelope_pipeline"])
    from dampfit.inference.noise import R_FLOOR

    assert s["noise_model"]["psd_ratio_at_f0"] >= R_FLOOR


def test_netcdf_round_trip(analysed, tmp_path):
    import arviz as az

    an, _ = analysed
    path = an.to_netcdf(tmp_path / "posterior.nc")
    back = az.from_netcdf(path)
    np.testing.assert_allclose(back.posterior["c"].values, an.posterior.posterior["c"].values)


def test_baselines_agree_with_posterior_on_clean_decay(analysed):
    an, truth = analysed
    for b in an.baselines.values():
        assert b is not None
        assert b.c == pytest.approx(truth["c"], rel=0.15)


def test_analyze_validates_mass(short_paper):
    rec, _ = short_paper
    with pytest.raises(InputError, match="positive"):
        analysis.analyze(rec, mass=-1.0)
    with pytest.raises(InputError, match="without --mass"):
        analysis.analyze(rec, mass_sd=0.1)
    with pytest.raises(InputError, match="Recording"):
        analysis.analyze(np.zeros((10, 2)), mass=1.0)


def test_damping_law_checks_in_summary(analysed):
    """Every analysis compares the damping laws; a viscous simulation is not flagged and
    reports no equivalent c (the viscous posterior is the answer)."""
    an, _ = analysed
    s = an.summary()
    mc = s["model_checks"]
    assert mc["amplitude_dependence"]["detected"] is False
    assert mc["single_viscous_c_adequate"] is True
    assert s["c_equivalent"] is None
    assert {"windows"} <= set(s["amplitude_curve"])
    assert not any("amplitude" in w for w in s["diagnostics"]["warnings"])


def test_c_equivalent_missing_reason_reaches_the_summary(analysed):
    """A non-viscous law's c_equivalent under "misfit" is absent from summary.json, with the
    reason in "missing" beside (not instead of) the mass reasons."""
    import copy
    from dataclasses import replace

    an, _ = analysed
    other = copy.copy(an)
    other.damping = replace(an.damping, chosen="coulomb",
                            adequacy={**an.damping.adequacy, "verdict": "misfit"})
    other._summary = None
    s = other.summary()
    assert s["c_equivalent"] is None
    assert s["missing"]["c_equivalent"].startswith("the verdict is misfit")
    assert an.summary()["missing"] == {} and an.summary()["c_equivalent"] is None


def test_damping_options_are_validated_before_work(short_paper):
    rec, _ = short_paper
    with pytest.raises(InputError, match="unknown damping model 'linear'"):
        analysis.analyze(rec, mass=5.3, model="linear")
    with pytest.raises(InputError, match="positive displacement amplitude"):
        analysis.analyze(rec, mass=5.3, amplitude=0.0)


def test_amplitude_draws_follow_their_moments():
    """posterior.conditional_amplitudes: one (A, B) per row of stored moments, with that mean
    and covariance (correlated case)."""
    from dampfit.inference import posterior

    mom = np.tile([1.0, -2.0, 4e-4, -1.5e-4, 1e-4], (200_000, 1))
    ab = posterior.conditional_amplitudes(mom, np.random.default_rng(0))
    np.testing.assert_allclose(ab.mean(axis=0), [1.0, -2.0], atol=2e-4)
    np.testing.assert_allclose(np.cov(ab.T), [[4e-4, -1.5e-4], [-1.5e-4, 1e-4]], rtol=0.02)
