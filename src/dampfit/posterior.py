r"""Posterior of c, k, u₀ (and ζ, f_n) with emcee, diagnosed and stored with arviz.

Model and priors
----------------
* Likelihood: the decay model (:mod:`dampfit.model`) with Gaussian noise of unknown σ; the
  linear coefficients (acceleration quadratures A, B and the drift terms) have flat priors
  and σ a Jeffreys prior 1/σ, all marginalised analytically
  (:func:`dampfit.model.log_marginal_likelihood`), tempered by 1/r (:mod:`dampfit.noise`).
* Decay rate p [1/s]: log-uniform on [10⁻⁶·ω_d, ω_d] (ζ up to ≈ 0.7).
* Damped frequency ω_d [rad/s]: log-uniform over the analysis pass band.
* Mass m [kg]: normal(m, sd) truncated to m > 0, independent of the data — the recording
  identifies only p and ω_n, so c = 2·m·p and k = m·ω_n² take the mass uncertainty by
  drawing m for every posterior sample (exact, since m does not enter the likelihood).
* u₀ [m]: for every posterior sample of θ, (A, B) are drawn from their conditional Gaussian
  N(β̂(θ), s²·r·(XᵀX)⁻¹) and u₀ = √(A² + B²)/(ω_n²·|G|) (eq. M2, G the filter gain).

Sampling
--------
emcee's affine-invariant ensemble (32 walkers) over θ = (ln p, ln ω_d), vectorised: one
jitted, vmapped JAX call evaluates a half-ensemble. Walkers start in a small ball drawn from
the least-squares covariance. The chain runs in blocks until (a) its length exceeds 50
integrated autocorrelation times, (b) arviz's rank-normalised R-hat < 1.01 and (c) the bulk
effective sample size of every reported quantity exceeds ``min_ess`` — or until
``max_steps``; then ``converged`` is False and the reason is in ``warnings``.
"""

from __future__ import annotations

import warnings as _warnings
from contextlib import nullcontext as _nullcontext
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import emcee
import jax
import jax.numpy as jnp
import numpy as np

from . import model
from .fit import LeastSquaresResult
from .preprocess import FitData

if TYPE_CHECKING:  # arviz imports matplotlib.pyplot: keep it out of the numeric import path
    import arviz as az


def _arviz():
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore", FutureWarning)
        import arviz

    return arviz

__all__ = ["PosteriorResult", "sample", "N_WALKERS"]

N_WALKERS = 32
#: Posterior draws per batched call when drawing the amplitudes (bounds memory use).
AMPLITUDE_CHUNK = 256
PARAMETERS = ("c", "k", "u0", "zeta", "f_n")


def MOVES():
    """emcee proposal mixture: differential evolution (80 %) + DE snooker (20 %) — for this
    2-D, nearly Gaussian target it mixes ≈ 3× faster per step than the default stretch move."""
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


@dataclass(frozen=True)
class PosteriorResult:
    """Posterior draws as arviz ``InferenceData`` plus convergence facts."""

    idata: "az.InferenceData"
    converged: bool
    n_steps: int
    burn_in: int
    thin: int
    autocorr_time: np.ndarray  # integrated autocorrelation time of (ln p, ln ω_d) [steps]
    acceptance: float
    max_r_hat: float
    min_ess_bulk: float
    warnings: tuple[str, ...] = field(default_factory=tuple)


# Module-level jitted kernels on padded inputs (FitData.padded): compiled once per shape bucket,
# reused across analyses (a study of thousands of recordings compiles a handful of times).
@jax.jit
def _batched_log_prob(thetas, tau, y, drift, mask, n, q, temper, bounds):
    lw_lo, lw_hi = bounds[0], bounds[1]

    def one(theta):
        lnp, lnw = theta[0], theta[1]
        inside = (lnw > lw_lo) & (lnw < lw_hi) & (lnp < lnw) & (lnp > lnw + np.log(1e-6))
        ll = model.log_marginal_likelihood(theta, tau, y, drift, temper, mask, n, q)
        return jnp.where(inside & jnp.isfinite(ll), ll, -jnp.inf)

    return jax.vmap(one)(thetas)


@jax.jit
def _batched_amplitudes(thetas, z, tau, y, drift, mask, n, q, temper):
    def draw(th, zz):
        beta, rss, _, (chol, scale) = model.profile(th, tau, y, drift, mask)
        # scaled (A, B) have covariance s²·(LLᵀ)⁻¹ (drift marginalised): L⁻ᵀ·z, then unscale
        dev = jax.scipy.linalg.solve_triangular(chol.T, zz, lower=False) / scale
        return beta[:2] + jnp.sqrt(rss / (n - q) / temper) * dev

    return jax.vmap(draw)(thetas, z)


def _padded_args(fd: FitData):
    pad = fd.padded
    arrays = tuple(jnp.asarray(a) for a in (pad.tau, pad.y, pad.drift, pad.mask))
    return arrays + (jnp.float64(pad.n), jnp.float64(pad.q))


def _make_log_prob(fd: FitData, band: tuple[float, float], temper: float):
    """Vectorised log posterior of θ = (ln p, ln ω_d) for emcee (NumPy in, NumPy out)."""
    with jax.enable_x64(True):
        args = _padded_args(fd)
        bounds = jnp.asarray([np.log(2 * np.pi * band[0]), np.log(2 * np.pi * band[1])])
        temper_ = jnp.float64(temper)

    def log_prob(thetas: np.ndarray) -> np.ndarray:  # called inside jax.enable_x64(True)
        return np.asarray(_batched_log_prob(jnp.asarray(thetas, dtype=jnp.float64), *args,
                                            temper_, bounds))

    return log_prob


def _conditional_amplitudes(fd: FitData, thetas: np.ndarray, temper: float, rng) -> np.ndarray:
    """Draw (A, B) [m/s²] given each θ from N(β̂(θ), s²·r·(XᵀX)⁻¹)."""
    n_draws = len(thetas)
    z = rng.standard_normal((n_draws, 2))
    out = np.empty((n_draws, 2))
    chunk = AMPLITUDE_CHUNK  # bounded memory: chunk × n_samples × q doubles
    with jax.enable_x64(True):
        args = _padded_args(fd)
        temper_ = jnp.float64(temper)
        for i in range(0, n_draws, chunk):
            th, zz = thetas[i : i + chunk], z[i : i + chunk]
            m = len(th)
            if m < chunk:  # pad to one shape: one compilation
                th = np.concatenate([th, np.repeat(th[-1:], chunk - m, axis=0)])
                zz = np.concatenate([zz, np.zeros((chunk - m, 2))])
            res = _batched_amplitudes(jnp.asarray(th), jnp.asarray(zz), *args, temper_)
            out[i : i + m] = np.asarray(res)[:m]
    return out


def mass_draws(mass: float | None, mass_sd: float, size, rng) -> np.ndarray | None:
    """Mass draws [kg]: normal(mass, mass_sd) truncated at m > 0; None without a mass."""
    if mass is None:
        return None
    if not mass_sd:
        return np.full(size, float(mass))
    draws = rng.normal(mass, mass_sd, size)
    bad = draws <= 0
    while bad.any():  # truncate at m > 0
        draws[bad] = rng.normal(mass, mass_sd, int(bad.sum()))
        bad = draws <= 0
    return draws


def sample(
    fd: FitData,
    ls: LeastSquaresResult,
    *,
    band: tuple[float, float],
    temper: float,
    mass: float | None = None,
    mass_sd: float = 0.0,
    seed: int = 0,
    min_ess: float = 1000.0,
    max_steps: int = 20000,
    block: int = 500,
    progress: bool = False,
) -> PosteriorResult:
    """Sample the posterior; see the module docstring for the model, priors and stopping rule.

    ``temper`` = 1/r; ``mass``, ``mass_sd`` [kg]; ``seed`` makes the run reproducible.
    """
    rng = np.random.default_rng(seed)
    log_prob = _make_log_prob(fd, band, temper)
    cov = np.asarray(ls.cov[:2, :2]) / temper
    if not np.all(np.isfinite(cov)) or np.linalg.eigvalsh(cov).min() <= 0:
        cov = np.diag((1e-3 * np.abs(ls.theta) + 1e-6) ** 2)
    start = rng.multivariate_normal(ls.theta, 0.25 * cov, size=N_WALKERS)
    sampler = emcee.EnsembleSampler(N_WALKERS, 2, log_prob, vectorize=True, moves=MOVES())
    warns: list[str] = []
    bar = _progress(max_steps, progress)
    try:
        run = run_adaptive(sampler, start, min_ess=min_ess, max_steps=max_steps, block=block,
                           bar=bar, x64=True)
    finally:
        bar.close()
    steps, tau, converged, reason = run.steps, run.tau, run.converged, run.reason
    if not converged:
        warns.append(f"posterior NOT converged after {steps} steps: {reason}")
    burn, thin = burn_thin(tau)
    chain = sampler.get_chain(discard=burn, thin=thin)  # (draw, walker, 2)
    lp = sampler.get_log_prob(discard=burn, thin=thin)
    idata = _to_idata(fd, ls, chain, lp, temper, mass, mass_sd, rng)
    az = _arviz()
    summ = az.summary(idata, var_names=[v for v in PARAMETERS if v in idata.posterior],
                      kind="diagnostics", round_to="none")
    max_rhat = float(summ["r_hat"].max())
    min_ess = float(summ["ess_bulk"].min())
    return PosteriorResult(
        idata=idata, converged=converged, n_steps=steps, burn_in=burn, thin=thin,
        autocorr_time=np.asarray(tau), acceptance=float(np.mean(sampler.acceptance_fraction)),
        max_r_hat=max_rhat, min_ess_bulk=min_ess, warnings=tuple(warns),
    )


@dataclass(frozen=True)
class AdaptiveRun:
    """Outcome of :func:`run_adaptive`: steps taken, autocorrelation times [steps] per
    dimension, whether the stopping rule was met, and otherwise why not."""

    steps: int
    tau: np.ndarray
    converged: bool
    reason: str


def run_adaptive(sampler: "emcee.EnsembleSampler", start: np.ndarray, *, min_ess: float,
                 max_steps: int, block: int = 500, bar=None, x64: bool = False) -> AdaptiveRun:
    """Run ``sampler`` from ``start`` in blocks until the stopping rule of the module
    docstring holds (≥ 50 τ_int, R-hat < 1.01, bulk ESS ≥ ``min_ess``) or ``max_steps``.

    ``bar`` (tqdm) is advanced per block; ``x64`` runs each block inside
    ``jax.enable_x64(True)`` (a JAX log-probability called once per half-ensemble).
    """
    state, steps = start, 0
    tau = np.full(sampler.ndim, np.nan)
    converged, reason = False, ""
    while steps < max_steps:
        n = min(block, max_steps - steps)
        with jax.enable_x64(True) if x64 else _nullcontext():
            state = sampler.run_mcmc(state, n, progress=False)
        steps += n
        if bar is not None:
            bar.update(n)
        tau = sampler.get_autocorr_time(tol=0)
        if steps < 50 * np.nanmax(tau):
            reason = f"chain shorter than 50 autocorrelation times ({np.nanmax(tau):.0f} steps)"
            continue
        burn, thin = burn_thin(tau)
        rhat, ess = diagnose(sampler.get_chain(discard=burn, thin=thin))
        if rhat < 1.01 and ess >= min_ess:
            converged = True
            break
        reason = f"R-hat {rhat:.3f} (needs < 1.01), bulk ESS {ess:.0f} (needs ≥ {min_ess:.0f})"
    return AdaptiveRun(steps=steps, tau=np.asarray(tau), converged=converged, reason=reason)


def burn_thin(tau: np.ndarray) -> tuple[int, int]:
    """Burn-in (3 τ) and thinning (τ/4) [steps] from autocorrelation times ``tau``."""
    t = float(np.nanmax(tau)) if np.all(np.isfinite(tau)) else 50.0
    return int(np.ceil(3 * t)), max(1, int(t / 4))


def diagnose(chain: np.ndarray) -> tuple[float, float]:
    """Worst rank-normalised R-hat and bulk ESS over the dimensions of a (draw, walker, k)
    chain, walkers taken as chains."""
    if chain.shape[0] < 8:
        return np.inf, 0.0
    x = np.transpose(chain, (1, 0, 2))  # (chain, draw, dim)
    az = _arviz()
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        rh = [float(az.rhat(x[..., i])) for i in range(x.shape[-1])]
        es = [float(az.ess(x[..., i], method="bulk")) for i in range(x.shape[-1])]
    return max(rh), min(es)


def _to_idata(fd, ls, chain, lp, temper, mass, mass_sd, rng) -> "az.InferenceData":
    n_draw, n_walk, _ = chain.shape
    flat = chain.reshape(-1, 2)
    p, wd = np.exp(flat[:, 0]), np.exp(flat[:, 1])
    ab = _conditional_amplitudes(fd, flat, temper, rng)
    wn2 = wd**2 + p**2
    u0 = np.hypot(ab[:, 0], ab[:, 1]) / (wn2 * abs(ls.gain))
    post = {
        "p": p, "omega_d": wd, "zeta": p / np.sqrt(wn2), "f_n": np.sqrt(wn2) / (2 * np.pi),
        "f_d": wd / (2 * np.pi), "delta": 2 * np.pi * p / wd, "Q": 0.5 * np.sqrt(wn2) / p,
        "u0": u0,
    }
    m = mass_draws(mass, mass_sd, p.size, rng)
    if m is not None:
        post.update({"mass": m, "c": 2 * m * p, "k": m * wn2, "c_crit": 2 * m * np.sqrt(wn2)})

    def shape(v):  # emcee: (draw, walker) → arviz: (chain, draw)
        return v.reshape(n_draw, n_walk).T

    return _arviz().from_dict(
        posterior={k: shape(v) for k, v in post.items()},
        sample_stats={"lp": lp.T},
        attrs={"sampler": f"emcee {emcee.__version__}", "n_walkers": n_walk,
               "likelihood_temper": float(temper)},
    )


def _progress(total: int, enabled: bool):
    from tqdm.auto import tqdm

    return tqdm(total=total, desc="posterior (emcee steps)", unit="step", disable=not enabled,
                leave=False, dynamic_ncols=True)
