r"""Posterior draws of one damping law: emcee, or the Laplace approximation for cheap runs.

Target: the tempered marginal likelihood ℓ(θ)/r of :mod:`dampfit.damping.fit` (A, B, drift
and σ integrated out, Whittle factor r from :mod:`dampfit.noise`) times the prior
:func:`~dampfit.damping.fit.log_prior` — the same calibrated noise model as
:mod:`dampfit.posterior`, which samples the viscous law this way.

* ``emcee``: 64 walkers over θ with the viscous sampler's proposals
  (:func:`dampfit.posterior.MOVES`: kernel-density independence + differential evolution;
  on the real phone spring's 5-parameter power law 4 s and ESS ≈ 6,600 where the default
  stretch move took 12–15 s for ESS ≈ 2,500), the likelihood compiled once with JAX and
  vmapped, started in a ball from the Laplace covariance; runs in blocks until the chain exceeds 50
  integrated autocorrelation times, R-hat < 1.01 and bulk ESS ≥ ``min_ess`` (arviz), or
  ``max_steps`` (then ``converged`` is False and the reason is in ``warnings``).
* ``laplace``: the (nested) Laplace approximation of :mod:`dampfit.damping.fit` — viscous
  θ ~ N(θ̂, Σ); for a nonlinear law the shape s from its marginal on the evidence grid (L3)
  (inverse CDF), then (ln p₀, ln ω) ~ N(φ̂_s, Σ_s). Exact for a Gaussian posterior in
  (ln p₀, ln ω); used where thousands of replicates or a quick look are wanted.

For every θ draw the amplitudes (A, B) are drawn from their conditional Gaussian
N(β̂(θ), s²·r·M⁻¹), s² = RSS/(n − q), β̂(θ) linearised about θ̂, and give the start amplitude
a₀ = |(A, B)|/(ω²·|G|) [m].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import emcee
import numpy as np

from ..posterior import MOVES, burn_thin, diagnose, run_adaptive, seed_sampler
from . import fit as dfit
from . import models

__all__ = ["ModelPosterior", "sample_emcee", "sample_laplace", "N_WALKERS"]

N_WALKERS = 64


@dataclass(frozen=True)
class ModelPosterior:
    """Draws of θ (N, k) and a₀ [m] (N,) of one law, with how they were made."""

    model: str
    theta: np.ndarray
    a0: np.ndarray
    method: str  # "emcee" or "laplace"
    converged: bool
    n_steps: int = 0
    max_r_hat: float = float("nan")
    min_ess_bulk: float = float("nan")
    acceptance: float = float("nan")
    warnings: tuple[str, ...] = field(default_factory=tuple)


def _amplitudes(mf: dfit.ModelFit, thetas, data: dfit.Data, rng) -> np.ndarray:
    """a₀ [m] for each θ draw: (A, B) ~ N(β̂(θ), s²·r·M⁻¹), β̂(θ) linearised about θ̂.

    β̂(θ) ≈ β̂(θ̂) + (∂β̂/∂θ)·(θ − θ̂) (central differences) keeps the correlation of the
    amplitude with the decay parameters at the cost of one Jacobian instead of one
    projection per draw; the linearisation error is second order in the posterior width.
    """
    thetas = np.asarray(thetas, dtype=float)
    if len(thetas) == 0:
        return np.empty(0)
    beta, rss, _, minv, _ = dfit.profile(mf.model, mf.theta, data)
    jb = dfit.jacobian(lambda th: dfit.profile(mf.model, th, data)[0][:, :2], mf.theta)
    s2 = float(rss) / max(data.n - data.q, 1) / mf.temper
    chol = np.linalg.cholesky(minv * s2)
    ab = (beta[:2] + (thetas - mf.theta) @ jb.T
          + rng.standard_normal((len(thetas), 2)) @ chol.T)
    w = np.exp(thetas[:, models.omega_index(mf.model)])
    return np.hypot(ab[:, 0], ab[:, 1]) / (w * w * mf.gain)


def sample_laplace(mf: dfit.ModelFit, data: dfit.Data, n_draws: int = 2000, *,
                   seed: int = 0) -> ModelPosterior:
    """Draws from the (nested) Laplace approximation on the prior support (module docstring)."""
    rng = np.random.default_rng(seed)
    th_hat, cov = mf.theta, mf.cov
    if mf.model == "viscous":
        if cov is None or not np.all(np.isfinite(cov)):
            return ModelPosterior(mf.model, np.empty((0, mf.k)), np.empty(0), "laplace", False,
                                  warnings=("viscous: no Laplace approximation (fit failed)",))
        th = rng.multivariate_normal(th_hat, cov, size=n_draws)
    else:
        g = mf.grid
        ok = np.isfinite(g.log_density) if g is not None else np.zeros(0, bool)
        if ok.sum() < 3:
            return ModelPosterior(mf.model, np.empty((0, mf.k)), np.empty(0), "laplace", False,
                                  warnings=(f"{mf.model}: no evidence grid (fit failed)",))
        x, dens = g.s[ok], np.exp(g.log_density[ok] - g.log_density[ok].max())
        cdf = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(x))])
        s = np.interp(rng.uniform(0, cdf[-1], n_draws), cdf, x)
        m = g.phi.shape[1]
        phi = np.column_stack([np.interp(s, x, g.phi[ok, j]) for j in range(m)])
        near = np.abs(s[:, None] - x[None, :]).argmin(axis=1)
        chol = np.linalg.cholesky(g.phi_cov[ok][near])
        phi = phi + np.einsum("bij,bj->bi", chol, rng.standard_normal((n_draws, m)))
        th = np.column_stack([phi[:, :1], s, phi[:, 1:]])
    a0 = _amplitudes(mf, th, data, rng)
    return ModelPosterior(mf.model, th, a0, "laplace", True)


def sample_emcee(mf: dfit.ModelFit, data: dfit.Data, band: tuple[float, float], *, seed: int = 0,
                 min_ess: float = 1000.0, max_steps: int = 20000, block: int = 500,
                 progress: bool = False) -> ModelPosterior:
    """emcee posterior of one law with the tempered likelihood (module docstring)."""
    rng = np.random.default_rng(seed)
    model, temper, k = mf.model, mf.temper, mf.k

    loglik = dfit.loglik_jax(model, data)  # compiled once, evaluated ~10⁴ times

    def log_prob(thetas):
        lp = dfit.log_prior(model, thetas, band)
        return np.where(np.isfinite(lp), temper * loglik(thetas) + lp, -np.inf)

    # start: a ball drawn from the Laplace approximation (inside the prior support)
    start = sample_laplace(mf, data, n_draws=N_WALKERS, seed=seed).theta
    if len(start) < N_WALKERS:
        cov = mf.cov if mf.cov is not None and np.all(np.isfinite(mf.cov)) else np.diag(
            np.full(k, 1e-6))
        start = rng.multivariate_normal(mf.theta, cov, size=N_WALKERS)
    sampler = emcee.EnsembleSampler(N_WALKERS, k, log_prob, vectorize=True, moves=MOVES())
    seed_sampler(sampler, rng)
    from tqdm.auto import tqdm

    with tqdm(total=max_steps, desc=f"{model} posterior", unit="step", disable=not progress,
              leave=False) as bar:
        run = run_adaptive(sampler, start, min_ess=min_ess, max_steps=max_steps, block=block,
                           bar=bar)
    steps, tau, converged, reason = run.steps, run.tau, run.converged, run.reason
    warns = () if converged else (f"{model} posterior NOT converged after {steps} steps: {reason}",)
    burn, thin = burn_thin(tau)
    chain = sampler.get_chain(discard=burn, thin=thin)
    rhat, ess = diagnose(chain)
    th = chain.reshape(-1, k)
    a0 = _amplitudes(mf, th, data, rng)
    return ModelPosterior(model, th, a0, "emcee", converged, n_steps=steps, max_r_hat=rhat,
                          min_ess_bulk=ess, acceptance=float(np.mean(sampler.acceptance_fraction)),
                          warnings=warns)
