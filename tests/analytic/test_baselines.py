"""Tests of the seed paper's baseline estimators (:mod:`dampfit.estimators.baselines`).

Synthetic windows are closed-form damped accelerations a(t) = A·e^{−pt}·cos(ω_d·t + φ) with
known p and f_d, so every estimate is checked against the truth.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from dampfit import physics
from dampfit.estimators.baselines import BaselineResult, envelope_pipeline, log_decrement
from dampfit.errors import InputError

MASS = 5.3  # [kg], the paper's weight

# (f_d [Hz], ζ, fs [Hz], duration [s], band [Hz]) — the paper's spring, and a stiffer, more damped one.
SLOW = (1.72, 0.003, 500.0, 60.0, (1.2, 2.4))
FAST = (10.0, 0.02, 200.0, 10.0, (7.0, 14.0))
METHODS = {"log_decrement": log_decrement, "envelope_pipeline": envelope_pipeline}


def _truth(f_d: float, zeta: float) -> tuple[float, float]:
    """Decay rate p [1/s] and natural angular frequency ω_n [rad/s] of damped frequency f_d [Hz]."""
    omega_n = 2.0 * math.pi * f_d / math.sqrt(1.0 - zeta**2)
    return zeta * omega_n, omega_n


def _window(
    f_d: float,
    zeta: float,
    fs: float,
    duration: float,
    *,
    amp: float = 3.0,
    phase: float = 0.3,
    noise: float = 0.0,
    drift: float = 0.0,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Uniform time [s] and acceleration [m/s²]: damped cosine + white noise (σ = noise) + linear drift."""
    p, _ = _truth(f_d, zeta)
    t = np.arange(int(round(duration * fs))) / fs
    a = amp * np.exp(-p * t) * np.cos(2.0 * math.pi * f_d * t + phase)
    rng = np.random.default_rng(seed)
    a = a + noise * rng.standard_normal(t.size) + drift * (t / duration - 0.5)
    return t, a


def _rel(x: float, ref: float) -> float:
    return abs(x / ref - 1.0)


# -- recovery on clean data -----------------------------------------------------------------


@pytest.mark.parametrize("case", [SLOW, FAST], ids=["1.72Hz", "10Hz"])
@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize("phase", [0.3, 2.0])
def test_clean_recovery(case, method, phase):
    f_d, zeta, fs, duration, band = case
    p_true, _ = _truth(f_d, zeta)
    t, a = _window(f_d, zeta, fs, duration, phase=phase)
    r = METHODS[method](t, a, fs, band, mass=MASS)
    assert r.method == method
    assert _rel(r.p, p_true) < 0.02
    assert _rel(r.zeta, zeta) < 0.02
    assert _rel(r.delta, physics.log_decrement_from_zeta(zeta)) < 0.02
    assert _rel(r.f_d, f_d) < 1e-3
    assert _rel(r.c, 2.0 * MASS * p_true) < 0.02


@pytest.mark.parametrize("case", [SLOW, FAST], ids=["1.72Hz", "10Hz"])
def test_log_decrement_regression_variant(case):
    f_d, zeta, fs, duration, band = case
    p_true, _ = _truth(f_d, zeta)
    t, a = _window(f_d, zeta, fs, duration)
    d = log_decrement(t, a, fs, band).details
    assert _rel(d["p_regression"], p_true) < 0.02
    assert _rel(d["zeta_regression"], zeta) < 0.02
    assert _rel(d["f_d_regression"], f_d) < 1e-3
    # peaks kept clear of the band-pass edge transients
    assert d["edge_guard"] > 0.0
    assert d["peak_times"][0] >= t[0] + d["edge_guard"]
    assert d["peak_times"][-1] <= t[-1] - d["edge_guard"]


def test_envelope_unweighted_fit_as_printed():
    f_d, zeta, fs, duration, band = SLOW
    p_true, _ = _truth(f_d, zeta)
    t, a = _window(f_d, zeta, fs, duration)
    r = envelope_pipeline(t, a, fs, band, weighted=False)
    assert r.details["weighted"] is False
    assert r.p == r.details["p_unweighted"]
    assert _rel(r.p, p_true) < 0.02


def test_envelope_details():
    f_d, zeta, fs, duration, band = SLOW
    p_true, omega_n = _truth(f_d, zeta)
    amp = 3.0
    t, a = _window(f_d, zeta, fs, duration, amp=amp)
    r = envelope_pipeline(t, a, fs, band)
    d = r.details
    for key in ("displacement", "envelope", "envelope_fit", "velocity", "fit_mask"):
        assert d[key].shape == t.shape
    mask = d["fit_mask"]
    assert mask.sum() > 0.5 * t.size
    assert not mask[0] and not mask[-1]
    # displacement amplitude ≈ A/ω_n² (filter gains ≈ 1 inside the band)
    assert _rel(d["K"], amp / omega_n**2) < 0.05
    # the fitted envelope follows the Hilbert envelope over the fit region
    assert np.max(np.abs(np.log(d["envelope_fit"][mask] / d["envelope"][mask]))) < 0.05
    assert r.p == d["p_weighted"]
    assert r.n_cycles is None


# -- noise and drift ------------------------------------------------------------------------


@pytest.mark.parametrize("phase", [0.3, 2.0])
def test_light_noise_and_drift_slow(phase):
    f_d, zeta, fs, duration, band = SLOW
    p_true, _ = _truth(f_d, zeta)
    # σ = 0.02 m/s² (≈ 0.7 % of the initial amplitude) and a 0.1 m/s² slow drift
    t, a = _window(f_d, zeta, fs, duration, phase=phase, noise=0.02, drift=0.1, seed=1)
    ld = log_decrement(t, a, fs, band, mass=MASS)
    env = envelope_pipeline(t, a, fs, band, mass=MASS)
    assert _rel(ld.p, p_true) < 0.05
    assert _rel(ld.zeta, zeta) < 0.05
    assert _rel(env.p, p_true) < 0.02
    assert _rel(env.zeta, zeta) < 0.02


def test_light_noise_fast_short_window():
    # 3 s: the 10 Hz, ζ = 0.02 record decays by 3.8 nepers, staying above the noise.
    f_d, zeta, fs, _, band = FAST
    p_true, _ = _truth(f_d, zeta)
    t, a = _window(f_d, zeta, fs, 3.0, noise=0.003, drift=0.05, seed=2)
    ld = log_decrement(t, a, fs, band, mass=MASS)
    env = envelope_pipeline(t, a, fs, band, mass=MASS)
    assert _rel(ld.p, p_true) < 0.05
    assert _rel(env.p, p_true) < 0.05


def test_envelope_pipeline_removes_large_drift():
    # the paper's point (Figs. 10–11): integrating raw acceleration drifts; band-passing after
    # each integration removes it. Drift here is 3× the oscillation amplitude.
    f_d, zeta, fs, duration, band = SLOW
    p_true, _ = _truth(f_d, zeta)
    t, a = _window(f_d, zeta, fs, duration, drift=10.0)
    r = envelope_pipeline(t, a, fs, band)
    assert _rel(r.p, p_true) < 0.02
    u = r.details["displacement"]
    assert abs(np.mean(u[r.details["fit_mask"]])) < 0.01 * np.max(np.abs(u))


# -- physical conversions -------------------------------------------------------------------


@pytest.mark.parametrize("method", sorted(METHODS))
def test_c_two_ways_agree(method):
    """c = 2·m·p (eq. 3) equals c = ζ·2√(k·m) (eq. 15) with k = m·ω_n², ω_n = 2π·f_d/√(1−ζ²)."""
    f_d, zeta, fs, duration, band = SLOW
    t, a = _window(f_d, zeta, fs, duration)
    r = METHODS[method](t, a, fs, band, mass=MASS)
    omega_n = 2.0 * math.pi * r.f_d / math.sqrt(1.0 - r.zeta**2)
    assert r.k == pytest.approx(MASS * omega_n**2, rel=1e-9)
    assert r.c == pytest.approx(2.0 * MASS * r.p, rel=1e-9)
    c_eq15 = r.zeta * float(physics.critical_damping(r.k, MASS))
    assert r.c == pytest.approx(c_eq15, rel=1e-9)
    assert r.delta == pytest.approx(r.p / r.f_d, rel=1e-9)  # δ = p·T_d


@pytest.mark.parametrize("method", sorted(METHODS))
def test_without_mass_c_and_k_are_none(method):
    f_d, zeta, fs, duration, band = FAST
    t, a = _window(f_d, zeta, fs, duration)
    r = METHODS[method](t, a, fs, band)
    assert r.c is None and r.k is None
    assert r.p > 0.0 and r.zeta > 0.0 and r.delta > 0.0 and r.f_d > 0.0


@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize("mass", [None, MASS])
def test_summary_is_json_safe(method, mass):
    f_d, zeta, fs, duration, band = FAST
    t, a = _window(f_d, zeta, fs, duration)
    r = METHODS[method](t, a, fs, band, mass=mass)
    s = r.summary()
    assert set(s) == {"method", "p", "zeta", "delta", "f_d", "c", "k", "n_cycles",
                      "n_cycles_used", "n_cycles_window", "supported", "support_reason",
                      "expected_rel_sd"}
    back = json.loads(json.dumps(s, allow_nan=False))
    assert back == s
    for key in ("p", "zeta", "delta", "f_d"):
        assert type(s[key]) is float
    assert (s["c"] is None) == (mass is None)
    if method == "log_decrement":
        assert type(s["n_cycles"]) is int
    else:
        assert s["n_cycles"] is None
    assert isinstance(r, BaselineResult)


# -- the log decrement's n ------------------------------------------------------------------


def test_n_cycles_default_is_all_available():
    f_d, zeta, fs, duration, band = SLOW
    t, a = _window(f_d, zeta, fs, duration)
    r = log_decrement(t, a, fs, band)
    d = r.details
    assert r.n_cycles == d["n_available"] == len(d["peak_times"]) - 1
    # the guard drops ≈ 2 × 5 s, so about (60 − 10)·1.72 ≈ 85 cycles remain
    assert 75 <= r.n_cycles <= 100


@pytest.mark.parametrize("n", [1, 10, 40])
def test_n_cycles_respected(n):
    f_d, zeta, fs, duration, band = SLOW
    p_true, _ = _truth(f_d, zeta)
    t, a = _window(f_d, zeta, fs, duration)
    r = log_decrement(t, a, fs, band, n_cycles=n)
    d = r.details
    assert r.n_cycles == n
    amps, times = d["peak_amplitudes"], d["peak_times"]
    assert r.delta == pytest.approx(math.log(amps[0] / amps[n]) / n, rel=1e-12)  # eq. 9
    assert r.f_d == pytest.approx(n / (times[n] - times[0]), rel=1e-12)
    assert r.zeta == pytest.approx(float(physics.zeta_from_log_decrement(r.delta)), rel=1e-12)
    # One cycle of ζ = 0.003 decays by only 1.9 %, so the ≈0.1 % residual filter transient at
    # the edge guard is a ≈6 % error in δ; over 10+ cycles it is negligible.
    tol = 0.10 if n == 1 else 0.02
    assert _rel(r.p, p_true) < tol


# -- the paper's worked example -------------------------------------------------------------


def test_paper_worked_log_decrement_numbers():
    """Flis et al. 2025, eqs. 10, 13 and 15: n = 97, u_a0 = 4 cm, u_an = 0.679 cm, k = 676.169 N/m."""
    delta = math.log(4.0 / 0.679) / 97.0
    assert delta == pytest.approx(0.0182827682, rel=1e-8)  # eq. 10
    gamma = float(physics.zeta_from_log_decrement(delta))
    assert gamma == pytest.approx(0.0029097806, rel=1e-8)  # eq. 13
    c = gamma * float(physics.critical_damping(676.169, 5.3))
    # Eq. 15 prints c = 0.3798290195 N·s/m for "0.0029097806·2·√(676.169·5.3)", but that product
    # is 0.3483820769; the printed value is what m = 6.3 kg gives (676.169·6.3 is exactly the
    # k·m that reproduces it). We assert what the formula gives with the stated m = 5.3 kg …
    assert c == pytest.approx(0.3483820769, rel=1e-8)
    # … and document the paper's figure as the m = 6.3 kg value.
    c_printed = gamma * float(physics.critical_damping(676.169, 6.3))
    assert c_printed == pytest.approx(0.3798290195, rel=1e-8)


# -- input errors ---------------------------------------------------------------------------


@pytest.mark.parametrize("method", sorted(METHODS))
def test_errors_on_bad_arrays(method):
    fn = METHODS[method]
    f_d, zeta, fs, duration, band = FAST
    t, a = _window(f_d, zeta, fs, duration)
    with pytest.raises(InputError, match="empty"):
        fn(np.array([]), np.array([]), fs, band)
    with pytest.raises(InputError, match="mismatched lengths"):
        fn(t, a[:-1], fs, band)
    with pytest.raises(InputError, match="1-D"):
        fn(t, np.column_stack([a, a]), fs, band)
    with pytest.raises(InputError, match="only 5 samples"):
        fn(t[:5], a[:5], fs, band)
    bad = a.copy()
    bad[10] = np.nan
    with pytest.raises(InputError, match="NaN or infinite"):
        fn(t, bad, fs, band)
    jitter = t.copy()
    jitter[100] += 0.3 / fs
    with pytest.raises(InputError, match="not a uniform grid"):
        fn(jitter, a, fs, band)
    with pytest.raises(InputError, match="strictly increasing"):
        fn(t[::-1], a, fs, band)
    with pytest.raises(InputError, match="does not match the sample rate"):
        fn(t, a, 2.0 * fs, band)
    with pytest.raises(InputError, match="must be positive"):
        fn(t, a, 0.0, band)
    with pytest.raises(InputError, match="pair"):
        fn(t, a, fs, 5.0)
    with pytest.raises(InputError, match="not a valid pass band"):
        fn(t, a, fs, (14.0, 7.0))


@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize("mass", [0.0, -1.0, float("nan")])
def test_error_on_bad_mass(method, mass):
    f_d, zeta, fs, duration, band = FAST
    t, a = _window(f_d, zeta, fs, duration)
    with pytest.raises(InputError, match="mass must be positive"):
        METHODS[method](t, a, fs, band, mass=mass)


@pytest.mark.parametrize("method", sorted(METHODS))
def test_error_on_too_few_cycles(method):
    f_d, zeta, fs, _, band = SLOW
    t, a = _window(f_d, zeta, fs, 1.5)  # ≈ 2.6 cycles before any edge guard
    with pytest.raises(InputError, match="(fewer than 2|needs at least 3)"):
        METHODS[method](t, a, fs, band)


def test_envelope_error_on_short_window():
    f_d, zeta, fs, _, band = FAST
    t, a = _window(f_d, zeta, fs, 0.6)
    with pytest.raises(InputError, match="too short"):
        envelope_pipeline(t, a, fs, band)


@pytest.mark.parametrize("n", [0, -3, 10_000])
def test_error_on_n_cycles_out_of_range(n):
    f_d, zeta, fs, duration, band = FAST
    t, a = _window(f_d, zeta, fs, duration)
    with pytest.raises(InputError, match=r"n_cycles=-?\d+ is out of range"):
        log_decrement(t, a, fs, band, n_cycles=n)


@pytest.mark.parametrize("n", [2.5, True])
def test_error_on_non_integer_n_cycles(n):
    f_d, zeta, fs, duration, band = FAST
    t, a = _window(f_d, zeta, fs, duration)
    with pytest.raises(InputError, match="n_cycles must be an integer"):
        log_decrement(t, a, fs, band, n_cycles=n)


def test_error_messages_are_one_line():
    f_d, zeta, fs, _, band = SLOW
    t, a = _window(f_d, zeta, fs, 1.5)
    for fn in METHODS.values():
        with pytest.raises(InputError) as info:
            fn(t, a, fs, band)
        assert "\n" not in str(info.value)
