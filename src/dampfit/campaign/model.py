r"""Hierarchical model of a test campaign: several free decays of one damper (pure JAX, no I/O).

Per-test likelihood
-------------------
Test i (one recording, its own window, band, drift, amplitudes and noise calibration r_i)
has the profiled σ-marginal likelihood of θ_i = (ln p_i, ln ω_d,i) [ln(1/s), ln(rad/s)]

    ℓ_i(θ_i) = (1/r_i)·[−½·ln det X⊥ᵀX⊥ − ½·(n_i − q_i)·ln RSS_i(θ_i)]                (C1)

(eq. P3 of :mod:`dampfit.model.profile`, the viscous columns
:class:`~dampfit.model.laws.ViscousM1`; amplitudes, drift and σ integrated out). In the
population coordinates ψ_i = (ln p_i, ln ω_n,i), ω_n² = ω_d² + p², it is approximated by its
Laplace expansion about its maximum ψ̂_i,

    ℓ̃_i(ψ) = ℓ_i(θ̂_i) − ½·(ψ − ψ̂_i)ᵀ·Σ_i⁻¹·(ψ − ψ̂_i),   Σ_i = J·(−∇²ℓ_i)⁻¹·Jᵀ,     (C2)

J = ∂ψ/∂θ = [[1, 0], [p²/ω_n², ω_d²/ω_n²]]. The exact ℓ_i is restored afterwards by importance
weights (:mod:`dampfit.campaign.sampling`), so (C2) only has to be a good proposal.

Population (hierarchical, non-centred)
--------------------------------------
*Known-mass (or no-mass) design* ("hierarchical"): hyper-parameters φ = (μ_p, μ_ω, τ_p, τ_ω),

    ln p_i   = μ_p + τ_p·z_p,i,      ln ω_n,i = μ_ω + τ_ω·z_ω,i,     z ~ N(0, 1),         (C3)

μ_p [ln(1/s)] and μ_ω [ln(rad/s)] the population medians' logarithms, τ_p and τ_ω [1] the
between-test standard deviations of ln p and ln ω_n (relative spreads). The population damper
is c = 2·m·e^{μ_p} [N·s/m], k = m·e^{2μ_ω} [N/m] (m [kg] the given mass, drawn normal(m, sd)).

*Added-mass design* ("added-mass"): known added masses Δm_i [kg] (sd s_Δm [kg]), unknown
effective mass m₀ [kg], stiffness k [N/m] and a shared c [N·s/m]. With M_i = m₀ + Δm_i,

    ln ω_n,i = ½·ln k − ½·ln M_i + τ_ω·z_ω,i,     ln p_i = ln c − ln 2 − ln M_i + τ_p·z_p,i,   (C4)

i.e. ω_n,i² = k/M_i and c = 2·M_i·p_i up to between-test scatter. It is sampled as
φ = (ln p₀, ln ω₀, ln m₀, ln τ_p, ln τ_ω) with the bare system's p₀ = c/(2m₀) [1/s] and
ω₀ = √(k/m₀) [rad/s], so ln p_i = ln p₀ − ln(1 + Δm_i/m₀) and
ln ω_n,i = ln ω₀ − ½·ln(1 + Δm_i/m₀): the bare test pins (p₀, ω₀) and the fall of the
frequency with Δm pins m₀, far less correlated than (ln c, ln k, ln m₀). The added-mass uncertainty
enters linearised: δ ln M_i = δΔm_i/M_i with sd s_i/M_i moves (ln p_i, ln ω_n,i) by
(−1, −½)·δ ln M_i, a covariance (s_i/M_i)²·[[1, ½], [½, ¼]] added to the scatter; s_i = s_Δm
for every added mass and s_i = 0 for the bare system (Δm_i = 0: nothing was put on a scale).

Marginal over the z's
---------------------
With the Gaussian (C2), the per-test ψ_i integrate out in closed form:

    p(data | φ) ∝ Π_i N(ψ̂_i; μ_i(φ), T_i(φ) + Σ_i),   T_i = diag(τ_p², τ_ω²) (+ the Δm term),  (C5)

and ψ_i | φ, data is Gaussian with mean μ_i + T_i(T_i + Σ_i)⁻¹(ψ̂_i − μ_i) and covariance
T_i − T_i(T_i + Σ_i)⁻¹T_i — the non-centred draw ψ_i = μ_i + (T_i)^{½}·z_i conditioned on the
data, well defined as τ → 0. emcee therefore samples only φ (4 or 5 dimensions); the z's are
drawn exactly given φ.

Sampler coordinates (non-centred levels)
----------------------------------------
With few tests the spreads are barely identified and the levels' conditional width follows
them: given τ_ω, ln ω_n of the population is known to ≈ √((τ_ω² + Σ_ωω)/n), from the tests'
own 1e-5 when τ_ω → 0 to τ_ω/√n when the scatter prior allows ≈ 5 % — a funnel. With two tests
the posterior of ln τ_ω is flat over that whole range (one difference of two frequencies cannot
tell the spread from zero), and emcee needed τ_int ≈ 240 steps and 20,000 steps in all
(3–6× a 3-test campaign). emcee therefore samples x = (η_p, η_ω, [ln m₀], ln τ_p, [ln τ_ω]),

    level_j = c_j(τ, m₀) + s_j(τ, m₀)·η_j,   s_j = (Σ_i w_ij)^{−½},
    c_j = s_j²·Σ_i w_ij·(ψ̂_ij + δ_ij),   w_ij = 1/(τ_j² + Σ_i,jj + D_i,jj),                (C8)

for the two levels (μ_p, μ_ω; or ln p₀, ln ω₀), δ_i = ln(M_i/m₀)·(1, ½) and D_i the added-mass
term of T_i (both 0 in the known-mass design): the precision-weighted mean of the tests and
its width, so that η is ≈ standard normal whatever τ. The map is triangular (τ and m₀ are
kept), its log-Jacobian Σ_j ln s_j is added to the log posterior, and every result is
reported in φ (:func:`to_hyper`).

Priors (weakly informative; documented in ``summary.json`` terms)
-----------------------------------------------------------------
* τ_p ~ half-normal(scale :data:`TAU_P_SCALE` = 0.5): relative spreads of up to ≈ 100 % in
  the decay rate are plausible; τ_p ≥ 0.
* τ_ω: with probability :data:`P_SHARED_FREQUENCY` = ½ exactly 0 (model M₀: the tests share one
  frequency law, ω_n,i = ω_n or ω_n,i² = k/M_i), otherwise half-normal(scale
  :data:`TAU_OMEGA_SCALE` = 0.05) (model M₁: up to ≈ 10 % scatter, e.g. from remounting).
  Repeated releases of an unchanged system agree in frequency to the precision of each test
  (1e-5–1e-4 relative), far below any scale a continuous prior could be given; under M₁ alone τ_ω
  then sits near the tests' own precision and widens the intervals of k and m₀ by ≈ √2 for
  nothing (measured: 98–100 % coverage of nominal 90 %). The spike at 0 lets the data choose.
* μ_p, μ_ω (or ln p₀, ln ω₀, ln m₀): normal with sd :data:`LOCATION_SD` = 5 (a factor e⁵ ≈ 150)
  about the least-squares values — flat wherever the data have anything to say.

Shared frequency or scatter: the Bayes factor
---------------------------------------------
M₀ is M₁ at τ_ω = 0 and the other priors do not depend on τ_ω, so the Savage–Dickey ratio gives
the Bayes factor from M₁'s posterior alone, Rao–Blackwellised over the other parameters φ₋:

    B₀₁ = p(τ_ω = 0 | data, M₁) / π(τ_ω = 0)
        = E_{φ₋ | data, M₁} [ L(φ₋, 0) / ∫₀^∞ L(φ₋, τ)·π(τ) dτ ],                          (C7)

L the likelihood (C5), π the normalised half-normal. The τ-integral is a quadrature in ln τ on
:data:`BF_GRID` points from τ = 10⁻¹⁰ (below it L is flat at L(φ₋, 0): the rest adds
L(φ₋, 0)·π(0)·10⁻¹⁰) to 10 scales. (C7) uses the Gaussian (C2); the exact likelihoods multiply
it by the ratio of the two models' mean importance weights (C6)
(:mod:`dampfit.campaign.sampling`). P(M₀ | data) = B₀₁/(1 + B₀₁) for even prior odds.
* μ_p, μ_ω (or ln p₀, ln ω₀, ln m₀): normal with sd :data:`LOCATION_SD` = 5 (a factor e⁵ ≈ 150)
  about the least-squares values — flat wherever the data have anything to say.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dampfit.model import profile
from dampfit.model.laws import ViscousM1

#: Half-normal scale of τ_p, the between-test sd of ln p [1].
TAU_P_SCALE = 0.5
#: Half-normal scale of τ_ω, the between-test sd of ln ω_n [1].
TAU_OMEGA_SCALE = 0.05
#: Prior probability [1] that τ_ω = 0 exactly (model M₀ of the module docstring).
P_SHARED_FREQUENCY = 0.5
#: Quadrature points of the τ-integral of (C7), and its lower end [1].
BF_GRID = 256
BF_TAU_MIN = 1e-10
#: Draws of M₁'s posterior averaged in (C7) (a fixed size: the kernel compiles once).
BF_DRAWS = 2048
#: Prior sd [1] of the location parameters (μ_p, μ_ω; ln c, ln k, ln m₀) about their
#: least-squares values.
LOCATION_SD = 5.0
#: Lower bound of ln τ [1] (τ > 1e-13: far below any test's own relative uncertainty; the
#: prior density in ln τ vanishes like τ there, so the bound cuts off nothing measurable).
LN_TAU_MIN = -30.0
#: The viscous law with the pipeline's (M1) columns: θ = (ln p, ln ω_d).
M1 = ViscousM1()


class CampaignData(NamedTuple):
    """Per-test Laplace summaries and the design, as float64 arrays.

    ``psi_hat`` (n, 2) = (ln p̂_i, ln ω̂_n,i); ``sigma`` (n, 2, 2) Σ_i of (C2); ``dm`` (n,) Δm_i
    [kg] (zeros in the known-mass design); ``dm_sd`` (n,) their sds s_i [kg] (0 for the bare
    system); ``centre`` (k,) prior centres of
    the location parameters; ``added`` 1.0 in the added-mass design, else 0.0."""

    psi_hat: jnp.ndarray
    sigma: jnp.ndarray
    dm: jnp.ndarray
    dm_sd: jnp.ndarray
    centre: jnp.ndarray
    added: jnp.ndarray


def hyper_names(added_mass: bool) -> tuple[str, ...]:
    """Names of φ in the posterior (and their order in the sampler)."""
    if added_mass:
        return ("ln_p0", "ln_omega0", "ln_m0", "ln_tau_p", "ln_tau_omega")
    return ("mu_ln_p", "mu_ln_omega_n", "ln_tau_p", "ln_tau_omega")


def means_and_scatter(phi, data: CampaignData, xp=jnp):
    """μ_i(φ) (n, 2) and T_i(φ) (n, 2, 2) of (C3)/(C4) for one φ (k,) (``xp`` = jnp or np)."""
    n = data.psi_hat.shape[0]
    tau_p, tau_w = xp.exp(phi[-2]), xp.exp(phi[-1])
    base = xp.diag(xp.stack([tau_p**2, tau_w**2]))
    ones = xp.ones(n)
    if phi.shape[0] == 5:
        ln_p0, ln_w0, ln_m0 = phi[0], phi[1], phi[2]
        big_m = xp.exp(ln_m0) + data.dm
        ratio = xp.log1p(data.dm * xp.exp(-ln_m0))  # ln(M_i/m₀)
        mu = xp.stack([ln_p0 - ratio, ln_w0 - 0.5 * ratio], axis=-1)
        s2 = (data.dm_sd / big_m) ** 2
        dmcov = s2[:, None, None] * xp.asarray([[1.0, 0.5], [0.5, 0.25]])[None]
        t = base[None] + dmcov
    else:
        mu = xp.stack([phi[0] * ones, phi[1] * ones], axis=-1)
        t = xp.broadcast_to(base, (n, 2, 2))
    return mu, t


def _log_normal2(x, cov):
    """log N(x; 0, cov) for batches of 2-vectors x (..., 2) and 2×2 cov (..., 2, 2)."""
    a, b, d = cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 1]
    det = a * d - b * b
    quad = (d * x[..., 0] ** 2 - 2 * b * x[..., 0] * x[..., 1] + a * x[..., 1] ** 2) / det
    return -0.5 * quad - 0.5 * jnp.log(det) - jnp.log(2 * jnp.pi)


def _log_prior(phi, data: CampaignData):
    """Priors of the module docstring; τ sampled as u = ln τ (log-Jacobian + u)."""
    u_p, u_w = phi[-2], phi[-1]
    tau_p, tau_w = jnp.exp(u_p), jnp.exp(u_w)
    loc = phi[:-2]
    lp = -0.5 * jnp.sum(((loc - data.centre) / LOCATION_SD) ** 2)
    lp = lp - 0.5 * (tau_p / TAU_P_SCALE) ** 2 - 0.5 * (tau_w / TAU_OMEGA_SCALE) ** 2 + u_p + u_w
    ok = (u_p > LN_TAU_MIN) & (u_w > LN_TAU_MIN)
    return jnp.where(ok, lp, -jnp.inf)


def _one_log_posterior(phi, data: CampaignData):
    lp = _log_prior(phi, data)
    mu, t = means_and_scatter(phi, data)
    ll = jnp.sum(_log_normal2(data.psi_hat - mu, t + data.sigma))
    out = lp + ll
    return jnp.where(jnp.isfinite(out), out, -jnp.inf)


@jax.jit
def log_posterior(phis, data: CampaignData):
    """Log posterior of a batch of φ (walkers, k) under (C5) and the priors [1]; −inf outside
    the support (τ < 0). Compiled once per (walkers, n tests, design)."""
    return jax.vmap(_one_log_posterior, in_axes=(0, None))(phis, data)


@jax.jit
def log_posterior_shared(phis, data: CampaignData):
    """Log posterior of M₀ (τ_ω = 0) for a batch of φ₋ (walkers, k − 1): φ without its last
    entry ln τ_ω [1]."""
    full = jnp.concatenate([phis, jnp.full((phis.shape[0], 1), -jnp.inf)], axis=1)

    def one(phi):
        lp = _log_prior(phi.at[-1].set(0.0), data)  # the τ_ω terms at u = 0 are constant
        lp = lp + 0.5 * (1.0 / TAU_OMEGA_SCALE) ** 2
        mu, t = means_and_scatter(phi, data)
        out = lp + jnp.sum(_log_normal2(data.psi_hat - mu, t + data.sigma))
        return jnp.where(jnp.isfinite(out), out, -jnp.inf)

    return jax.vmap(one)(full)



# ----------------------------------------------------------------------- sampler coordinates
def _centring(phi, data: CampaignData, xp=jnp):
    """(c, s) of (C8) (2,) each for the levels at φ's spreads (and m₀); φ's levels unused."""
    tau2 = xp.exp(2.0 * phi[-2:])  # τ_p², τ_ω² (0 for ln τ = −inf)
    own = data.sigma[:, [0, 1], [0, 1]]  # Σ_i,jj (n, 2)
    if phi.shape[0] == 5:
        big_m = xp.exp(phi[2]) + data.dm
        ratio = xp.log1p(data.dm * xp.exp(-phi[2]))
        shift = xp.stack([ratio, 0.5 * ratio], axis=-1)
        extra = ((data.dm_sd / big_m) ** 2)[:, None] * xp.asarray([1.0, 0.25])[None]
    else:
        shift = xp.zeros_like(own)
        extra = xp.zeros_like(own)
    w = 1.0 / (tau2[None, :] + own + extra)
    total = xp.sum(w, axis=0)
    centre = xp.sum(w * (data.psi_hat + shift), axis=0) / total
    return centre, 1.0 / xp.sqrt(total)


def to_hyper(x, data: CampaignData, xp=jnp):
    """φ (k,) and ln|∂φ/∂x| [1] from sampler coordinates x (k,) of (C8); x's η in the level
    slots, the rest of x as in φ (``xp`` = jnp or np)."""
    centre, scale = _centring(x, data, xp)
    phi = xp.concatenate([centre + scale * x[:2], x[2:]])
    return phi, xp.sum(xp.log(scale))


def from_hyper(phi: np.ndarray, data: CampaignData) -> np.ndarray:
    """Sampler coordinates x (N, k) of φ rows (N, k) (the inverse of :func:`to_hyper`)."""
    phi = np.atleast_2d(np.asarray(phi, dtype=float))
    d = CampaignData(*(np.asarray(a) for a in data))
    out = phi.copy()
    for i, row in enumerate(phi):
        centre, scale = _centring(row, d, np)
        out[i, :2] = (row[:2] - centre) / scale
    return out


@jax.jit
def _sampler_m1(xs, data: CampaignData):
    def one(x):
        phi, logdet = to_hyper(x, data)
        out = _one_log_posterior(phi, data) + logdet
        return jnp.where(jnp.isfinite(out), out, -jnp.inf)

    return jax.vmap(one)(xs)


@jax.jit
def _sampler_m0(xs, data: CampaignData):
    full = jnp.concatenate([xs, jnp.full((xs.shape[0], 1), -jnp.inf)], axis=1)

    def one(x):
        phi, logdet = to_hyper(x, data)
        out = log_posterior_shared(phi[None, :-1], data)[0] + logdet
        # a level far out makes the map's log-Jacobian inf − inf: outside, not NaN (emcee
        # stops at a NaN)
        return jnp.where(jnp.isfinite(out), out, -jnp.inf)

    return jax.vmap(one)(full)


def sampler_log_posterior(shared: bool):
    """Batched log posterior [1] in the sampler coordinates of (C8): of M₀ (``shared``: τ_ω = 0,
    x without ln τ_ω) or of M₁; the log posterior of φ plus the map's log-Jacobian."""
    return _sampler_m0 if shared else _sampler_m1


@jax.jit
def _log_bf_terms(phis, data: CampaignData):
    """ln[L(φ₋, 0) / ∫ L(φ₋, τ)·π(τ) dτ] of (C7) for each row of ``phis`` (N, k) (its last
    entry ignored)."""
    u = jnp.linspace(jnp.log(BF_TAU_MIN), jnp.log(10 * TAU_OMEGA_SCALE), BF_GRID)
    tau = jnp.exp(u)
    log_pi = 0.5 * jnp.log(2 / jnp.pi) - jnp.log(TAU_OMEGA_SCALE) - 0.5 * (tau / TAU_OMEGA_SCALE) ** 2
    du = u[1] - u[0]
    trap = jnp.full(BF_GRID, du).at[0].set(0.5 * du).at[-1].set(0.5 * du)

    def loglik(phi, ln_tau):
        mu, t = means_and_scatter(phi.at[-1].set(ln_tau), data)
        return jnp.sum(_log_normal2(data.psi_hat - mu, t + data.sigma))

    def one(phi):
        ll0 = loglik(phi, -jnp.inf)
        lls = jax.vmap(lambda v: loglik(phi, v))(u)
        body = jax.scipy.special.logsumexp(lls + log_pi + u + jnp.log(trap))
        below = ll0 + log_pi[0] + jnp.log(BF_TAU_MIN)
        return ll0 - jnp.logaddexp(body, below)

    return jax.vmap(one)(phis)


def log_bayes_factor_shared(phi: np.ndarray, data: CampaignData,
                            rng: np.random.Generator) -> float:
    """ln B₀₁ of (C7) from M₁'s posterior draws ``phi`` (N, k), at most :data:`BF_DRAWS` of
    them (drawn without replacement). Float64 must be enabled."""
    phi = np.asarray(phi, dtype=float)
    if phi.shape[0] > BF_DRAWS:
        phi = phi[rng.choice(phi.shape[0], BF_DRAWS, replace=False)]
    n = phi.shape[0]
    pad = np.empty((BF_DRAWS, phi.shape[1]))
    pad[:] = phi[0]
    pad[:n] = phi
    terms = np.asarray(_log_bf_terms(jnp.asarray(pad), data))[:n]
    terms = terms[np.isfinite(terms)]
    if terms.size == 0:
        return float("nan")
    top = terms.max()
    return float(top + np.log(np.mean(np.exp(terms - top))))


def conditional(phi: np.ndarray, data: CampaignData, rng: np.random.Generator) -> np.ndarray:
    """One draw of ψ_i | φ, data for every row of ``phi`` (N, k): array (N, n, 2) (NumPy).

    Gaussian with mean μ + T(T + Σ)⁻¹(ψ̂ − μ) and covariance T − T(T + Σ)⁻¹T (module
    docstring), stable as T → 0."""
    phi = np.asarray(phi, dtype=float)
    psi_hat, sigma = np.asarray(data.psi_hat), np.asarray(data.sigma)
    dm, dm_sd = np.asarray(data.dm), np.asarray(data.dm_sd)
    n = psi_hat.shape[0]
    tau_p, tau_w = np.exp(phi[:, -2]), np.exp(phi[:, -1])
    t = np.zeros((phi.shape[0], n, 2, 2))
    t[..., 0, 0] = tau_p[:, None] ** 2
    t[..., 1, 1] = tau_w[:, None] ** 2
    if phi.shape[1] == 5:
        big_m = np.exp(phi[:, 2])[:, None] + dm[None, :]
        ratio = np.log1p(dm[None, :] * np.exp(-phi[:, [2]]))
        mu = np.stack([phi[:, [0]] - ratio, phi[:, [1]] - 0.5 * ratio], -1)
        s2 = (dm_sd / big_m) ** 2
        t = t + s2[..., None, None] * np.array([[1.0, 0.5], [0.5, 0.25]])
    else:
        mu = np.broadcast_to(phi[:, None, :2], (phi.shape[0], n, 2))
    gain = t @ np.linalg.inv(t + sigma[None])
    mean = mu + np.einsum("...ij,...j->...i", gain, psi_hat[None] - mu)
    cov = t - gain @ t
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    z = rng.standard_normal(mean.shape)
    l11 = np.sqrt(np.maximum(cov[..., 0, 0], 0.0))
    l21 = np.where(l11 > 0, cov[..., 0, 1] / np.where(l11 > 0, l11, 1.0), 0.0)
    l22 = np.sqrt(np.maximum(cov[..., 1, 1] - l21**2, 0.0))
    return np.stack([mean[..., 0] + l11 * z[..., 0],
                     mean[..., 1] + l21 * z[..., 0] + l22 * z[..., 1]], -1)


def gaussian_log_likelihood(psi: np.ndarray, data: CampaignData) -> np.ndarray:
    """ℓ̃_i(ψ) − ℓ_i(θ̂_i) of (C2) for draws ψ (N, n, 2): array (N, n) (NumPy)."""
    psi_hat, sigma = np.asarray(data.psi_hat), np.asarray(data.sigma)
    prec = np.linalg.inv(sigma)
    d = psi - psi_hat[None]
    return -0.5 * np.einsum("...i,...ij,...j->...", d, prec[None], d)


# --------------------------------------------------------------------------- exact (C1)
@jax.jit
def _batched_marginal(thetas, samples: profile.Samples, temper):
    def one(theta):
        ll = profile.log_marginal(M1, theta, samples, temper)
        return jnp.where(jnp.isfinite(ll), ll, -jnp.inf)

    return jax.vmap(one)(thetas)


#: Batch size of exact-likelihood evaluations (fixed, so the kernel compiles once per padded
#: shape bucket of the recording).
CHUNK = 1024


def exact_log_likelihood(thetas: np.ndarray, samples: profile.Samples, temper: float) -> np.ndarray:
    """ℓ_i(θ) of (C1) for θ rows (N, 2) = (ln p, ln ω_d) of one test: array (N,); −inf where
    undefined. Evaluated in fixed-size chunks; call with float64 enabled
    (``jax.enable_x64(True)``)."""
    thetas = np.asarray(thetas, dtype=float)
    out = np.empty(thetas.shape[0])
    for start in range(0, thetas.shape[0], CHUNK):
        part = thetas[start:start + CHUNK]
        pad = np.zeros((CHUNK, 2))
        pad[:] = part[0] if part.shape[0] else 0.0
        pad[:part.shape[0]] = part
        vals = np.asarray(_batched_marginal(jnp.asarray(pad), samples, jnp.float64(temper)))
        out[start:start + part.shape[0]] = vals[:part.shape[0]]
    return out


def _stencil(theta: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The 9-point central-difference stencil about θ with steps h (2,): rows (9, 2)."""
    offsets = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1],
                        [1, 1], [-1, -1], [1, -1], [-1, 1]], dtype=float)
    return theta[None] + offsets * h[None]


def _derivatives(values: np.ndarray, h: np.ndarray):
    """Gradient and Hessian of ℓ from its values on :func:`_stencil`."""
    f0, fx1, fx0, fy1, fy0, fpp, fmm, fpm, fmp = values
    g = np.array([(fx1 - fx0) / (2 * h[0]), (fy1 - fy0) / (2 * h[1])])
    hxx = (fx1 - 2 * f0 + fx0) / h[0] ** 2
    hyy = (fy1 - 2 * f0 + fy0) / h[1] ** 2
    hxy = (fpp + fmm - fpm - fmp) / (4 * h[0] * h[1])
    return g, np.array([[hxx, hxy], [hxy, hyy]])


def laplace(theta0: np.ndarray, samples: profile.Samples, temper: float,
            fallback_cov: np.ndarray, iterations: int = 3) -> tuple[np.ndarray, np.ndarray, float]:
    """Maximum θ̂ of ℓ (C1) by Newton steps from ``theta0`` (the least-squares θ) and the
    Laplace covariance (−∇²ℓ)⁻¹ there, the derivatives by central differences with steps of
    half the current sd (the exact-likelihood kernel, so nothing else compiles);
    ``fallback_cov`` (least-squares covariance × r) when the Hessian is not negative definite.
    Returns (θ̂, cov, ℓ(θ̂)). Float64 must be enabled."""
    theta = np.asarray(theta0, dtype=float)
    cov = np.asarray(fallback_cov, dtype=float)
    ok_cov = np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(cov) > 0)
    h = 0.5 * np.sqrt(np.diag(cov)) if ok_cov else 1e-4 * (np.abs(theta) + 1.0)
    value = float("nan")
    for _ in range(iterations):
        vals = exact_log_likelihood(_stencil(theta, h), samples, temper)
        value = float(vals[0])
        if not np.all(np.isfinite(vals)):
            break
        g, hess = _derivatives(vals, h)
        if not np.all(np.linalg.eigvalsh(-hess) > 0):
            break
        cov = np.linalg.inv(-hess)
        step = cov @ g
        h = 0.5 * np.sqrt(np.diag(cov))
        if not np.all(np.isfinite(step)) or np.any(np.abs(step) > 10 * h):
            break
        theta = theta + step
        if np.all(np.abs(step) < 1e-3 * h):
            break
    value = float(exact_log_likelihood(theta[None], samples, temper)[0])
    return theta, cov, value


def to_population(theta: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ψ̂, Σ) in ψ = (ln p, ln ω_n) from (θ̂, cov) in θ = (ln p, ln ω_d) by the delta method
    (J of (C2))."""
    p, wd = np.exp(theta[0]), np.exp(theta[1])
    wn2 = p**2 + wd**2
    jac = np.array([[1.0, 0.0], [p**2 / wn2, wd**2 / wn2]])
    return np.array([theta[0], 0.5 * np.log(wn2)]), jac @ cov @ jac.T


def to_decay(psi: np.ndarray) -> np.ndarray:
    """θ = (ln p, ln ω_d) from ψ = (ln p, ln ω_n) (..., 2); ln ω_d NaN where p ≥ ω_n."""
    lnp, lnw = psi[..., 0], psi[..., 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        wd2 = np.exp(2 * lnw) - np.exp(2 * lnp)
        lnwd = np.where(wd2 > 0, 0.5 * np.log(np.where(wd2 > 0, wd2, 1.0)), np.nan)
    return np.stack([lnp, lnwd], -1)
