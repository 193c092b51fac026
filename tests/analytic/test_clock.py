"""The sample-clock test (:mod:`dampfit.signal.clock`): stamps that scatter around a steady
clock while the samples follow the clock are detected and corrected; stamps that are right
(regular, or irregular but exact) are left alone."""

from __future__ import annotations

import numpy as np
import pytest

from dampfit import simulate as sim
from dampfit import stages
from dampfit.signal import clock, prepare

BASE = dict(duration=30.0, sample_rate=100.0, noise_density=150.0, u0=0.004)


def _recording(**kw):
    cfg = sim.from_modal(0.8, 3.3, 0.006, seed=kw.pop("seed", 1), **{**BASE, **kw})
    return cfg, sim.recording(cfg)[0]


def test_stamps_scattered_around_a_steady_clock_are_corrected():
    cfg, rec = _recording(timestamp_jitter=0.08, quantization=0.0024)
    _, exact = _recording(quantization=0.0024)  # the same samples at their true times
    prep = prepare.prepare(rec)
    assert prep.timing["moved"] and prep.timing["kappa"] == pytest.approx(1.0, abs=0.15)
    assert any("steady sample clock" in n for n in prep.notes)
    before = np.std(rec.time - exact.time)
    after = np.std(prep.time - exact.time)
    assert after < before / 5


@pytest.mark.parametrize("kw", [dict(), dict(jitter=0.08, gaps=3), dict(jitter=0.02)])
def test_right_stamps_are_kept(kw):
    """Regular stamps, and irregular sampling stamped exactly (the simulator's jitter), are
    analysed at the recorded times."""
    _, rec = _recording(**kw)
    prep = prepare.prepare(rec)
    assert not prep.timing["moved"]
    np.testing.assert_array_equal(prep.time, rec.time)
    assert abs(prep.timing["kappa"]) < 0.2 or not np.isfinite(prep.timing["kappa_se"])


def test_a_tiny_but_significant_kappa_moves_nothing():
    """κ̂ must be substantial (> KAPPA_MIN), not only many standard errors from 0."""
    t = np.arange(2000) / 100.0
    rng = np.random.default_rng(0)
    stamps = t + 0.001 / 100.0 * rng.standard_normal(t.size)
    grid = np.linspace(t[0], t[-1], 4000)
    bp = np.sin(2 * np.pi * 3.0 * grid)
    # values that follow the stamps except for 10 % of their deviation from the clock
    delta = stamps - clock.steady_clock(stamps)
    y = np.sin(2 * np.pi * 3.0 * (stamps - 0.1 * delta))
    out = clock.check(stamps, y, np.ones(t.size, bool), grid, bp, 3.0)
    assert out.kappa == pytest.approx(0.1, abs=0.03) and out.kappa > clock.KAPPA_Z * out.kappa_se
    assert not out.moved and out.time is stamps


def test_steady_clock_counts_dropped_samples():
    t = np.delete(np.arange(1000) * 0.01, [100, 101, 500])
    np.testing.assert_allclose(clock.steady_clock(t), t, atol=1e-12)


@pytest.mark.heavy
def test_phone_stamps_are_analysed_like_exact_stamps(monkeypatch):
    """End to end: with stamp errors the fit sees the sensor noise, not a noise proportional
    to the signal's slope (read as given, the stamps leave ≈ 1.3× the residual in the fitted,
    low-passed band here), and f_n comes out as from the exact times."""
    import dampfit

    _, rec = _recording(timestamp_jitter=0.08, noise_density=100.0, seed=4)
    _, exact = _recording(noise_density=100.0, seed=4)
    a = dampfit.analyze(rec, mass=0.8, model="viscous", min_ess=400)
    b = dampfit.analyze(exact, mass=0.8, model="viscous", min_ess=400)
    fa, fb = a.summary()["parameters"]["f_n"], b.summary()["parameters"]["f_n"]
    assert fa["q50"] == pytest.approx(fb["q50"], abs=1.5 * fb["sd"])
    assert fa["sd"] == pytest.approx(fb["sd"], rel=0.2)
    assert a.noise.sigma == pytest.approx(b.noise.sigma, rel=0.1)
    monkeypatch.setattr(clock, "KAPPA_Z", np.inf)  # the stamps read as given
    st = stages.fit_stages(prepare.prepare(rec), 0.8)
    assert st.noise.sigma > 1.2 * b.noise.sigma
