"""Analytic tests of the nonlinear damping laws (dampfit.model.laws and .reference).

Tiers: the reference ODE solver against closed forms (viscous; exact piecewise Coulomb); the
closed-form averaged envelopes against their own rate equation (K1)–(K2); the acceleration
model against the reference ODE solution for every law and damping level (the accuracy the
module docstring states); nesting with the viscous model (M1); equivalent-damping formulas
(FEMA 274 λ); invariants (NumPy path = JAX path, jit, finite gradients at edge parameters).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from dampfit.model import viscous as viscous_model
from dampfit.model import laws as models
from tests._support.reference_sim import noisy_recording, reference_decay
from dampfit.errors import InputError
from dampfit.simulate import free_decay

M, F = 1.0, 1.0  # [kg], [Hz]
W = 2 * np.pi * F
K = M * W * W
U0 = 0.1  # [m]


def law_setup(law: str, zeta_eq: float, frac: float = 0.5):
    """Physical coefficients and θ for an initial equivalent damping ratio ``zeta_eq``.

    ``frac`` is the nonlinear share of the initial decay rate (coulomb, quadratic); the power
    law uses α = 0.5.
    """
    p0 = zeta_eq * W
    if law == "coulomb":
        pv, pc = (1 - frac) * p0, frac * p0
        coef = dict(c=2 * M * pv, F_c=pc * np.pi * M * W * U0 / 2)
        return coef, np.array([np.log(p0), frac, np.log(W)])
    if law == "quadratic":
        pv, pq = (1 - frac) * p0, frac * p0
        coef = dict(c=2 * M * pv, c2=pq * 3 * np.pi * M / (4 * W * U0))
        return coef, np.array([np.log(p0), frac, np.log(W)])
    alpha = 0.5
    c_alpha = float(p0 * 2 * np.pi * M / ((W * U0) ** (alpha - 1) * models.lam(alpha)))
    return dict(c_alpha=c_alpha, alpha=alpha), np.array([np.log(p0), alpha, np.log(W)])


# ------------------------------------------------------------------ the reference solver
def test_reference_matches_viscous_closed_form():
    t = np.linspace(0, 20, 4001)
    u, v, a = reference_decay(t, 0.5, 0.5 * (4 * np.pi) ** 2, 0.05, c=0.2)
    u2, v2, a2 = free_decay(t, 0.5, 0.2, 0.5 * (4 * np.pi) ** 2, 0.05)
    assert np.max(np.abs(u - u2)) < 1e-8 * 0.05
    assert np.max(np.abs(a - a2)) < 1e-8 * np.max(np.abs(a2))


def test_reference_matches_exact_coulomb_and_sticks():
    """Pure friction: harmonic half-cycles about ±F_c/k, amplitude −2F_c/k each; stops when k|u| ≤ F_c."""
    f_c = 0.1
    t = np.linspace(0, 12, 6001)
    u, v, a = reference_decay(t, M, K, U0, F_c=f_c)
    d = f_c / K
    exact = np.zeros_like(t)
    un, tn = U0, 0.0
    while True:
        if K * abs(un) <= f_c:
            exact[t >= tn] = un
            break
        s = -np.sign(un)
        seg = (t >= tn) & (t <= tn + np.pi / W)
        exact[seg] = -s * d + (un + s * d) * np.cos(W * (t[seg] - tn))
        un, tn = -s * d - (un + s * d), tn + np.pi / W
    assert tn < t[-1]  # the mass did stick inside the record
    assert np.max(np.abs(u - exact)) < 1e-7 * U0
    assert np.all(v[t > tn + 1e-6] == 0)


def test_reference_rejects_bad_input():
    with pytest.raises(InputError, match="increasing times"):
        reference_decay(np.array([0.0, 0.0, 1.0]), M, K, U0)
    with pytest.raises(InputError, match="non-negative damping"):
        reference_decay(np.linspace(0, 1, 5), M, K, U0, F_c=-1.0)


def test_noisy_recording_adds_lead_and_noise():
    t = np.linspace(0, 1, 101)
    rec = noisy_recording(t, np.zeros_like(t), 0.1, seed=3, lead=0.5)
    assert rec.n_samples == 101 + 50 and rec.time[0] < 0
    assert 0.07 < np.std(rec.accel) < 0.13


# ------------------------------------------------------------- envelopes and rate laws
@pytest.mark.parametrize("law, theta", [
    ("viscous", [np.log(0.05), np.log(W)]),
    ("coulomb", [np.log(0.05), 0.6, np.log(W)]),
    ("coulomb", [np.log(0.05), 1.0, np.log(W)]),  # pure friction: linear decay, then stops
    ("coulomb", [np.log(0.05), 1.4, np.log(W)]),  # negative viscous part (outside the prior)
    ("quadratic", [np.log(0.05), 0.7, np.log(W)]),
    ("quadratic", [np.log(0.05), 0.0, np.log(W)]),
    ("power", [np.log(0.05), 0.3, np.log(W)]),
    ("power", [np.log(0.05), 1.0 + 3e-7, np.log(W)]),  # series branch near α = 1
    ("power", [np.log(0.05), 2.2, np.log(W)]),
])
def test_envelope_solves_the_averaged_rate_equation(law, theta):
    """de/dτ = −R(e) (K1) with R(e) = ρ(e)·e from (K2), e(0) = 1, e ≥ 0."""
    theta = np.array(theta)
    tau = np.linspace(0, 60, 60001)
    e, r, dr = models.envelope(law, theta, tau, xp=np)
    assert e[0] == pytest.approx(1.0)
    assert np.all(e >= 0)
    de = np.gradient(e, tau)
    moving = e > 1e-3
    assert np.max(np.abs(de + r)[moving][1:-1]) < 1e-6
    # R from the physical rate law: R = ρ(e)·e with ρ from local_rate
    rho = models.local_rate(law, theta, e[moving])
    np.testing.assert_allclose(r[moving], rho * e[moving], rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(dr[moving], np.gradient(r[moving], e[moving], edge_order=2),
                               rtol=1e-3, atol=1e-6)


def test_power_law_is_continuous_through_viscous():
    """The series branch (|α − 1| < 10⁻⁶) and the closed form agree: e(α) is smooth at α = 1."""
    tau = np.linspace(0, 50, 501)
    ev = models.envelope("viscous", np.array([np.log(0.05), np.log(W)]), tau, xp=np)[0]
    slopes = []
    for d in (-1e-5, -1e-7, 1e-7, 1e-5):  # both sides of the branch switch
        ep = models.envelope("power", np.array([np.log(0.05), 1 + d, np.log(W)]), tau, xp=np)[0]
        slopes.append((ep - ev) / d)  # ≈ ∂e/∂α at α = 1 = −½(p₀τ)²·e^{−p₀τ}·(−1)… any sign
    x = 0.05 * tau
    expect = 0.5 * x * x * np.exp(-x)  # ∂e/∂α at α = 1 from e = exp(log1p(−(1−α)x)/(1−α))
    for sl in slopes:
        np.testing.assert_allclose(sl, expect, atol=2e-4)


def test_viscous_columns_are_the_viscous_model_m1():
    """For viscous damping the columns span exactly dampfit.model.viscous.acceleration (M1): the models nest."""
    p, wd = 0.3, 2 * np.pi * 1.7
    tau = np.linspace(0, 10, 3001)
    with jax.enable_x64(True):
        y = np.asarray(viscous_model.acceleration(jnp.asarray(tau), p, wd, 1.3, -0.4))
    lp, lw = np.log(p), np.log(wd)
    for law, theta in (("viscous", [lp, lw]), ("power", [lp, 1.0, lw]),
                       ("coulomb", [lp, 0.0, lw]), ("quadratic", [lp, 0.0, lw])):
        x = models.columns(law, np.array(theta), tau, xp=np)
        coef, *_ = np.linalg.lstsq(x, y, rcond=None)
        assert np.max(np.abs(x @ coef - y)) < 1e-12 * np.max(np.abs(y)), law
        # |(A, B)| = ω²·a₀ (displacement amplitude at τ = 0, eq. M2 with ω_n² = ω_d² + p²)
        u0 = np.hypot(1.3, -0.4) / (wd**2 + p**2)
        assert np.hypot(*coef) / wd**2 == pytest.approx(u0, rel=1e-10)


def _inband_rms(r: np.ndarray, dt: float, f: float) -> float:
    spec = np.fft.rfft(r)
    fr = np.fft.rfftfreq(r.size, dt)
    spec[(fr > 1.5 * f) | (fr < 0.5 * f)] = 0
    return float(np.sqrt(np.mean(np.fft.irfft(spec, r.size) ** 2)))


# (law, ζ_eq, bound on in-band error / (amplitude·ζ_eq)); the module docstring quotes these
ACCURACY = [("coulomb", 3e-3, 0.08), ("coulomb", 0.03, 0.08), ("quadratic", 3e-3, 0.02),
            ("quadratic", 0.03, 0.02), ("power", 3e-3, 0.04), ("power", 0.03, 0.04)]


@pytest.mark.parametrize("law, zeta_eq, bound", ACCURACY)
def test_acceleration_model_matches_reference_ode(law, zeta_eq, bound):
    """The averaged model fits the DOP853 solution to O(ζ_eq) in band, over a decay to 30 %."""
    kw, theta = law_setup(law, zeta_eq)
    tt = np.linspace(0, 50 / zeta_eq / W, 20000)
    t_end = tt[np.argmax(models.envelope(law, theta, tt, xp=np)[0] < 0.3)]
    t = np.arange(0, t_end, 1 / (40 * F))
    _, _, a = reference_decay(t, M, K, U0, **kw)

    def resid(lnw):
        th = theta.copy()
        th[-1] = lnw
        x = models.columns(law, th, t, xp=np)
        coef, *_ = np.linalg.lstsq(x, a, rcond=None)
        return a - x @ coef, coef

    lnw = minimize_scalar(lambda v: np.sum(resid(v)[0] ** 2),
                          bracket=(np.log(W) - 1e-4, np.log(W) + 1e-4), tol=1e-14).x
    r, coef = resid(lnw)
    err = _inband_rms(r, t[1] - t[0], F) / (W * W * U0)
    assert err < bound * zeta_eq, (err / zeta_eq, bound)
    # the amplitude at release and the carrier frequency come out right
    assert np.hypot(*coef) / W**2 == pytest.approx(U0, rel=3 * zeta_eq)
    assert abs(np.exp(lnw) / W - 1) < 3 * zeta_eq**2


# --------------------------------------------------------------- equivalent damping
def test_lambda_special_values_and_equivalent_viscous():
    """λ(0) = 4, λ(1) = π, λ(2) = 8/3 (FEMA 274); the power law reduces to the other laws."""
    assert models.lam(0.0) == pytest.approx(4.0)
    assert models.lam(1.0) == pytest.approx(np.pi)
    assert models.lam(2.0) == pytest.approx(8 / 3)
    a0, a = 0.02, 0.013
    m, c, f_c, c2 = 2.0, 0.3, 0.5, 4.0
    w = W
    th_c = np.array([0.0, 0.0, np.log(w)])
    th_c[0] = np.log(c / (2 * m) + 2 * f_c / (np.pi * m * w * a0))
    th_c[1] = (2 * f_c / (np.pi * m * w * a0)) / np.exp(th_c[0])
    assert models.c_equivalent("coulomb", th_c, a0, a, m) == pytest.approx(c + 4 * f_c / (np.pi * w * a))
    th_q = np.array([np.log(c / (2 * m) + 4 * c2 * w * a0 / (3 * np.pi * m)), 0.0, np.log(w)])
    th_q[1] = (4 * c2 * w * a0 / (3 * np.pi * m)) / np.exp(th_q[0])
    expect_q = c + 8 * c2 * w * a / (3 * np.pi)
    assert models.c_equivalent("quadratic", th_q, a0, a, m) == pytest.approx(expect_q)
    for alpha, c_a in ((0.0, f_c), (1.0, c), (2.0, c2), (0.35, 0.7)):
        rho0 = c_a * (w * a0) ** (alpha - 1) * models.lam(alpha) / (2 * np.pi * m)
        th = np.array([np.log(rho0), alpha, np.log(w)])
        expect = models.lam(alpha) * c_a * (w * a) ** (alpha - 1) / np.pi
        assert models.c_equivalent("power", th, a0, a, m) == pytest.approx(expect)
        assert models.physical("power", th, a0, m)["c_alpha"] == pytest.approx(c_a)


@pytest.mark.parametrize("law", ["coulomb", "quadratic", "power"])
def test_physical_inverts_the_shape_parameters(law):
    kw, theta = law_setup(law, 0.01, frac=0.4)
    phys = models.physical(law, theta, U0, M)
    for name, value in kw.items():
        assert phys[name] == pytest.approx(value, rel=1e-12), name


# ------------------------------------------------------------------------ invariants
@pytest.mark.parametrize("law, theta", [
    ("coulomb", [np.log(0.2), 0.5, np.log(W), 0.1]),
    ("power", [np.log(0.2), 0.4, np.log(W), 0.2, -0.1, 0.05]),
])
def test_numpy_path_equals_jit_and_gradients_are_finite(law, theta):
    """One source, two array modules: jit(JAX) = NumPy, batched = looped, finite gradients."""
    tau = np.linspace(0, 30, 1201)
    theta = np.array(theta)
    both = np.stack([theta, theta + 1e-3])
    x_np = models.columns(law, both, tau, xp=np)  # batched NumPy
    with jax.enable_x64(True):
        fn = jax.jit(jax.value_and_grad(
            lambda th: (jnp.sum(models.columns(law, th, jnp.asarray(tau)) ** 2),
                        models.columns(law, th, jnp.asarray(tau))), has_aux=True))
        for i in range(2):
            (_, x_jax), g = fn(jnp.asarray(both[i]))
            np.testing.assert_allclose(np.asarray(x_jax), x_np[i], rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(models.columns(law, both[i], tau, xp=np), x_np[i], rtol=0, atol=0)
            assert np.all(np.isfinite(np.asarray(g)))


def test_phase_terms_follow_a_frequency_drift():
    """A chirp with a quadratic frequency drift is fitted exactly by J = 2 phase terms (K4)."""
    tau = np.linspace(0, 40, 4001)
    x = 2 * tau / 40 - 1
    psi = W * tau + 0.8 * (1.5 * x**2 - 0.5) - 0.3 * (2.5 * x**3 - 1.5 * x)
    u = np.exp(-0.05 * tau) * np.cos(psi + 0.4)
    acc = np.gradient(np.gradient(u, tau, edge_order=2), tau, edge_order=2)
    th = np.array([np.log(0.05), np.log(W), 0.8, -0.3])
    cols = models.columns("viscous", th, tau, xp=np)
    coef, *_ = np.linalg.lstsq(cols, acc, rcond=None)
    inner = slice(5, -5)
    assert np.max(np.abs((cols @ coef - acc)[inner])) < 2e-4 * np.max(np.abs(acc))
    assert models.n_phase("viscous", th) == 2 and models.n_phase("power", np.zeros(5)) == 2
