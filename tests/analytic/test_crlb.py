"""Tests of the Cramér–Rao bound (:mod:`dampfit.inference.crlb`).

Analytic tier: scaling laws, the Yao–Pandit closed form against the numerical Fisher matrix,
the delta method for c and k. Recovery tier: Monte-Carlo nonlinear least squares on white
noise attains the bound.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize, signal

from dampfit.inference import crlb
from dampfit.errors import InputError

# 2 Hz, p = 0.4 1/s (ζ ≈ 0.032), 8 s at 50 Hz: 16 cycles, 3.2 decay times
FS, N, P, WD, A, B, SIG = 50.0, 400, 0.4, 2 * math.pi * 2.0, 1.0, 0.5, 0.05
T = np.arange(N) / FS


def _bound(t=T, sigma=SIG, **kw):
    args = dict(p=P, omega_d=WD, a_cos=A, a_sin=B)
    args.update(kw)
    return crlb.bound(t, sigma, **args)


def _model(x, t):
    return np.exp(-x[0] * t) * (x[2] * np.cos(x[1] * t) + x[3] * np.sin(x[1] * t))


def _jac(x, t):
    e, c, s = np.exp(-x[0] * t), np.cos(x[1] * t), np.sin(x[1] * t)
    return np.stack([-t * e * (x[2] * c + x[3] * s), t * e * (x[3] * c - x[2] * s), e * c, e * s], 1)


# -- scaling ---------------------------------------------------------------------------------


def test_bound_scales_linearly_with_sigma():
    b1, b2 = _bound(mass=2.0), _bound(sigma=2 * SIG, mass=2.0)
    for name in ("p", "omega_d", "zeta", "f_n", "u0", "c", "k"):
        assert b2[name]["sd"] == pytest.approx(2 * b1[name]["sd"], rel=1e-9), name
        assert b2[name]["value"] == pytest.approx(b1[name]["value"], rel=1e-12)


def test_bound_scales_as_inverse_sqrt_n_at_fixed_duration():
    # same 8 s record sampled 4x more densely: 4x the samples, half the sd
    dense = np.arange(4 * N) / (4 * FS)
    assert _bound(dense)["p"]["sd"] == pytest.approx(0.5 * _bound()["p"]["sd"], rel=0.01)
    assert _bound(dense)["f_n"]["sd"] == pytest.approx(0.5 * _bound()["f_n"]["sd"], rel=0.01)


def test_short_undamped_records_gain_n_to_the_three_halves():
    # p·T ≪ 1: at fixed rate, doubling the length divides sd(p) by 2^{3/2}
    sd = [_bound(np.arange(n) / FS, p=1e-4)["p"]["sd"] for n in (200, 400)]
    assert sd[0] / sd[1] == pytest.approx(2**1.5, rel=0.02)


def test_long_records_stop_improving_once_the_decay_is_gone():
    # beyond ~10/p the signal is below the noise: four times longer gains < 1 %
    sd = [_bound(np.arange(n) / FS)["p"]["sd"] for n in (int(10 / P * FS), int(40 / P * FS))]
    assert sd[1] == pytest.approx(sd[0], rel=0.01)
    assert sd[1] <= sd[0]


# -- the closed form ------------------------------------------------------------------------


@pytest.mark.parametrize("phase", np.linspace(0, np.pi, 5, endpoint=False))
def test_yao_pandit_agrees_with_numerical_fisher_for_many_cycles(phase):
    # 16 cycles per decay time 1/p at 200 Hz: per-phase agreement to ~1 %
    fs, n, p, wd = 200.0, 12000, 0.125, 2 * math.pi * 2.0
    t = np.arange(n) / fs
    var_num = np.linalg.inv(crlb.fisher(t, 0.1, p, wd, math.cos(phase), -math.sin(phase), None))[0, 0]
    var_yp = crlb.yao_pandit_var_p(1.0, 0.1, 1 / fs, n, p)
    assert math.sqrt(var_num / var_yp) == pytest.approx(1.0, abs=0.01)


def test_yao_pandit_is_exact_for_the_phase_averaged_fisher_matrix():
    # few cycles per decay time (2 Hz, p = 1, 5 s at 10 Hz): one phase is off by several %,
    # the Fisher matrix in (p, ω_d, amplitude, phase) averaged over the phase is exact
    fs, n, p, wd, amp = 10.0, 50, 1.0, 2 * math.pi * 2.0, 1.3
    t = np.arange(n) / fs
    polar, ratios = [], []
    for ph in np.linspace(0, 2 * np.pi, 16, endpoint=False):
        f = crlb.fisher(t, 0.1, p, wd, amp * math.cos(ph), -amp * math.sin(ph), None)
        jac = np.eye(4)  # (A, B) = (R cos φ, −R sin φ)
        jac[2:, 2:] = [[math.cos(ph), -amp * math.sin(ph)], [-math.sin(ph), -amp * math.cos(ph)]]
        polar.append(jac.T @ f @ jac)
        ratios.append(np.linalg.inv(f)[0, 0])
    var_yp = crlb.yao_pandit_var_p(amp, 0.1, 1 / fs, n, p)
    assert np.linalg.inv(np.mean(polar, axis=0))[0, 0] == pytest.approx(var_yp, rel=1e-9)
    assert max(abs(math.sqrt(r / var_yp) - 1) for r in ratios) > 0.02  # single phases differ


def test_yao_pandit_undamped_limit_and_small_decay_branch():
    n, dt, sig, amp = 500, 0.01, 0.2, 1.5
    undamped = 24 * sig**2 / (amp**2 * dt**2 * n * (n**2 - 1))
    assert crlb.yao_pandit_var_p(amp, sig, dt, n, 0.0) == pytest.approx(undamped, rel=1e-9)
    # the two branches (direct sums below N·2pΔ = 1e-2, closed form above) join continuously
    below = crlb.yao_pandit_var_p(amp, sig, dt, n, 0.999e-2 / (2 * dt * n))
    above = crlb.yao_pandit_var_p(amp, sig, dt, n, 1.001e-2 / (2 * dt * n))
    assert below == pytest.approx(above, rel=1e-4)


# -- derived quantities ----------------------------------------------------------------------


def test_delta_method_for_c_k_and_mass_uncertainty():
    m, sm = 2.0, 0.1
    b = _bound(mass=m, mass_sd=sm)
    wn2 = P**2 + WD**2
    assert b["c"]["value"] == pytest.approx(2 * m * P)
    assert b["c"]["sd"] == pytest.approx(2 * m * b["p"]["sd"], rel=1e-9)
    assert b["c"]["sd_with_mass"] == pytest.approx(math.hypot(b["c"]["sd"], 2 * P * sm), rel=1e-9)
    assert b["k"]["value"] == pytest.approx(m * wn2)
    assert b["k"]["sd_with_mass"] == pytest.approx(math.hypot(b["k"]["sd"], wn2 * sm), rel=1e-9)
    assert b["u0"]["value"] == pytest.approx(math.hypot(A, B) / wn2)
    assert b["zeta"]["value"] == pytest.approx(P / math.sqrt(wn2))
    assert b["units"]["c"] == "N s/m" and b["units"]["u0"] == "m"
    # without mass uncertainty the two sds coincide; without mass c and k are absent
    b0 = _bound(mass=m)
    assert b0["c"]["sd_with_mass"] == b0["c"]["sd"]
    assert "c" not in _bound() and "c" not in _bound()["units"]


def test_zeta_bound_matches_finite_difference_delta_method():
    b = _bound()
    cov = np.linalg.inv(crlb.fisher(T, SIG, P, WD, A, B, 0))[:2, :2]
    wn = math.hypot(P, WD)
    h = 1e-7
    grad = np.array([(P + h) / math.hypot(P + h, WD) - P / wn, P / math.hypot(P, WD + h) - P / wn]) / h
    assert b["zeta"]["sd"] == pytest.approx(math.sqrt(grad @ cov @ grad), rel=1e-5)


def test_gaps_jitter_and_drift_only_lose_information():
    full = _bound()["p"]["sd"]
    keep = np.ones(N, dtype=bool)
    keep[50:80] = keep[200:230] = False  # two gaps
    assert _bound(T[keep])["p"]["sd"] > full
    jittered = T + np.random.default_rng(0).uniform(-0.2, 0.2, N) / FS
    assert _bound(jittered)["p"]["sd"] == pytest.approx(full, rel=0.02)
    assert _bound(drift_degree=4)["p"]["sd"] >= _bound(drift_degree=None)["p"]["sd"]


def test_per_sample_sigma():
    assert _bound(sigma=np.full(N, SIG))["p"]["sd"] == pytest.approx(_bound()["p"]["sd"], rel=1e-12)
    noisier_tail = np.where(T > 4.0, 3 * SIG, SIG)
    assert _bound(sigma=noisier_tail)["p"]["sd"] > _bound()["p"]["sd"]


def test_from_noise_density_matches_the_welch_density_of_white_noise():
    fs, density = 200.0, 0.03
    sigma = crlb.from_noise_density(density, fs)
    assert sigma == pytest.approx(density * math.sqrt(fs / 2))
    x = sigma * np.random.default_rng(3).standard_normal(200_000)
    _, pxx = signal.welch(x, fs=fs, nperseg=1024)
    assert math.sqrt(np.mean(pxx[5:-5])) == pytest.approx(density, rel=0.02)


# -- Monte Carlo -----------------------------------------------------------------------------


def test_least_squares_attains_the_bound_in_monte_carlo():
    rng = np.random.default_rng(1)
    truth = np.array([P, WD, A, B])
    clean = _model(truth, T)
    est = []
    for _ in range(300):
        y = clean + SIG * rng.standard_normal(N)
        r = optimize.least_squares(
            lambda x: _model(x, T) - y, truth * [1.2, 1.002, 0.9, 1.1],
            jac=lambda x: _jac(x, T), method="lm",
        )
        est.append(r.x[0])
    rmse = math.sqrt(np.mean((np.array(est) - P) ** 2))
    assert rmse / _bound(drift_degree=None)["p"]["sd"] == pytest.approx(1.0, abs=0.15)


# -- validation ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(t=np.array([0.0, 1.0])), "at least 3"),
        (dict(t=T[::-1]), "strictly increasing"),
        (dict(sigma=np.ones(3)), "one value per sample"),
        (dict(sigma=0.0), "sigma must be positive"),
        (dict(p=-0.1), "p ≥ 0"),
        (dict(a_cos=0.0, a_sin=0.0), "amplitude is zero"),
        (dict(mass_sd=0.1), "without mass"),
        (dict(mass=-1.0), "positive number of kilograms"),
        (dict(mass=1.0, mass_sd=-0.1), "mass_sd"),
        (dict(drift_degree=-1), "drift_degree"),
        (dict(t=T[:6], drift_degree=3), "cannot identify"),
        (dict(t=np.linspace(0, 1e-9, 20), drift_degree=None), "singular|no information"),
    ],
)
def test_bound_rejects_bad_designs(kwargs, match):
    with pytest.raises(InputError, match=match):
        _bound(**kwargs)


@pytest.mark.parametrize(
    ("args", "match"),
    [((1.0, 0.1, 0.01, 2, 0.1), "N must be"), ((0.0, 0.1, 0.01, 100, 0.1), "A must be"),
     ((1.0, 0.1, 0.01, 100, -1.0), "non-negative"), ((1.0, 0.1, -0.01, 100, 0.1), "dt must be")],
)
def test_yao_pandit_rejects_bad_input(args, match):
    with pytest.raises(InputError, match=match):
        crlb.yao_pandit_var_p(*args)


def test_from_noise_density_rejects_bad_input():
    with pytest.raises(InputError, match="noise density"):
        crlb.from_noise_density(-1.0, 100.0)
    with pytest.raises(InputError, match="sample rate"):
        crlb.from_noise_density(0.01, 0.0)


@pytest.mark.parametrize("modes", [1, 2])
def test_a_long_design_blocked_gives_the_same_bound(monkeypatch, modes):
    """A design longer than ``ONE_PIECE`` samples is accumulated block by block (memory linear
    in n, issue 33) and must give the bound of the whole Jacobian with its QR drift basis:
    the drift basis is only re-parametrised (Q = V·R⁻¹), so F⁻¹'s decay block is unchanged."""
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0.0, 60.0, 20_000))  # irregular times
    sigma = 0.01 * (1.0 + rng.uniform(size=t.size))  # one sigma per sample
    mode_list = [(0.05, 12.5, 1.0, 0.3), (0.2, 41.0, 0.2, -0.1)][:modes]

    def both():
        if modes == 1:
            return crlb.bound(t, sigma, p=0.05, omega_d=12.5, a_cos=1.0, a_sin=0.3,
                              mass=2.0, drift_degree=30)
        return crlb.bound_modes(t, sigma, mode_list, drift_degree=30, mass=2.0, mode_of_mass=0)

    whole = both()
    monkeypatch.setattr(crlb, "ONE_PIECE", 1000)
    monkeypatch.setattr(crlb, "BLOCK", 777)  # blocks that do not divide n
    blocked = both()
    pairs = [(whole, blocked)] if modes == 1 else list(zip(whole, blocked))
    for w, b in pairs:
        for name in ("p", "omega_d", "zeta", "f_n", "u0", "c", "k"):
            if name not in w:  # c and k: the mass's mode only
                continue
            assert b[name]["sd"] == pytest.approx(w[name]["sd"], rel=1e-7), name
