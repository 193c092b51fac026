r"""Posterior draws of one damping law: emcee, or the Laplace approximation for cheap runs.

Target: the tempered marginal likelihood ℓ(θ)/r of :mod:`dampfit.inference.law_fit` (A, B, drift
and σ integrated out, Whittle factor r from :mod:`dampfit.inference.noise`) times the prior
:func:`~dampfit.inference.law_fit.log_prior` — the same calibrated noise model as
:mod:`dampfit.inference.posterior`, which samples the viscous law this way.

* ``emcee``: 64 walkers over θ with the viscous sampler's proposals
  (:func:`dampfit.inference.posterior.default_moves`: kernel-density independence + differential evolution;
  on the real phone spring's 5-parameter power law 4 s and ESS ≈ 6,600 where the default
  stretch move took 12–15 s for ESS ≈ 2,500), the likelihood compiled once with JAX and
  vmapped, started in a ball from the Laplace covariance; runs in blocks until the chain exceeds 50
  integrated autocorrelation times, R-hat < 1.01 and bulk ESS ≥ ``min_ess`` (arviz), or
  ``max_steps`` (then ``converged`` is False and the reason is in ``warnings``).
* ``laplace``: the (nested) Laplace approximation of :mod:`dampfit.inference.law_fit` — viscous
  θ ~ N(θ̂, Σ); for a nonlinear law the shape s from its marginal on the evidence grid (L3)
  (inverse CDF), then (ln p₀, ln ω) ~ N(φ̂_s, Σ_s). Exact for a Gaussian posterior in
  (ln p₀, ln ω); used where thousands of replicates or a quick look are wanted.

For every θ draw the amplitudes (A, B) are drawn from their conditional Gaussian
N(β̂(θ), s²·r·M⁻¹), s² = RSS/(n − q), β̂(θ) linearised about θ̂, and give the start amplitude
a₀ = |(A, B)|/(ω²·|G|) [m].

Bounded work
------------
A damping law's emcee run gets a :class:`Budget` tied to the viscous posterior of the same
recording (:meth:`Budget.from_viscous`): at most max(:data:`STEP_FACTOR` × the viscous
sampler's steps, :data:`MIN_BUDGET_STEPS`) steps, counted in steps only, so the same seed gives
the same draws on any machine and under any load (the viscous sampler's own steps are counted
the same way). A run stopped by its budget is returned as it is, with ``converged=False``,
``stop_reason`` "step budget reached …" and a warning — never a run many times longer than the
viscous one (a Coulomb law on a recording with a rattle once took 18,913 steps, 229 s against
≈ 17 s). A wall-time limit (``Budget(max_seconds=…)``) is still honoured when a caller sets one
("wall-time budget reached …"); none is set by default, since such a stop depends on the
machine's speed and load.

Ill-conditioned laws are not sampled with emcee (:func:`conditioning`): a Laplace covariance
that is missing or not positive definite, a correlation matrix of θ with condition number above
:data:`MAX_CONDITION` (parameters the data cannot tell apart), or a shape parameter whose
optimum sits on its prior bound (the law then degenerates into a simpler one). Such a law gets
the Laplace draws, ``ill_conditioned=True`` with the reason, ``converged=False`` and a warning.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from dampfit._options import DEFAULT_MAX_STEPS, DEFAULT_MIN_ESS, DEFAULT_SEED
from dampfit.inference.posterior import ensemble, run_adaptive
from dampfit.inference.sampler_run import SamplerRun, Stop, diagnose
from dampfit.inference import law_fit
from dampfit.model import laws

N_WALKERS = 64
#: A law's step budget is at most this many times the viscous sampler's steps …
STEP_FACTOR = 3
#: … but never below this many steps (also the budget without a viscous reference).
MIN_BUDGET_STEPS = 2000
#: Condition number of θ's Laplace correlation matrix above which a law is ill-conditioned
#: (|correlation| ≈ 1 − 10⁻⁸: two parameters the data cannot tell apart). The laws fitted to
#: the simulated Coulomb, quadratic and viscous test recordings give 1–10².
MAX_CONDITION = 1e8
#: A shape parameter closer than this fraction of its prior width to a bound is "on the bound".
BOUND_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Budget:
    """Work allowed to one emcee run: ``max_steps`` [steps], ``max_seconds`` [s] (None: no
    wall-time limit) and ``basis``, a sentence saying where the numbers come from."""

    max_steps: int
    max_seconds: float | None = None
    basis: str = ""

    @classmethod
    def from_viscous(cls, steps: int | None = None, seconds: float | None = None) -> "Budget":
        """The budget of the module docstring from the viscous sampler's ``steps`` (None:
        unknown). Its wall time ``seconds`` [s] is recorded in ``basis`` only: the budget is
        counted in steps, so that it does not depend on the machine or its load."""
        n = int(steps) if steps is not None and np.isfinite(steps) and steps > 0 else 0
        max_steps = max(STEP_FACTOR * n, MIN_BUDGET_STEPS)
        basis = (f"max({STEP_FACTOR} x the viscous sampler's {n} steps, {MIN_BUDGET_STEPS})"
                 if n else f"{MIN_BUDGET_STEPS} steps (no viscous reference)")
        if seconds is not None and np.isfinite(seconds) and seconds >= 0:
            basis += (f" (the viscous sampler took {float(seconds):.3g} s; no wall-time limit, "
                      "so the same seed gives the same draws under any load)")
        return cls(max_steps=max_steps, max_seconds=None, basis=basis)

    def summary(self) -> dict:
        return {"max_steps": int(self.max_steps), "max_seconds": self.max_seconds,
                "basis": self.basis}


@dataclass(frozen=True)
class ModelPosterior:
    """Draws of θ (N, k) and a₀ [m] (N,) of one law, with how they were made: ``method``
    "emcee" with its ``run`` (:class:`~dampfit.inference.sampler_run.SamplerRun`: steps,
    R-hat, ESS, budget … read through), or "laplace" (``run`` None). ``converged`` and
    ``stop_reason`` are the draws' verdict: the run's for emcee; for Laplace draws whether the
    approximation exists, and "ill-conditioned: not sampled with emcee"
    (:attr:`Stop.NOT_SAMPLED`) for a law emcee was not run on."""

    model: str
    theta: np.ndarray
    a0: np.ndarray
    method: str  # "emcee" or "laplace"
    converged: bool
    run: SamplerRun | None = None
    warnings: tuple[str, ...] = field(default_factory=tuple)
    ill_conditioned: bool = False
    ill_conditioned_reason: str = ""
    stop_reason: str = ""  # "converged", "step budget reached …", …

    @property
    def n_steps(self) -> int:
        return 0 if self.run is None else self.run.n_steps

    @property
    def max_r_hat(self) -> float:
        return float("nan") if self.run is None else self.run.max_r_hat

    @property
    def min_ess_bulk(self) -> float:
        return float("nan") if self.run is None else self.run.min_ess_bulk

    @property
    def acceptance(self) -> float:
        return float("nan") if self.run is None else self.run.acceptance

    @property
    def wall_time_s(self) -> float:  # emcee only [s]
        return float("nan") if self.run is None else self.run.wall_time_s

    @property
    def budget(self) -> Budget | None:  # emcee only
        return None if self.run is None else self.run.budget

    def diagnostics(self) -> dict:
        """JSON-safe facts about how the draws were made: method, converged, steps, wall
        time [s], stop reason, the budget and the conditioning verdict."""
        return {"method": self.method, "converged": bool(self.converged),
                "n_steps": int(self.n_steps),
                "wall_time_s": self.wall_time_s if np.isfinite(self.wall_time_s) else None,
                "stop_reason": self.stop_reason or None,
                "budget": self.budget.summary() if self.budget is not None else None,
                "ill_conditioned": bool(self.ill_conditioned),
                "ill_conditioned_reason": self.ill_conditioned_reason or None}


def conditioning(mf: law_fit.ModelFit) -> str | None:
    """Why ``mf`` (after :func:`dampfit.inference.law_fit.laplace`) is too ill-conditioned for
    emcee, or None when it is fine (criteria in the module docstring)."""
    cov = mf.cov
    if cov is None or not np.all(np.isfinite(cov)):
        return ("Laplace covariance not available: the Hessian of the log likelihood is not "
                "positive definite at the optimum")
    cov = np.asarray(cov, dtype=float)
    ev = np.linalg.eigvalsh(0.5 * (cov + cov.T))
    if ev.min() <= 0:
        return "Laplace covariance not positive definite"
    law = laws.get(mf.model)
    if law.shape_prior is not None:
        lo, hi = law.shape_prior
        s = float(mf.theta[1])
        tol = BOUND_TOLERANCE * (hi - lo)
        if s <= lo + tol or s >= hi - tol:
            return (f"{law.shape_name} = {s:g} is on its prior bound [{lo:g}, {hi:g}]: "
                    f"the {mf.model} law degenerates there")
    d = np.sqrt(np.diag(cov))
    cond = float(np.linalg.cond(cov / np.outer(d, d)))
    if not np.isfinite(cond) or cond > MAX_CONDITION:
        return (f"condition number {cond:.3g} of the parameters' correlation matrix "
                f"(> {MAX_CONDITION:.0e}): the data cannot tell them apart")
    return None


def _amplitudes(mf: law_fit.ModelFit, thetas, data: law_fit.Data, rng) -> np.ndarray:
    """a₀ [m] for each θ draw: (A, B) ~ N(β̂(θ), s²·r·M⁻¹), β̂(θ) linearised about θ̂.

    β̂(θ) ≈ β̂(θ̂) + (∂β̂/∂θ)·(θ − θ̂) (central differences) keeps the correlation of the
    amplitude with the decay parameters at the cost of one Jacobian instead of one
    projection per draw; the linearisation error is second order in the posterior width.
    """
    thetas = np.asarray(thetas, dtype=float)
    if len(thetas) == 0:
        return np.empty(0)
    beta, rss, _, minv, _ = law_fit.profile(mf.model, mf.theta, data)
    jb = law_fit.jacobian(lambda th: law_fit.profile(mf.model, th, data)[0][:, :2], mf.theta)
    s2 = float(rss) / max(data.n - data.q, 1) / mf.temper
    chol = np.linalg.cholesky(minv * s2)
    ab = (beta[:2] + (thetas - mf.theta) @ jb.T
          + rng.standard_normal((len(thetas), 2)) @ chol.T)
    w = np.exp(thetas[:, laws.omega_index(mf.model)])
    return np.hypot(ab[:, 0], ab[:, 1]) / (w * w * mf.gain)


def sample_laplace(mf: law_fit.ModelFit, data: law_fit.Data, n_draws: int = 2000, *,
                   seed: int = 0) -> ModelPosterior:
    """Draws from the (nested) Laplace approximation on the prior support (module docstring);
    an ill-conditioned law (:func:`conditioning`) is flagged in ``ill_conditioned``."""
    rng = np.random.default_rng(seed)
    th_hat, cov = mf.theta, mf.cov
    if laws.get(mf.model).shape_prior is None:  # no shape parameter: plain Laplace
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
    why = conditioning(mf)
    return ModelPosterior(mf.model, th, a0, "laplace", True, ill_conditioned=why is not None,
                          ill_conditioned_reason=why or "")


def sample_emcee(mf: law_fit.ModelFit, data: law_fit.Data, band: tuple[float, float], *,
                 seed: int = DEFAULT_SEED, min_ess: float = DEFAULT_MIN_ESS,
                 max_steps: int = DEFAULT_MAX_STEPS,
                 progress: bool = False, budget: Budget | None = None) -> ModelPosterior:
    """emcee posterior of one law with the tempered likelihood (module docstring).

    ``budget`` (default :meth:`Budget.from_viscous` with no reference: 2000 steps) bounds the
    run together with ``max_steps``; pass ``Budget.from_viscous(steps, seconds)`` with the
    viscous sampler's steps and wall time [s]. An ill-conditioned law
    (:func:`conditioning`) is not sampled: it gets the Laplace draws, flagged.
    """
    budget = budget if budget is not None else Budget.from_viscous()
    why = conditioning(mf)
    if why is not None:
        lap = sample_laplace(mf, data, seed=seed)
        note = ("the Laplace approximation is reported instead (approximate intervals)"
                if len(lap.a0) else "no draws")
        return replace(lap, converged=False, ill_conditioned=True, ill_conditioned_reason=why,
                       stop_reason=Stop.NOT_SAMPLED.value, warnings=lap.warnings + (
                           f"{mf.model} damping law is ill-conditioned ({why}); not sampled "
                           f"with emcee, {note}",))
    rng = np.random.default_rng(seed)
    model, temper, k = mf.model, mf.temper, mf.k

    def log_prob(thetas):  # the jitted profile of dampfit.model.profile, ~10⁴ evaluations
        lp = law_fit.log_prior(model, thetas, band)
        return np.where(np.isfinite(lp), temper * law_fit.loglik_batch(model, thetas, data) + lp,
                        -np.inf)

    # start: a ball drawn from the Laplace approximation (inside the prior support)
    start = sample_laplace(mf, data, n_draws=N_WALKERS, seed=seed).theta
    if len(start) < N_WALKERS:
        cov = mf.cov if mf.cov is not None and np.all(np.isfinite(mf.cov)) else np.diag(
            np.full(k, 1e-6))
        start = rng.multivariate_normal(mf.theta, cov, size=N_WALKERS)
    sampler = ensemble(k, log_prob, rng, N_WALKERS)
    from dampfit._progress import progress_bar

    with progress_bar(int(min(max_steps, budget.max_steps)), f"damping laws: {model} posterior",
                      enabled=progress) as bar:
        run = run_adaptive(sampler, start, min_ess=min_ess, max_steps=max_steps, bar=bar,
                           budget=budget)
    warns = () if run.converged else (run.not_converged(f"{model} posterior"),)
    rhat, ess = diagnose(run.draws)
    th = run.draws.reshape(-1, k)
    a0 = _amplitudes(mf, th, data, rng)
    run = replace(run, max_r_hat=rhat, min_ess_bulk=ess, warnings=warns)
    return ModelPosterior(model, th, a0, "emcee", run.converged, run=run, warnings=warns,
                          stop_reason=run.stop_reason)
