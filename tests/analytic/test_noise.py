"""The noise calibration of the pipeline (:mod:`dampfit.inference.noise`, calibrated mode):
the Welch spectrum of the residuals corrected for what the fit removes, and the floor at the
white level of the residual above f₀/2 — slow drift does not widen the intervals, misfit at the
harmonics does, and short records are not mistaken for quiet ones."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from dampfit.inference import noise

FS, F0 = 50.0, 3.0


def _design(n: int, p: float = 0.3) -> np.ndarray:
    """Jacobian-like design of a decay fit: two oscillation columns, their p- and ω-derivatives
    and a cubic drift basis (n, 7)."""
    tau = np.arange(n) / FS
    e, w = np.exp(-p * tau), 2 * np.pi * F0
    c, s = e * np.cos(w * tau), e * np.sin(w * tau)
    x = 2 * tau / tau[-1] - 1
    return np.column_stack([-p * tau * c, -w * tau * s, c, s, np.ones(n), x, x**2, x**3])


def _project(jac: np.ndarray, y: np.ndarray) -> np.ndarray:
    q, _ = np.linalg.qr(jac)
    return y - q @ (q.T @ y)


def test_projection_depletion_matches_simulated_residuals():
    """d(f) is the expected Welch spectrum of least-squares residuals of white noise over that
    of the noise itself (checked by simulation on a 3 s design, where it matters)."""
    jac = _design(150)
    nper = 64
    rng = np.random.default_rng(0)
    acc = 0.0
    for _ in range(3000):
        f, pxx = signal.welch(_project(jac, rng.standard_normal(150)), fs=FS, nperseg=nper,
                              detrend=False)
        acc = acc + pxx
    inner = (f > 0) & (f < FS / 2)
    empirical = acc[inner] / 3000 / (2 / FS)
    np.testing.assert_allclose(noise.projection_depletion(jac, nper)[inner], empirical,
                               rtol=0.05, atol=0.02)
    near = np.argmin(np.abs(f - F0))
    assert empirical[near - 1] < 0.85  # the fit removes a sizeable share at f₀ here


def test_short_record_is_not_mistaken_for_a_quiet_one():
    """White noise on a 3 s record: the plain r is biased low by the fit's projection; the
    calibrated r is ≈ 1 on average."""
    jac = _design(150)
    rng = np.random.default_rng(1)
    plain, cal = [], []
    for _ in range(200):
        res = _project(jac, rng.standard_normal(150))
        nm = noise.estimate(res, FS, F0, 0.25 * F0, jac.shape[1], jacobian=jac)
        plain.append(nm.psd_ratio_raw)
        cal.append(nm.local)
    assert np.mean(plain) < 0.9
    assert np.mean(cal) == pytest.approx(1.0, abs=0.1)


def test_slow_drift_does_not_widen_and_harmonics_do():
    jac = _design(3000, p=0.05)
    rng = np.random.default_rng(2)
    tau = np.arange(3000) / FS
    white = 0.01 * rng.standard_normal(3000)
    drift = 0.05 * np.sin(2 * np.pi * 0.15 * tau + 1.0)  # far below f₀/2, not a cubic
    res = _project(jac, white + drift)
    nm = noise.estimate(res, FS, F0, 0.25 * F0, jac.shape[1], jacobian=jac)
    legacy = noise.estimate(res, FS, F0, 0.25 * F0, jac.shape[1], white=1.0)
    # white noise of the residual's high-frequency level: r ≈ (0.01²)/(total variance)
    expected = 0.01**2 / (np.sum(res**2) / (3000 - jac.shape[1]))
    assert nm.psd_ratio == pytest.approx(expected, rel=0.2)
    assert legacy.psd_ratio == 1.0  # the plain mode keeps its floor at r_white
    # a distorted waveform: power at 2 f₀ and 3 f₀ raises the floor to what white noise of the
    # whole residual would give (r_white = 1 here), far above the level at f₀ itself
    harm = 0.03 * np.exp(-0.05 * tau) * (np.cos(4 * np.pi * F0 * tau) + np.cos(6 * np.pi * F0 * tau))
    res_h = _project(jac, white + harm)
    nm_h = noise.estimate(res_h, FS, F0, 0.25 * F0, jac.shape[1], jacobian=jac)
    assert nm_h.sensor > 2 * nm_h.local and nm_h.psd_ratio == nm_h.sensor
    assert nm_h.psd_ratio == pytest.approx(1.0, rel=0.1)


def test_the_floor_follows_the_decimation_path():
    """After a zero-phase low-pass and decimation, white noise leaves r ≈ r_white in both
    estimates (the path's power gain divided out of the floor)."""
    from dampfit.signal import filters

    fs_filter, q = 100.0, 8
    sos = filters.lowpass_sos(4.5, fs_filter)
    rng = np.random.default_rng(3)
    fs_fit = fs_filter / q
    rw = noise.white_ratio(sos, fs_filter, fs_fit, F0)
    local, sensor = [], []
    for _ in range(40):
        y = signal.sosfiltfilt(sos, rng.standard_normal(40000))[::q]
        tau = np.arange(y.size) / fs_fit
        jac = np.column_stack([np.exp(-0.05 * tau) * np.cos(2 * np.pi * F0 * tau),
                               np.exp(-0.05 * tau) * np.sin(2 * np.pi * F0 * tau),
                               np.ones_like(tau)])
        nm = noise.estimate(_project(jac, y), fs_fit, F0, 0.25 * F0, 3, white=rw,
                            jacobian=jac, lowpass=(sos, fs_filter))
        local.append(nm.local)
        sensor.append(nm.sensor)
    assert rw > 1.2
    assert np.mean(local) == pytest.approx(rw, rel=0.05)
    assert np.mean(sensor) == pytest.approx(rw, rel=0.05)
