r"""Stage 3 of a campaign: the hyper-posterior of φ (eqs. C3–C5, in the sampler coordinates
of C8) sampled with emcee (differential-evolution moves, :func:`ensemble`, and the stopping
rule of :func:`dampfit.inference.posterior.run_adaptive`), once for each frequency model (M₁:
τ_ω free; M₀: τ_ω = 0), their posterior probabilities by the Savage–Dickey ratio (C7), each
draw's per-test values drawn from their conditional and importance-resampled to the exact
per-test likelihoods (C6), and the model-averaged draws as arviz InferenceData
(:func:`sample`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dampfit import physics
from dampfit._progress import progress_bar
from dampfit.errors import DampfitError
from dampfit.inference.sampler_run import ReadsRun, SamplerRun, Stop, diagnostics, to_idata

#: Least importance ESS of (C6) as a fraction of the draws [1] for a converged result.
MIN_IMPORTANCE_FRACTION = 0.1
#: emcee walkers over the 4–5 hyper-parameters.
N_WALKERS = 64


@dataclass(frozen=True)
class Problem:
    """What a campaign's hyper-posterior is of: the fitted ``tests``
    (:class:`dampfit.campaign.tests.TestFit`), their ``data`` (:mod:`dampfit.campaign.model`),
    the added masses ``dm`` [kg] (None: a hierarchical campaign) and the given ``mass``,
    ``mass_sd`` [kg]."""

    tests: Any
    data: Any
    dm: Any
    mass: float | None
    mass_sd: float

    @property
    def added(self) -> bool:
        """An added-mass campaign (m₀ estimated)."""
        return self.dm is not None


#: The quantities whose worst R-hat and bulk ESS summarise the campaign's convergence.
REPORTED = ("c", "k", "zeta", "f_n", "p", "m0", "tau_p", "tau_omega")


@dataclass(frozen=True)
class CampaignSampling(ReadsRun):
    """The joint posterior and the sampler's facts: ``run`` the
    :class:`~dampfit.inference.sampler_run.SamplerRun` of the more probable frequency model,
    with the model-averaged draws as its ``idata``, the steps of both models and the
    convergence of both (read through: ``converged``, ``n_steps``, ``diagnostics`` …)."""

    run: SamplerRun
    importance_ess_fraction: float
    seconds: float = float("nan")
    #: posterior probability [1] that the tests share one frequency law (τ_ω = 0), eq. (C7)
    p_shared_frequency: float = float("nan")
    #: ln B₀₁ [1] of (C7) with the exact-likelihood correction
    log_bayes_factor_shared: float = float("nan")


def _start(data, added: bool, rng, n_walkers: int) -> np.ndarray:
    """Walkers about the moment estimates: locations at the prior centres (± their spread
    over the tests), τ from the tests' scatter (a small positive value at least)."""
    psi = np.asarray(data.psi_hat)
    centre = np.asarray(data.centre)
    tau0 = np.maximum(np.std(psi, axis=0, ddof=1), [1e-3, 1e-4])
    loc_sd = np.maximum(tau0 / np.sqrt(psi.shape[0]), 1e-4)
    if added:
        loc_sd = np.array([loc_sd[0], loc_sd[1], 0.05])
    loc = centre[None] + rng.standard_normal((n_walkers, centre.size)) * loc_sd[None]
    ln_tau = np.log(tau0)[None] + 0.3 * rng.standard_normal((n_walkers, 2))
    return np.concatenate([loc, ln_tau], axis=1)


def _to_hyper(x: np.ndarray, data, shared: bool) -> np.ndarray:
    """φ rows (N, k) from sampler coordinates x (N, k or k − 1 under M₀ ``shared``) of
    (C8); ln τ_ω = −inf under M₀."""
    import jax
    import jax.numpy as jnp

    from dampfit.campaign import model

    x = np.asarray(x, dtype=float)
    if shared:
        x = np.concatenate([x, np.full((x.shape[0], 1), -np.inf)], axis=1)
    with jax.enable_x64(True):
        phi = jax.vmap(lambda row: model.to_hyper(row, data)[0])(jnp.asarray(x))
    out = np.array(phi)
    if shared:
        out[:, -1] = -np.inf
    return out


def _to_sampler(phi: np.ndarray, data, shared: bool) -> np.ndarray:
    """Sampler coordinates (C8) of φ rows (N, k); under M₀ (``shared``) without ln τ_ω,
    whatever φ's last entry (M₁'s walkers seed M₀)."""
    from dampfit.campaign import model

    phi = np.array(phi, dtype=float)
    if shared:
        phi[:, -1] = -np.inf
    x = model.from_hyper(phi, data)
    return x[:, :-1] if shared else x


def _laplace_start(target, data, candidates: np.ndarray, rng) -> np.ndarray:
    """Walkers (len(candidates), k) drawn from the Laplace approximation N(φ*, −H⁻¹) of the
    log posterior ``target`` (a batched model function of :mod:`dampfit.campaign.model`),
    φ* its mode found by a trust-region Newton search (exact JAX gradient and Hessian) from
    the best of ``candidates`` (walkers, k). If the search fails or the Hessian at its end is
    not negative definite, ``candidates`` themselves are returned."""
    import jax
    import jax.numpy as jnp
    from scipy import optimize

    lp = np.asarray(target(jnp.asarray(candidates), data))
    if not np.any(np.isfinite(lp)):
        return candidates
    x0 = candidates[int(np.nanargmax(np.where(np.isfinite(lp), lp, -np.inf)))]

    def neg(x):
        return -target(x[None], data)[0]

    value_grad = jax.jit(jax.value_and_grad(neg))
    hess = jax.jit(jax.hessian(neg))

    def fun(x):
        v, g = value_grad(jnp.asarray(x))
        return float(v), np.asarray(g, dtype=float)

    try:
        res = optimize.minimize(fun, x0, jac=True, hess=lambda x: np.asarray(hess(jnp.asarray(x))),
                                method="trust-exact", options={"maxiter": 200})
        h = np.asarray(hess(jnp.asarray(res.x)), dtype=float)
        chol = np.linalg.cholesky(np.linalg.inv(0.5 * (h + h.T)))
    except (ValueError, np.linalg.LinAlgError):
        return candidates
    if not (np.all(np.isfinite(res.x)) and np.isfinite(res.fun) and res.fun <= -np.max(lp)
            and np.all(np.isfinite(chol))):
        return candidates
    return res.x[None] + rng.standard_normal(candidates.shape) @ chol.T


@dataclass(frozen=True)
class _ModelRun:
    """One model's sampled, importance-resampled draws: φ (N, k) with ln τ_ω = −inf under M₀,
    ψ (N, n, 2), ln of the mean importance weight (C6), the importance ESS fraction and the
    emcee run."""

    phi: np.ndarray
    psi: np.ndarray
    log_mean_weight: float
    ess_fraction: float
    run: SamplerRun
    m1_draws: np.ndarray | None = None
    last: np.ndarray | None = None


def _run_model(problem: Problem, shared: bool, rng, progress, max_steps, min_ess,
               start=None) -> _ModelRun:
    """Sample one model's hyper-posterior (M₀ ``shared``: τ_ω = 0; else M₁) from ``start``
    (walkers, k) or :func:`_start`, draw each test's ψ given φ and resample by the
    exact-likelihood weights (C6)."""
    import jax.numpy as jnp

    from dampfit.campaign import model
    from dampfit.inference import posterior

    data = problem.data
    ndim = len(model.hyper_names(problem.added)) - (1 if shared else 0)
    target = model.sampler_log_posterior(shared)  # non-centred levels (C8)

    def log_prob(xs: np.ndarray) -> np.ndarray:  # inside jax.enable_x64(True)
        return np.asarray(target(jnp.asarray(xs, dtype=jnp.float64), data))

    sampler = ensemble(ndim, log_prob, rng)
    if start is None:
        start = _to_sampler(_start(data, problem.added, rng, sampler.nwalkers), data, shared)
    start = start[:, :ndim]
    bar = progress_bar(max_steps, "campaign posterior (emcee steps)", enabled=progress)
    try:
        run = posterior.run_adaptive(sampler, start, min_ess=min_ess, max_steps=max_steps,
                                     bar=bar, x64=True)
    finally:
        bar.close()
    n_draw, n_walk, _ = run.draws.shape  # coordinates (C8)
    phi = _to_hyper(run.draws.reshape(-1, ndim), data, shared)  # ln τ_ω = −inf under M₀
    psi = model.conditional(phi, data, rng)  # (N, n, 2)
    logw = _importance_log_weights(problem.tests, psi, data)
    finite = logw[np.isfinite(logw)]
    log_mean = (float(finite.max() + np.log(np.sum(np.exp(finite - finite.max())) / logw.size))
                if finite.size else -np.inf)
    ess_frac, idx = _resample(logw, n_draw, n_walk, rng)
    return _ModelRun(phi=phi[idx], psi=psi[idx], log_mean_weight=log_mean,
                     ess_fraction=ess_frac, run=run, m1_draws=None if shared else phi,
                     last=_to_hyper(sampler.get_last_sample().coords, data, shared))


#: A model whose posterior probability is below this [1] need not have converged (its draws
#: are at most this fraction of the result).
NEGLIGIBLE_MODEL = 0.01


def sample(problem: Problem, seed: int, progress: bool, max_steps: int,
           min_ess: float) -> CampaignSampling:
    """Both frequency models (M₁: τ_ω free; M₀: τ_ω = 0, :mod:`dampfit.campaign.model`),
    their posterior probabilities by (C7) with the exact-likelihood correction, and the
    model-averaged draws: each (draw, walker) slot of the more probable model's layout holds
    a draw of the other model with that model's probability."""
    import jax

    from dampfit.campaign import model

    rng = np.random.default_rng(seed)
    data = problem.data
    with jax.enable_x64(True):
        m1 = _run_model(problem, False, rng, progress, max_steps, min_ess)
        # M₀ starts from its own Laplace approximation, found from M₁'s last walkers (ln τ_ω
        # dropped): M₀ can be far narrower than M₁ — with an exact bare mass, the bare test
        # pins ω₀ to its own 1e-5 — and a walker left 100 posterior sd out stays there under
        # the DE moves and spoils the importance weights (measured: importance ESS 0.006 %)
        m0 = _run_model(problem, True, rng, progress, max_steps, min_ess,
                        start=_laplace_start(model.sampler_log_posterior(True), data,
                                             _to_sampler(m1.last, data, True), rng))
        log_bf = model.log_bayes_factor_shared(m1.m1_draws, data, rng)
    log_bf += m0.log_mean_weight - m1.log_mean_weight
    prior_odds = np.log(model.P_SHARED_FREQUENCY / (1 - model.P_SHARED_FREQUENCY))
    p_shared = (float(1.0 / (1.0 + np.exp(-(log_bf + prior_odds))))
                if np.isfinite(log_bf) else 0.0)
    weighed = [(label, r) for label, r, weight in (("scatter", m1, 1 - p_shared),
                                                   ("shared-frequency", m0, p_shared))
               if weight >= NEGLIGIBLE_MODEL]
    stop, warns = _convergence(weighed)
    base, other, p_other = (m0, m1, 1 - p_shared) if p_shared >= 0.5 else (m1, m0, p_shared)
    phi, psi = base.phi.copy(), base.psi.copy()
    swap = rng.random(phi.shape[0]) < p_other
    pick = rng.integers(other.phi.shape[0], size=int(swap.sum()))
    phi[swap], psi[swap] = other.phi[pick], other.psi[pick]
    idata = _to_idata(phi, psi, problem, base.run.n_walkers, rng)
    idata.posterior.attrs["p_shared_frequency"] = p_shared
    run = base.run.finish(idata, warns, names=REPORTED,
                          diagnostics=diagnostics(idata, scalars_only=True),
                          n_steps=m1.run.n_steps + m0.run.n_steps, stop=stop,
                          stop_reason="; ".join(warns) or "converged", unmet="")
    return CampaignSampling(
        run=run, importance_ess_fraction=float(min(r.ess_fraction for _, r in weighed)),
        p_shared_frequency=p_shared, log_bayes_factor_shared=float(log_bf))


def _convergence(weighed) -> tuple[Stop, list[str]]:
    """(:class:`Stop` of the whole, warnings) of the (label, :class:`_ModelRun`) of every
    model that is not negligible: each must have converged and kept enough importance ESS."""
    stop, warns = Stop.CONVERGED, []
    for label, r in weighed:
        if not r.run.converged:
            stop = r.run.stop if stop is Stop.CONVERGED else stop
            warns.append(r.run.not_converged(f"campaign posterior ({label} model)"))
        if r.ess_fraction < MIN_IMPORTANCE_FRACTION:
            stop = Stop.WEIGHTS if stop is Stop.CONVERGED else stop
            warns.append(f"the exact per-test likelihoods differ from their Laplace forms "
                         f"({label} model): importance ESS only {100 * r.ess_fraction:.1f} % "
                         "of the draws")
    return stop, warns


def ensemble(ndim: int, log_prob, rng):
    """emcee's vectorised ensemble over φ with differential-evolution moves (80 % DE, 20 % DE
    snooker), seeded from ``rng``. Not :func:`dampfit.inference.posterior.default_moves`: its
    KDE proposal costs ≈ 50 ms a step in 4–5 dimensions (measured: 2000 steps 114 s against
    4.5 s for DE at integrated autocorrelation ≈ 20–40 steps either way on a 5-test
    campaign). The log-probability is called directly (no emcee wrapper), as in
    :func:`dampfit.inference.posterior.ensemble`."""
    import emcee

    from dampfit.inference import posterior

    sampler = emcee.EnsembleSampler(N_WALKERS, ndim, log_prob, vectorize=True,
                                    moves=[(emcee.moves.DEMove(), 0.8),
                                           (emcee.moves.DESnookerMove(), 0.2)])
    sampler.log_prob_fn = log_prob
    posterior.seed_sampler(sampler, rng)
    return sampler


def _importance_log_weights(tests, psi: np.ndarray, data) -> np.ndarray:
    """log w of (C6) per joint draw (N,)."""
    import jax

    from dampfit.campaign import model

    approx = model.gaussian_log_likelihood(psi, data)  # (N, n), 0 at ψ̂
    theta = model.to_decay(psi)
    logw = np.zeros(psi.shape[0])
    with jax.enable_x64(True):
        for i, t in enumerate(tests):
            th = theta[:, i]
            ok = np.all(np.isfinite(th), axis=1)
            ll = np.full(th.shape[0], -np.inf)
            if ok.any():
                ll[ok] = model.exact_log_likelihood(th[ok], t.samples(), t.temper)
            logw += ll - t.ll_max - approx[:, i]
    return logw


def _resample(logw: np.ndarray, n_draw: int, n_walk: int, rng) -> tuple[float, np.ndarray]:
    """Importance ESS fraction [1] and indices (into the flat (draw, walker) order) of each
    walker's draws resampled systematically by its weights."""
    finite = np.isfinite(logw)
    if not finite.any():
        raise DampfitError("no posterior draw has a finite likelihood in every test")
    w = np.where(finite, np.exp(logw - logw[finite].max()), 0.0)
    frac = float(w.sum() ** 2 / np.sum(w**2) / w.size)
    w2 = w.reshape(n_draw, n_walk)
    idx = np.empty((n_draw, n_walk), dtype=int)
    for j in range(n_walk):
        wj = w2[:, j]
        if wj.sum() <= 0:  # this walker's draws all impossible: borrow the pooled weights
            wj = w2.sum(axis=1)
        cdf = np.cumsum(wj / wj.sum())
        u = (rng.random() + np.arange(n_draw)) / n_draw
        rows = np.minimum(np.searchsorted(cdf, u), n_draw - 1)
        idx[:, j] = rows * n_walk + j
    return frac, idx.ravel()


def _to_idata(phi, psi, problem: Problem, n_walk: int, rng):
    """arviz InferenceData of the hyper-parameters, population, predictive and per-test
    quantities (walkers as chains)."""
    from dampfit.campaign import model
    from dampfit.inference import posterior

    added = problem.added
    n_total, n_tests = psi.shape[0], psi.shape[1]
    names = model.hyper_names(added)
    post: dict[str, np.ndarray] = {name: phi[:, j] for j, name in enumerate(names)}
    tau_p, tau_w = np.exp(phi[:, -2]), np.exp(phi[:, -1])
    post["tau_p"], post["tau_omega"] = tau_p, tau_w
    if added:
        p, wn, m0 = np.exp(phi[:, 0]), np.exp(phi[:, 1]), np.exp(phi[:, 2])
        m = m0
        post["m0"] = m0
        test_mass = m0[:, None] + np.asarray(problem.dm)[None, :]
    else:
        m = posterior.mass_draws(problem.mass, problem.mass_sd, n_total, rng)
        p, wn = np.exp(phi[:, 0]), np.exp(phi[:, 1])
        if m is not None:
            post["mass"] = m
        test_mass = None if m is None else np.broadcast_to(m[:, None], (n_total, n_tests))
    q = physics.quantities(p, mass=m, omega_n=wn)
    for name in ("c", "k", "zeta", "f_n", "p", "c_crit"):
        if name in q:
            post[name] = q[name]
    z = rng.standard_normal((n_total, 2))
    p_new, wn_new = p * np.exp(tau_p * z[:, 0]), wn * np.exp(tau_w * z[:, 1])
    qn = physics.quantities(p_new, mass=m, omega_n=wn_new)
    for name in ("c", "k", "zeta", "f_n", "p"):
        if name in qn:
            post[f"predictive_{name}"] = qn[name]
    p_i, wn_i = np.exp(psi[..., 0]), np.exp(psi[..., 1])
    qi = physics.quantities(p_i, mass=test_mass, omega_n=wn_i)
    for name in ("c", "k", "zeta", "f_n", "p"):
        if name in qi:
            post[f"{name}_test"] = qi[name]
    import emcee

    return to_idata(post, n_walk, coords={"test": np.arange(1, n_tests + 1)},
                    dims={k_: ["test"] for k_ in post if k_.endswith("_test")},
                    attrs={"sampler": f"emcee {emcee.__version__}", "n_walkers": n_walk,
                           "model": "added-mass" if added else "hierarchical",
                           "per_test_likelihood": "exact tempered profile (importance-resampled)"})
