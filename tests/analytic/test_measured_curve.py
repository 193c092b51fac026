"""The measured damper curve (:mod:`dampfit.damping.measured`): F(v) = Σ b_j |v|^a_j sgn v,
b_j ≥ 0, fitted to half-period peaks of a decay whose truth is known in closed form.

The peaks come from the laws' own averaged envelope (K3 of :mod:`dampfit.model.laws`, not the
curve's quadrature), with noise of a known rms on ln|u|, so the fit's c_eq(A), its bootstrap
interval and its residual rms have exact values to compare with.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dampfit.damping import measured
from dampfit.fem.damper import c_equivalent, theta
from dampfit.model import laws

M, K, U0 = 5.3, 619.0, 0.04  # [kg], [N/m], [m]
W = math.sqrt(K / M)


def peaks(law, coeffs, span=30.0, noise=0.003, seed=0):
    """Half-period peak times [s] and amplitudes [m] of the law's averaged decay from U0,
    with lognormal noise of rms ``noise`` on ln|u|."""
    t = np.arange(0.0, span, math.pi / W)
    env = laws.get(law).envelope(theta(law, coeffs, M, W, U0), t, xp=np)[0]
    keep = env > 0.3  # a softening law (α < 1) stops in a finite time
    rng = np.random.default_rng(seed)
    return t[keep], U0 * env[keep] * np.exp(noise * rng.standard_normal(keep.sum()))


@pytest.mark.parametrize("law, coeffs", [("quadratic", {"c": 0.2, "c2": 1.6}),
                                         ("power", {"c_alpha": 0.53, "alpha": 0.5}),
                                         ("power", {"c_alpha": 0.9, "alpha": 1.6})])
def test_the_curve_follows_a_known_law_over_the_measured_range(law, coeffs):
    """c_eq(A) of the fitted curve within 3 % of the law's (K2) over the range, the residual
    rms the noise's (the envelope is followed to the scatter), the 90 % interval at the middle
    amplitude around the truth and no wider than 10 %; α = 1.6 is off the exponent grid."""
    t, p = peaks(law, coeffs)
    curve = measured.fit(t, p, W, M)
    lo, hi = curve.amplitude_range
    assert lo < 0.6 * U0 and hi > 0.9 * U0
    amps = np.geomspace(lo, hi, 7)
    truth = np.array([c_equivalent(law, coeffs, W, a) for a in amps])
    np.testing.assert_allclose(curve.c_eq(amps), truth, rtol=0.03)
    assert curve.rms < 1.15 * 0.003
    mid = math.sqrt(lo * hi)
    ci = curve.interval(mid)
    true_mid = c_equivalent(law, coeffs, W, mid)
    assert ci["q05"] <= true_mid * 1.01 and ci["q95"] >= true_mid * 0.99
    assert (ci["q95"] - ci["q05"]) / ci["q50"] < 0.10
    assert np.all(curve.b >= 0) and np.all(curve.boot >= 0)


def test_the_fit_is_seeded_and_the_mass_widens_its_interval():
    t, p = peaks("quadratic", {"c": 0.2, "c2": 1.6})
    a, b = measured.fit(t, p, W, M, seed=3), measured.fit(t, p, W, M, seed=3)
    np.testing.assert_array_equal(a.boot, b.boot)
    wide = measured.fit(t, p, W, M, mass_sd=0.05 * M, seed=3)
    mid = math.sqrt(a.amplitude_range[0] * a.amplitude_range[1])
    width = lambda c: c.interval(mid)["q95"] - c.interval(mid)["q05"]
    assert width(wide) > 2 * width(a)


def test_a_sigmoid_damping_is_beyond_the_family_and_the_rms_says_so():
    """ζ that rises steeply between two plateaus (as on the phone spring) is not a sum of
    A^(a-1) terms with b >= 0 (log-convex in ln A): the fit's rms stays well above the noise,
    so the outputs can tell the curve does not follow the recording."""
    t = np.arange(0.0, 120.0, math.pi / W)
    rate = lambda a: 0.004 + 0.008 / (1 + (0.02 / a) ** 12)  # [1/s]
    ln_a = [math.log(U0)]
    for dt in np.diff(t):
        ln_a.append(ln_a[-1] - rate(math.exp(ln_a[-1])) * dt)
    rng = np.random.default_rng(1)
    p = np.exp(np.array(ln_a) + 0.001 * rng.standard_normal(t.size))
    curve = measured.fit(t, p, W, M)
    assert curve.rms > 3 * 0.001


def test_too_few_peaks_is_a_value_error():
    with pytest.raises(ValueError, match="at least"):
        measured.fit(np.arange(10.0), np.geomspace(1, 0.5, 10), W, M)
