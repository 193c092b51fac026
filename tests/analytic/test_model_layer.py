"""The model layer: law classes, the one profile (dampfit.model.profile) and its compositions."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import optimize

from dampfit.model import laws
from dampfit.model import profile as prof
from dampfit.model.viscous import drift_basis


def _decay(tau, p, w, a, b):
    return np.exp(-p * tau) * (a * np.cos(w * tau) + b * np.sin(w * tau))


def test_laws_carry_names_units_priors_and_dispatch():
    for name, law in laws.LAWS.items():
        assert law.name == name and laws.get(name) is law
        for j in range(laws.MAX_PHASE + 1):
            lj = law.with_phase(j)
            assert len(lj.names) == len(lj.units) == lj.n_params
            assert lj.phase_count(np.zeros(lj.n_params)) == j
    assert laws.get("power", np.zeros(5)).n_phase == 2
    th = np.array([np.log(0.1), 0.5, np.log(10.0)])
    band = (0.5, 5.0)
    assert np.isfinite(laws.log_prior("coulomb", th, band))
    assert laws.log_prior("coulomb", th * [1, 3, 1], band) == -np.inf  # f = 1.5 outside [0, 1]
    with pytest.raises(ValueError, match="unknown damping model"):
        laws.get("maxwell")
    draws = np.array([th, th * [1, 3, 1], th * [1, 0.5, 1]])
    with jax.enable_x64(True):
        np.testing.assert_array_equal(np.asarray(laws.LAWS["coulomb"].log_prior(
            jnp.asarray(draws), band, xp=jnp)), laws.log_prior("coulomb", draws, band))


def test_viscous_law_and_m1_columns_span_the_same_space():
    """Viscous (law columns) and ViscousM1 (eq. M1 columns) give the same RSS; the
    determinant differs by the constant |(1 + iρ/ω)²|² only."""
    rng = np.random.default_rng(3)
    tau = np.linspace(0, 8, 500)
    y = _decay(tau, 0.3, 12.0, 0.7, 0.2) + 0.05 * rng.standard_normal(tau.size)
    th = jnp.array([np.log(0.31), np.log(12.01)])
    with jax.enable_x64(True):
        s = prof.Samples.from_arrays(tau, y, drift_basis(tau, 1))
        a = prof.profile(laws.Viscous(), th, s.tau, s.y, s.drift, s.mask)
        b = prof.profile(laws.ViscousM1(), th, s.tau, s.y, s.drift, s.mask)
    assert float(a.rss) == pytest.approx(float(b.rss), rel=1e-10)
    rho_w = 0.31 / 12.01
    assert float(a.logdet - b.logdet) == pytest.approx(4 * np.log(1 + rho_w**2), abs=1e-9)


@pytest.mark.heavy
def test_padding_leaves_the_marginal_likelihood_unchanged():
    """Inert rows and zero drift columns (Samples.from_arrays) change nothing."""
    rng = np.random.default_rng(0)
    tau = np.linspace(0, 10, 700)
    y = _decay(tau, 0.1, 9.0, 1.0, 0.3) + 0.02 * rng.standard_normal(tau.size)
    q = drift_basis(tau, 2)
    th = jnp.array([np.log(0.1), np.log(9.0)])
    with jax.enable_x64(True):
        plain = prof.Samples.from_arrays(tau, y, q)
        padded = prof.Samples.from_arrays(tau, y, q, pad_to=1024, drift_columns=8)
        for law in (laws.LAWS["viscous"], laws.ViscousM1()):
            a = float(prof.log_marginal(law, th, plain, 0.7))
            b = float(prof.log_marginal(law, th, padded, 0.7))
            assert b == pytest.approx(a, rel=1e-12)


@pytest.mark.heavy
def test_sum_of_two_viscous_laws_recovers_both_modes():
    """A two-mode decay is fitted by Sum(viscous, viscous): both frequencies and rates."""
    rng = np.random.default_rng(1)
    tau = np.arange(0, 30, 0.01)
    truth = [(0.08, 2 * np.pi * 2.0), (0.25, 2 * np.pi * 3.1)]
    y = (_decay(tau, *truth[0], 1.0, -0.4) + _decay(tau, *truth[1], 0.6, 0.5) + 0.03
         + 0.01 * rng.standard_normal(tau.size))
    model = prof.Sum(laws.Viscous(), laws.Viscous())
    assert model.n_params == 4 and model.n_columns == 4
    assert model.names == ("0.ln_p0", "0.ln_omega", "1.ln_p0", "1.ln_omega")
    with jax.enable_x64(True):
        s = prof.Samples.from_arrays(tau, y, drift_basis(tau, 1))
        resid = jax.jit(lambda th: prof.profile(model, th, s.tau, s.y, s.drift, s.mask).residual)
        jac = jax.jit(jax.jacfwd(lambda th: prof.profile(model, th, s.tau, s.y, s.drift,
                                                         s.mask).residual))
        start = np.log([0.12, truth[0][1] * 1.003, 0.18, truth[1][1] * 0.997])
        sol = optimize.least_squares(lambda th: np.asarray(resid(jnp.asarray(th))), start,
                                     jac=lambda th: np.asarray(jac(jnp.asarray(th))),
                                     method="lm")
        beta = np.asarray(prof.profile(model, jnp.asarray(sol.x), s.tau, s.y, s.drift,
                                       s.mask).beta)
    p1, w1, p2, w2 = np.exp(sol.x)
    assert w1 == pytest.approx(truth[0][1], rel=1e-5) and w2 == pytest.approx(truth[1][1], rel=1e-5)
    assert p1 == pytest.approx(truth[0][0], rel=0.02) and p2 == pytest.approx(truth[1][0], rel=0.02)
    # the law columns carry |(A, B)| = ω²·a₀ scaled by (1 + iρ/ω)²: amplitudes in order
    assert np.hypot(*beta[:2]) == pytest.approx(np.hypot(1.0, -0.4), rel=0.02)
    assert np.hypot(*beta[2:4]) == pytest.approx(np.hypot(0.6, 0.5), rel=0.02)


@pytest.mark.heavy
def test_joint_likelihood_of_two_recordings_peaks_at_the_shared_rate():
    """Two recordings sharing the decay rate p (own frequency, amplitude, drift, noise)."""
    rng = np.random.default_rng(2)
    p = 0.15
    recs = [(np.arange(0, 20, 0.01), 2 * np.pi * 2.5, 1.0, 0.02),
            (np.arange(0, 15, 0.008), 2 * np.pi * 2.8, 0.4, 0.01)]
    joint = prof.Joint(laws.ViscousM1(), 2, shared=(0,))
    assert joint.n_params == 3 and joint.names == ("ln_p0", "ln_omega[0]", "ln_omega[1]")
    np.testing.assert_array_equal(joint.index(), [[0, 1], [0, 2]])
    with jax.enable_x64(True):
        samples = []
        for tau, w, amp, sd in recs:
            y = _decay(tau, p, w, amp, 0.3 * amp) + 0.05 + sd * rng.standard_normal(tau.size)
            samples.append(prof.Samples.from_arrays(tau, y, drift_basis(tau, 2), pad_to=2048,
                                                    drift_columns=4))
        tempers = [1.0, 0.8]

        def neg(th):
            return -prof.joint_log_marginal(joint, th, samples, tempers)

        f = jax.jit(jax.value_and_grad(neg))
        truth = np.log([p, recs[0][1], recs[1][1]])
        # the joint likelihood is the sum of the per-recording ones at the mapped θ
        ind = sum(t * float(prof.log_marginal(joint.model, th, s))
                  for th, s, t in zip(joint.split(jnp.asarray(truth)), samples, tempers))
        assert float(-f(jnp.asarray(truth))[0]) == pytest.approx(ind, rel=1e-12)
        start = truth + np.array([0.3, 2e-3, -2e-3])
        sol = optimize.minimize(lambda th: tuple(np.asarray(v) for v in f(jnp.asarray(th))),
                                start, jac=True, method="BFGS", options={"gtol": 1e-8})
        # curvature from central differences of the compiled gradient
        h = 1e-6
        hess = np.array([(np.asarray(f(jnp.asarray(sol.x + h * e))[1])
                          - np.asarray(f(jnp.asarray(sol.x - h * e))[1])) / (2 * h)
                         for e in np.eye(3)])
    sd = np.sqrt(np.diag(np.linalg.inv(0.5 * (hess + hess.T))))
    assert np.all(np.abs(sol.x - truth) < 4 * sd), (sol.x - truth, sd)
    assert np.exp(sol.x[0]) == pytest.approx(p, rel=0.01)
    # shared: one rate; combine() inverts split()
    np.testing.assert_allclose(joint.combine(np.stack([np.asarray(t) for t in
                                                       joint.split(sol.x)])), sol.x)
