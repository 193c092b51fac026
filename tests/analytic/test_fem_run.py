"""The run export judges a law by (:func:`dampfit.fem.response.free_run`) and the scalar force
it runs (:func:`dampfit.fem.damper.scalar_force`), against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dampfit.fem import damper, response

CASES = {
    "viscous": {"c": 0.3},
    "coulomb": {"c": 0.2, "F_c": 0.06},
    "quadratic": {"c": 0.2, "c2": 1.6},
    "power": {"c_alpha": 0.53, "alpha": 0.5},
    damper.MEASURED: {"v_1": 0.1, "F_1": 0.01, "v_2": 0.3, "F_2": 0.05, "v_3": 0.5,
                      "F_3": 0.05, "v_4": 0.9, "F_4": 0.2},
}


@pytest.mark.parametrize("law", list(CASES))
def test_the_scalar_force_is_the_force(law):
    """Term for term the NumPy law, through 0, both signs, on and between a table's knots and
    beyond its last point."""
    v = np.concatenate([-np.geomspace(1e-7, 20.0, 400)[::-1], [0.0],
                        np.geomspace(1e-7, 20.0, 400), [0.1, 0.3, 0.5, 0.9, -0.9]])
    f = damper.scalar_force(law, CASES[law])
    got = np.array([f(float(x)) for x in v])
    np.testing.assert_allclose(got, damper.force(law, CASES[law], v), rtol=1e-12, atol=1e-15)
    assert f(0.0) == 0.0


def test_a_viscous_run_is_the_closed_form_free_decay():
    """m·ü + c·u̇ + k·u = 0 from rest at u0: a(t) = −(k·u + c·u̇)/m of the exact solution
    u = u0·e^{−pt}(cos ω_d t + (p/ω_d) sin ω_d t), to 1e-5 of the peak over 30 periods (the
    RK4 phase error: 6000 steps of (ω·h)⁵/120 ≈ 2.5e-10 rad; measured 7.7e-7)."""
    m, k, c, u0 = 0.3, 25.0, 0.02, 0.01
    w = math.sqrt(k / m)
    p = c / (2 * m)
    wd = math.sqrt(w * w - p * p)
    t, a = response.free_run(damper.scalar_force("viscous", {"c": c}), k, m, u0,
                             30 * 2 * math.pi / w)
    e = np.exp(-p * t)
    u = u0 * e * (np.cos(wd * t) + p / wd * np.sin(wd * t))
    v = -u0 * e * (w * w / wd) * np.sin(wd * t)
    exact = -(k * u + c * v) / m
    assert np.max(np.abs(a - exact)) < 1e-5 * np.max(np.abs(exact))
    assert np.diff(t).max() <= 2 * math.pi / w / response.RUN_STEPS_PER_PERIOD * (1 + 1e-12)


def test_a_coulomb_run_loses_two_fc_over_k_a_half_cycle():
    """Friction alone: each half cycle the turning point moves 2·F_c/k towards 0 (the exact
    piecewise solution), so the run's peaks of |a|/ω² — |u| + F_c/k, the jump of the force
    at the turn — fall by 2·F_c/k every half period."""
    m, k, fc, u0 = 0.5, 200.0, 0.05, 0.01
    w = math.sqrt(k / m)
    f = damper.scalar_force("coulomb", {"c": 0.0, "F_c": fc})
    t, a = response.free_run(f, k, m, u0, 6 * 2 * math.pi / w)
    tp, ap = response.envelope(t, a / w ** 2)
    assert tp.size == 11
    np.testing.assert_allclose(np.diff(ap), -2 * fc / k, rtol=1e-3)
    np.testing.assert_allclose(np.diff(tp), math.pi / w, rtol=1e-3)


def test_verify_start_reproduces_a_clean_nonlinear_decay():
    """verify's start of a nonlinear deck (released at rest at the first interior peak, on
    the trend, its displacement scaled so that the run's first peak is on the trend): a clean
    power-law decay (α = 0.3, steep at v = 0, so that its |a| peaks lie above the displacement
    by the force's share) run again from that start retraces its own envelope to 1e-4; left
    unscaled it would sit the force's share (~0.2 %) off."""
    from dampfit.fem.verify_damper import compare_from, run_start, start_state

    k, m = 10.0, 0.5
    w = math.sqrt(k / m)
    T = 2 * math.pi / w
    co = {"c_alpha": 0.004, "alpha": 0.3}
    f = damper.scalar_force("power", co)
    tau, acc = response.free_run(f, k, m, 0.05, 40 * T, 100)
    raw = start_state(tau, {"accel": acc, "omega_d": w}, T, "power", w)
    assert raw["v"] == 0.0 and raw["offset_s"] >= 3 * T
    scaled = run_start(raw, "power", co, k, m)
    rms = {}
    for name, st in (("raw", raw), ("scaled", scaled)):
        tr, ar = response.free_run(f, k, m, st["u"], tau[-1] - st["offset_s"], 100)
        env = response.log_envelope_error(tau, acc / w ** 2, tr + st["offset_s"], ar / w ** 2,
                                          compare_from(tau[0], st, tau[0] + 3 * T),
                                          tau[-1] - 3 * T)
        rms[name] = env["rms_vs_peaks"]
    assert rms["scaled"] < 2e-4
    assert rms["raw"] > 5 * rms["scaled"]
