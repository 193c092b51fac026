"""The K-mode model (dampfit.model.modes), its least squares and Cramér–Rao bound: analytic
checks and invariants (K = 1 is today's viscous model; K modes are the sum of K one-mode
models; the ordered prior; Kaufman's Jacobian gives the exact gradient)."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dampfit.errors import InputError
from dampfit.inference import crlb, modes_close
from dampfit.inference import least_squares as ls_mod
from dampfit.inference import modes as M
from dampfit.model import modes as mm
from dampfit.model import profile as prof
from dampfit.model import viscous
from dampfit.model.laws import P_RANGE, ViscousM1

TAU = np.arange(0.0, 12.0, 0.01)
MODES = [(0.15, 2 * np.pi * 2.1, 1.0, -0.3), (0.6, 2 * np.pi * 5.3, 0.25, 0.4),
         (1.1, 2 * np.pi * 11.0, 0.1, 0.05)]


def _y(modes, tau=TAU, noise=0.0, seed=0):
    y = sum(viscous.acceleration(tau, p, w, a, b, xp=np) for p, w, a, b in modes)
    return y + noise * np.random.default_rng(seed).standard_normal(tau.size)


def test_k_mode_model_is_the_sum_of_one_mode_models():
    """(MK1): the K-mode prediction with (θ, β, d) equals Σ of the (M1) accelerations of each
    mode plus the drift, for K = 1, 2, 3."""
    q = viscous.drift_basis(TAU, 2)
    d = np.array([0.03, -0.01, 0.02])
    for k in (1, 2, 3):
        theta = mm.to_theta([m[0] for m in MODES[:k]], [m[1] for m in MODES[:k]])
        beta = np.concatenate([[m[2], m[3]] for m in MODES[:k]])
        with jax.enable_x64(True):
            got = np.asarray(prof.predict(mm.model(k), jnp.asarray(np.concatenate([theta, beta, d])),
                                          TAU, q))
        np.testing.assert_allclose(got, _y(MODES[:k]) + q @ d, rtol=0, atol=1e-12)
    assert mm.model(3).n_params == 6 and mm.model(3).n_columns == 6


def test_one_mode_is_todays_viscous_model_to_rounding():
    """K = 1 gives the one-mode (M1) profile likelihood bit for bit up to rounding."""
    y = _y(MODES[:1], noise=0.02)
    q = viscous.drift_basis(TAU, 3)
    th = np.log([0.16, 2 * np.pi * 2.1003])
    with jax.enable_x64(True):
        s = prof.Samples.from_arrays(TAU, y, q, pad_to=1536, drift_columns=8)
        a = float(prof.log_marginal(mm.model(1), jnp.asarray(th), s, 0.8))
        b = float(prof.log_marginal(ViscousM1(), jnp.asarray(th), s, 0.8))
        c = float(viscous.log_marginal_likelihood(jnp.asarray(th), TAU, y, q, 0.8))
    assert a == pytest.approx(b, rel=1e-14) and a == pytest.approx(c, rel=1e-12)


def test_ordered_prior_density_support_and_volume():
    band = (1.0, 20.0)
    lw = np.log(2 * np.pi * np.array(band))
    th = mm.to_theta([0.1, 0.5], [2 * np.pi * 2.0, 2 * np.pi * 6.0])
    dens = -math.log(math.log(20.0)) * 2 - 2 * math.log(math.log(mm.P_MAX / P_RANGE)) + math.log(2)
    assert mm.log_prior(th, *lw) == pytest.approx(dens, rel=1e-12)
    assert mm.log_prior(th, *lw) == pytest.approx(-mm.log_prior_volume(2, band), rel=1e-12)
    swapped = th[[2, 3, 0, 1]]
    assert mm.log_prior(swapped, *lw) == -np.inf  # frequencies out of order
    assert mm.log_prior(mm.to_theta([0.1], [2 * np.pi * 30.0]), *lw) == -np.inf  # out of band
    assert mm.log_prior(mm.to_theta([20.0], [2 * np.pi * 2.0]), *lw) == -np.inf  # p > ω
    assert mm.log_prior(mm.to_theta([3.0], [2 * np.pi * 2.0]), *lw) == -np.inf  # ζ > 0.2
    # order() sorts by frequency and returns the permutation; NumPy and JAX agree
    srt, perm = mm.order(swapped)
    np.testing.assert_array_equal(srt, th)
    np.testing.assert_array_equal(perm, [1, 0])
    batch = np.stack([th, swapped, th])
    with jax.enable_x64(True):
        jx = np.asarray(jax.jit(lambda t: mm.log_prior(t, lw[0], lw[1], xp=jnp))(batch))
    np.testing.assert_array_equal(jx, mm.log_prior(batch, *lw))
    p, w = mm.rates(th)
    np.testing.assert_allclose(mm.to_theta(p, w), th)
    with pytest.raises(ValueError, match="at least one mode"):
        mm.model(0)


@pytest.mark.heavy
def test_kaufman_jacobian_gives_the_exact_rss_gradient():
    """Kaufman's variable-projection Jacobian drops a term orthogonal to the residual: Jᵀr,
    the gradient of the RSS, is exact (compared with autodiff through the Cholesky)."""
    y = _y(MODES[:2], noise=0.05)
    q = viscous.drift_basis(TAU, 2)
    mask = np.ones(TAU.size)
    th = np.log([0.17, 2 * np.pi * 2.101, 0.55, 2 * np.pi * 5.298])
    with jax.enable_x64(True):
        args = jax.device_put((TAU, y, q, mask))
        r = M.vp_residual(2, *args)
        g_k = np.asarray(jax.grad(lambda t: jnp.sum(r(t) ** 2))(jnp.asarray(th)))
        g_x = np.asarray(jax.grad(lambda t: jnp.sum(
            prof.profile(mm.model(2), t, *args).residual ** 2))(jnp.asarray(th)))
        np.testing.assert_array_equal(np.asarray(r(jnp.asarray(th))),
                                      np.asarray(prof.profile(mm.model(2), jnp.asarray(th),
                                                              *args).residual))
    np.testing.assert_allclose(g_k, g_x, rtol=1e-9, atol=1e-9 * np.abs(g_x).max())


@pytest.mark.heavy
def test_one_mode_least_squares_equals_the_pipeline_fit(short_paper):
    """fit_modes with K = 1 on the one-mode fit samples lands on the optimum of
    dampfit.inference.least_squares (the same model and profile)."""
    from dampfit.signal import prepare as pp

    rec, _ = short_paper
    prep = pp.prepare(rec)
    fd = pp.fit_data(prep)
    ref = ls_mod.least_squares(fd, 0.03, prep.f0)
    fit = M.fit_modes(fd, np.log([[0.03, 2 * np.pi * prep.f0]]))
    assert fit.converged and ref.converged
    np.testing.assert_allclose(fit.theta, ref.theta, rtol=1e-7)
    assert fit.rss == pytest.approx(ref.rss, rel=1e-9)
    np.testing.assert_allclose(fit.beta[:2], ref.beta[:2], rtol=1e-6)


def test_bound_of_one_mode_equals_the_one_mode_crlb():
    t = TAU[::2]
    p, w, a, b = MODES[0]
    one = crlb.bound(t, 0.02, p=p, omega_d=w, a_cos=a, a_sin=b, drift_degree=1)
    many = crlb.bound_modes(t, 0.02, [MODES[0]], drift_degree=1)[0]
    for name in ("p", "omega_d", "zeta", "f_n", "u0"):
        assert many[name]["sd"] == pytest.approx(one[name]["sd"], rel=1e-10)
        assert many[name]["value"] == pytest.approx(one[name]["value"], rel=1e-12)
    with_mass = crlb.bound_modes(t, 0.02, MODES[:2], drift_degree=1, mass=0.5, mode_of_mass=1)
    assert "c" not in with_mass[0] and "c" in with_mass[1] and "k" in with_mass[1]
    with pytest.raises(InputError, match="non-empty list"):
        crlb.fisher_modes(t, 0.02, [])
    with pytest.raises(InputError, match="cannot identify"):
        crlb.fisher_modes(t[:10], 0.02, MODES, drift_degree=1)


def test_close_modes_cost_precision_and_far_modes_do_not():
    """The CRLB inflation (C2) of a pair grows as its separation shrinks; far modes ≈ 1."""
    t = np.arange(0.0, 30.0, 0.02)
    p, w = 0.1, 2 * np.pi * 3.0
    far = modes_close.inflation(t, [(p, w, 1.0, 0.0), (p, 2 * np.pi * 9.0, 0.5, 0.2)])
    assert max(g for m in far for g in m.values()) < 1.05
    g = []
    for gap_cells in (8.0, 3.0, 1.5):
        w2 = w + 2 * np.pi * gap_cells / 30.0
        infl = modes_close.inflation(t, [(p, w, 1.0, 0.0), (p, w2, 0.7, 0.3)])
        g.append(max(infl[0]["zeta"], infl[1]["zeta"]))
    assert g[0] < g[1] < g[2] and g[2] > 1.25
    rows, warns = modes_close.pairs([p, p], [w, w + 2 * np.pi * 1.5 / 30.0],
                                    [1.0, 0.0, 0.7, 0.3], t)
    assert rows[0]["flagged"] and rows[0]["separation_resolution"] == pytest.approx(1.5, rel=1e-3)
    assert rows[0]["separation_half_power"] == pytest.approx(
        (1.5 / 30.0) / (p / math.pi), rel=1e-3)
    assert len(warns) == 1 and "modes 1 and 2" in warns[0]
