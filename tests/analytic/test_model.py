"""Analytic tests of the forward model: ODE residual, closed form vs an ODE solver, regimes."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dampfit import physics
from dampfit.model import viscous as model

M = 5.3  # [kg]


def params(f_n: float, zeta: float):
    wn = 2 * np.pi * f_n
    p = zeta * wn
    return p, np.sqrt(wn**2 - p**2), wn


@pytest.fixture(autouse=True)
def x64():
    with jax.enable_x64(True):
        yield


@pytest.mark.parametrize("zeta", [1e-4, 0.01, 0.08, 0.3, 0.7])
def test_satisfies_equation_of_motion(zeta):
    """m·ü + c·u̇ + k·u = 0 with c = 2mp, k = m·ω_n² (seed paper eq. 22, F = 0)."""
    p, wd, wn = params(1.72, zeta)
    c, k = 2 * M * p, M * wn**2
    tau = jnp.linspace(0, 30, 20001)
    args = (p, wd, 1.3, -0.4)
    u, v, a = (np.asarray(f(tau, *args)) for f in (model.displacement, model.velocity, model.acceleration))
    resid = M * a + c * v + k * u
    assert np.max(np.abs(resid)) <= 1e-12 * M * np.max(np.abs(a))


def test_derivatives_by_autodiff():
    """velocity = d/dτ displacement and acceleration = d²/dτ² displacement (jax.grad)."""
    p, wd, _ = params(3.0, 0.05)
    args = (p, wd, 0.7, 0.2)
    d1 = jax.vmap(jax.grad(lambda t: model.displacement(t, *args)))
    d2 = jax.vmap(jax.grad(jax.grad(lambda t: model.displacement(t, *args))))
    tau = jnp.linspace(0, 5, 501)
    np.testing.assert_allclose(d1(tau), model.velocity(tau, *args), rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(d2(tau), model.acceleration(tau, *args), rtol=1e-10, atol=1e-13)


@pytest.mark.parametrize("zeta,cycles", [(1e-4, 400), (0.002, 300), (0.05, 40), (0.3, 6), (0.7, 3)])
def test_closed_form_matches_ode_solver(zeta, cycles):
    """The closed form against scipy's DOP853 over hundreds of cycles, all regimes of ζ < 1."""
    f_n = 2.0
    p, wd, wn = params(f_n, zeta)
    args = (p, wd, 2.0, 1.0)
    t_end = cycles / f_n
    u0 = float(model.displacement(0.0, *args))
    v0 = float(model.velocity(0.0, *args))
    sol = solve_ivp(lambda t, y: [y[1], -2 * p * y[1] - wn**2 * y[0]], (0, t_end), [u0, v0],
                    method="DOP853", rtol=1e-12, atol=1e-15, dense_output=True)
    t = np.linspace(0, t_end, 5000)
    u_ref = sol.sol(t)[0]
    u = np.asarray(model.displacement(jnp.asarray(t), *args))
    scale = np.max(np.abs(u_ref))
    assert np.max(np.abs(u - u_ref)) < 1e-8 * scale


def test_float64_phase_over_hundreds_of_cycles():
    """JAX float64 result equals a NumPy complex-exponential evaluation at 20 Hz × 500 s."""
    p, wd, _ = params(20.0, 1e-4)
    tau = np.linspace(0, 500, 100001)
    a = np.asarray(model.acceleration(jnp.asarray(tau), p, wd, 1.0, 0.5))
    ref = np.real((1.0 - 0.5j) * np.exp((-p + 1j * wd) * tau))
    assert a.dtype == np.float64
    assert np.max(np.abs(a - ref)) < 1e-9


def test_envelope_amplitude_m2():
    """u0 = √(A² + B²)/ω_n² is the displacement envelope at τ = 0 (eq. M2)."""
    p, wd, wn = params(1.0, 1e-6)
    a_cos, a_sin = 3.0, -4.0
    tau = jnp.linspace(0, 1.0, 100001)
    u = np.asarray(model.displacement(tau, p, wd, a_cos, a_sin))
    assert np.max(np.abs(u)) == pytest.approx(5.0 / wn**2, rel=1e-5)


def test_design_matrix_and_profile_recover_coefficients():
    p, wd, _ = params(2.5, 0.01)
    tau = np.linspace(0, 20, 2000)
    drift = model.drift_basis(tau, 3)
    beta = np.array([1.5, -0.7, 0.2, 0.05, -0.03, 0.01])
    theta = jnp.array([np.log(p), np.log(wd)])
    y = np.asarray(model.design_matrix(theta, jnp.asarray(tau), jnp.asarray(drift))) @ beta
    b, rss, _, _ = model.profile(theta, jnp.asarray(tau), jnp.asarray(y), jnp.asarray(drift))
    np.testing.assert_allclose(b, beta, rtol=1e-9, atol=1e-12)
    assert float(rss) < 1e-20
    np.testing.assert_allclose(y[:5], np.asarray(model.acceleration(tau[:5], p, wd, 1.5, -0.7))
                               + drift[:5] @ beta[2:], rtol=1e-12)


@pytest.mark.heavy
def test_marginal_likelihood_peaks_at_truth_and_vmaps():
    rng = np.random.default_rng(0)
    p, wd, _ = params(1.5, 0.02)
    tau = np.linspace(0, 15, 1500)
    drift = jnp.asarray(model.drift_basis(tau, 2))
    y = np.asarray(model.acceleration(tau, p, wd, 1.0, 0.3)) + 0.01 * rng.standard_normal(tau.size)
    args = (jnp.asarray(tau), jnp.asarray(y), drift, 1.0)
    lnps = np.log(p) + np.linspace(-0.2, 0.2, 41)
    thetas = jnp.asarray([[lp, np.log(wd)] for lp in lnps])
    vec = np.asarray(jax.vmap(lambda th: model.log_marginal_likelihood(th, *args))(thetas))
    loop = np.array([float(model.log_marginal_likelihood(th, *args)) for th in thetas])
    jitted = np.asarray(jax.jit(jax.vmap(lambda th: model.log_marginal_likelihood(th, *args)))(thetas))
    np.testing.assert_allclose(vec, loop, rtol=1e-10)
    np.testing.assert_allclose(jitted, loop, rtol=1e-10)
    assert abs(lnps[np.argmax(vec)] - np.log(p)) <= 0.02
    assert np.all(np.isfinite(vec))


def test_drift_basis_evaluates_the_same_functions_elsewhere():
    """Coefficients fitted on the sample times apply on any other grid (plots)."""
    rng = np.random.default_rng(3)
    tau = np.sort(rng.uniform(0, 30, 400))  # irregular sample times
    q = model.drift_basis(tau, 5)
    np.testing.assert_allclose(model.drift_basis(tau, 5, at=tau), q, atol=1e-12)
    coef = q.T @ (0.3 + 0.01 * tau - 1e-4 * tau**2)  # a smooth drift, exactly representable
    dense = np.linspace(tau[0], tau[-1], 1000)
    np.testing.assert_allclose(model.drift_basis(tau, 5, at=dense) @ coef,
                               0.3 + 0.01 * dense - 1e-4 * dense**2, atol=1e-10)


def test_drift_basis_is_well_conditioned():
    tau = np.linspace(0, 300, 5000)
    basis = model.drift_basis(tau, 10)
    assert basis.shape == (5000, 11)
    assert np.linalg.cond(basis) < 100


@pytest.mark.parametrize("zeta", [1e-4, 0.05, 0.5])
def test_physics_round_trip(zeta):
    p, wd, wn = params(3.3, zeta)
    d = physics.quantities(p, wd, mass=M)
    p2, wd2 = physics.to_decay(d["c"], d["k"], M)
    assert p2 == pytest.approx(p, rel=1e-12) and wd2 == pytest.approx(wd, rel=1e-12)
    assert d["zeta"] == pytest.approx(zeta, rel=1e-12)
    assert d["c"] / d["c_crit"] == pytest.approx(zeta, rel=1e-12)
    assert physics.zeta_from_log_decrement(d["delta"]) == pytest.approx(zeta, rel=1e-12)


def test_physics_rejects_overdamped():
    with pytest.raises(ValueError, match="overdamped"):
        physics.to_decay(c=200.0, k=100.0, mass=1.0)


def test_amplitude_moments_are_the_regression_posterior():
    """Â, B̂ and their covariance equal the textbook linear-regression answer with the drift
    projected out: β̂ = (XᵀX)⁻¹Xᵀy, Cov = s²/temper·[(XᵀX)⁻¹]_osc, s² = RSS/(n − q)."""
    rng = np.random.default_rng(4)
    p, wd, _ = params(2.1, 0.015)
    tau = np.sort(rng.uniform(0, 12, 600))
    drift = model.drift_basis(tau, 3)
    y = (np.asarray(model.acceleration(tau, p, wd, 0.8, -0.5)) + 0.05 + 0.02 * tau / 12
         + 0.01 * rng.standard_normal(tau.size))
    theta = jnp.array([np.log(p) + 0.01, np.log(wd) - 1e-4])  # off the optimum on purpose
    temper = 0.4
    ll, mom = model.marginal_and_amplitudes(theta, jnp.asarray(tau), jnp.asarray(y),
                                            jnp.asarray(drift), temper)
    x = np.asarray(model.design_matrix(theta, jnp.asarray(tau), jnp.asarray(drift)))
    beta, *_ = np.linalg.lstsq(x, y, rcond=None)
    s2 = np.sum((y - x @ beta) ** 2) / (tau.size - x.shape[1])
    cov = s2 / temper * np.linalg.inv(x.T @ x)[:2, :2]
    np.testing.assert_allclose(np.asarray(mom)[:2], beta[:2], rtol=1e-9)
    np.testing.assert_allclose(np.asarray(mom)[2:], [cov[0, 0], cov[0, 1], cov[1, 1]], rtol=1e-8)
    assert float(ll) == pytest.approx(float(model.log_marginal_likelihood(
        theta, jnp.asarray(tau), jnp.asarray(y), jnp.asarray(drift), temper)), rel=1e-12)
