r"""Posterior of c, k, u₀ (and ζ, f_n) with emcee, diagnosed and stored with arviz.

Model and priors
----------------
* Likelihood: the decay model (:mod:`dampfit.model.viscous`) with Gaussian noise of unknown σ; the
  linear coefficients (acceleration quadratures A, B and the drift terms) have flat priors
  and σ a Jeffreys prior 1/σ, all marginalised analytically
  (:func:`dampfit.model.profile.log_marginal`), tempered by 1/r (:mod:`dampfit.inference.noise`),
  where r is the residual spectrum at f₀ corrected for what the fit itself removes there,
  floored at the level white noise carrying the residual's power above f₀/2 would have: misfit
  at f₀ or at its harmonics widens the intervals, slow drift below f₀/2 does not.
* Decay rate p [1/s]: log-uniform on [10⁻⁶·ω_d, ω_d] (ζ up to ≈ 0.7).
* Damped frequency ω_d [rad/s]: log-uniform over the analysis pass band.
* Mass m [kg]: normal(m, sd) truncated to m > 0, independent of the data — the recording
  identifies only p and ω_n, so c = 2·m·p and k = m·ω_n² take the mass uncertainty by
  drawing m for every posterior sample (exact, since m does not enter the likelihood).
* u₀ [m]: for every posterior sample of θ, (A, B) are drawn from their conditional Gaussian
  N(β̂(θ), s²·r·(XᵀX)⁻¹) and u₀ = √(A² + B²)/(ω_n²·|G|) (eq. M2, G the filter gain).

No measured decay
-----------------
The log-uniform prior on p is right for a decay the data resolve (the posterior then forgets
the prior), but not for one they cannot tell from 0 — a steady sine, a forced or
self-sustained vibration. The likelihood is then flat from p = 0 up to some p_max, and a
log-uniform prior puts as much mass on every decade below p_max as on the last one: the
"interval" of ζ stops at a lower end set only by the prior's floor 10⁻⁶·ω_d (and its upper
end moves with that floor). When the decay test of :func:`dampfit.inference.law_fit.decay_test`
(signed-root likelihood ratio against p = 0, tempered like the posterior) cannot tell the
decay from 0, :func:`dampfit.analyze` reports p, ζ, c and δ as one-sided: q05 = 0, and the
other statistics under a prior *uniform* in p on [0, ω_d] — importance weights ∝ p on the
same draws (the ratio of the two prior densities), which need no second run because the
log-uniform draws cover [floor, p_max]. The 90 % interval [0, q95] is then a 95 % upper bound
that does not depend on the floor; Q = 1/(2ζ) has no upper bound (q95, mean and sd null).
A decay the data resolve (z > 1.645) keeps the log-uniform posterior unchanged.

Sampling
--------
emcee's ensemble (64 walkers; kernel-density independence proposals mixed with
differential-evolution moves, see :func:`default_moves`) over θ = (ln p, ln ω_d), vectorised: one
jitted, vmapped JAX call evaluates a half-ensemble. Walkers start in a small ball drawn from
the least-squares covariance. The chain runs in blocks (sized from the running τ estimate,
see :func:`run_adaptive`) until (a) its length exceeds 50 integrated autocorrelation times,
(b) arviz's rank-normalised R-hat < 1.01 and (c) the bulk effective sample size of every
reported quantity exceeds ``min_ess`` — or until ``max_steps``; then ``converged`` is False
and the reason is in ``warnings``.
"""

from __future__ import annotations

import time
from contextlib import nullcontext as _nullcontext
from dataclasses import dataclass
from typing import TYPE_CHECKING

import emcee
import jax
import jax.numpy as jnp
import numpy as np
from threadpoolctl import threadpool_limits

from dampfit import physics
from dampfit._options import DEFAULT_MAX_STEPS, DEFAULT_MIN_ESS, DEFAULT_SEED
from dampfit.model import profile
from dampfit.model.viscous import M1
from dampfit.inference.executables import kernel
from dampfit.inference.least_squares import LeastSquaresResult
from dampfit.inference.sampler_run import SamplerRun, Stop, diagnose, diagnostics, to_idata
from dampfit.signal.prepare import FitData

if TYPE_CHECKING:  # arviz imports matplotlib.pyplot: keep it out of the numeric import path
    import arviz as az


#: Ensemble size: with the KDE proposal (:func:`default_moves`) a larger ensemble describes the target
#: better (τ ≈ 2 steps at 64 walkers, ≈ 2.6 at 32) and amortises emcee's per-step Python cost;
#: 64 walkers reached the stopping rule in the least wall time on the seed paper's recording.
N_WALKERS = 64
PARAMETERS = ("c", "k", "u0", "zeta", "f_n")


def default_moves():
    """emcee proposal mixture for the 2-D θ = (ln p, ln ω_d) (and, in
    :mod:`dampfit.inference.law_sampler`, the 3–6 parameters of a nonlinear damping law).

    80 % :class:`emcee.moves.KDEMove` — an independence proposal from a Gaussian kernel density
    estimate of the complementary half-ensemble (Scott's bandwidth). The posterior of θ is
    nearly Gaussian once the amplitudes are marginalised, so this proposal is close to the
    target itself: integrated autocorrelation τ ≈ 2–3 steps, against ≈ 9 for differential
    evolution alone and ≈ 28 for the default stretch move (measured on the seed paper's 60 s
    recording). It is a valid Metropolis–Hastings move for any target (the proposal density
    enters the acceptance ratio), but its efficiency relies on the ensemble describing the
    target, so 20 % differential-evolution moves (DE 15 %, DE snooker 5 %) keep local
    exploration for curved or skewed posteriors (low SNR, ζ near the prior bounds).
    """
    return [(emcee.moves.KDEMove(), 0.8), (emcee.moves.DEMove(), 0.15),
            (emcee.moves.DESnookerMove(), 0.05)]


#: The viscous sampler's result: its :class:`~dampfit.inference.sampler_run.SamplerRun`, whose
#: ``idata`` holds the draws of c, k, u₀, ζ, f_n … (the one sampler result type).
PosteriorResult = SamplerRun


@dataclass(frozen=True)
class Target:
    """What the viscous posterior is of: the fit data, the analysis pass ``band`` [Hz] (the
    prior support of ω_d) and ``temper`` = 1/r (r from :func:`dampfit.inference.noise.estimate`)."""

    fit_data: FitData
    band: tuple[float, float]
    temper: float


# Module-level kernel on padded inputs (FitData.padded): compiled once per shape bucket, reused
# across analyses (a study of thousands of recordings compiles a handful of times); under the CLI
# its executables are kept on disk (dampfit.inference.executables: no tracing in a new process;
# each call then costs ≈ 50 µs more than through jax.jit, ≈ 0.1 s over a 60 s recording's
# posterior, against ≈ 0.3 s of tracing and lowering saved).
@kernel
def _batched_log_prob(thetas, samples, temper, bounds):
    """(log posterior, conditional moments of (A, B)) for a batch of θ; see
    :func:`dampfit.model.profile.marginal_and_amplitudes` (the viscous (M1) columns) and
    :class:`~dampfit.model.profile.Samples` for ``samples``."""
    def one(theta):
        # the support of the viscous law's prior (its density is constant there: left out)
        inside = jnp.isfinite(M1.log_prior_ln(theta, bounds[0], bounds[1], xp=jnp))
        ll, ab, cov = profile.marginal_and_amplitudes(M1, theta, samples, temper)
        moments = jnp.stack([ab[0], ab[1], cov[0, 0], cov[0, 1], cov[1, 1]])
        return jnp.where(inside & jnp.isfinite(ll), ll, -jnp.inf), moments

    return jax.vmap(one)(thetas)


def _padded_args(fd: FitData):
    pad = fd.padded
    # device_put, not jnp.asarray / jnp.float64: those each compile an eager op in a new process
    arrays = tuple(np.asarray(a) for a in (pad.tau, pad.y, pad.drift, pad.mask))
    return profile.Samples(*jax.device_put(arrays + (np.float64(pad.n), np.float64(pad.q - 2))))


#: Per-draw emcee blob: conditional mean and covariance of the quadratures (A, B) given θ.
BLOB_FIELDS = ("a_cos", "a_sin", "cov_aa", "cov_ab", "cov_bb")


def _make_log_prob(fd: FitData, band: tuple[float, float], temper: float):
    """Vectorised log posterior of θ = (ln p, ln ω_d) for emcee (NumPy in, NumPy out).

    Returns rows ``[ln π(θ), Â, B̂, Σ_AA, Σ_AB, Σ_BB]``: emcee keeps the columns after the first
    as the blob of each accepted draw, so the amplitude posterior costs no second pass.
    """
    with jax.enable_x64(True):
        args = _padded_args(fd)
        bounds, temper_ = jax.device_put((np.log(2 * np.pi * np.asarray(band, np.float64)),
                                          np.float64(temper)))

    def log_prob(thetas: np.ndarray) -> np.ndarray:  # called inside jax.enable_x64(True)
        lp, moments = _batched_log_prob(np.asarray(thetas, dtype=np.float64), args,
                                        temper_, bounds)
        return np.column_stack([np.asarray(lp), np.asarray(moments)])

    return log_prob


def conditional_amplitudes(moments: np.ndarray, rng) -> np.ndarray:
    """One draw of (A, B) [m/s²] per row of ``moments`` = [Â, B̂, Σ_AA, Σ_AB, Σ_BB] (the
    blobs of :func:`_make_log_prob`), via the closed-form 2×2 Cholesky factor."""
    m = np.asarray(moments, dtype=float)
    z = rng.standard_normal((len(m), 2))
    l11 = np.sqrt(m[:, 2])
    l21 = m[:, 3] / l11
    l22 = np.sqrt(np.maximum(m[:, 4] - l21**2, 0.0))
    return np.column_stack([m[:, 0] + l11 * z[:, 0], m[:, 1] + l21 * z[:, 0] + l22 * z[:, 1]])


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


def sample(target: Target, ls: LeastSquaresResult, *, mass: float | None = None,
           mass_sd: float = 0.0, seed: int = DEFAULT_SEED, min_ess: float = DEFAULT_MIN_ESS,
           max_steps: int = DEFAULT_MAX_STEPS, progress: bool = False) -> SamplerRun:
    """Sample the posterior of ``target`` from the least squares ``ls``; see the module
    docstring for the model, priors and stopping rule. ``mass``, ``mass_sd`` [kg]; ``seed``
    makes the run reproducible. The result's ``idata`` holds the draws, its ``warnings`` say
    why a run did not converge."""
    rng = np.random.default_rng(seed)
    log_prob = _make_log_prob(target.fit_data, target.band, target.temper)
    cov = np.asarray(ls.cov[:2, :2]) / target.temper
    if not np.all(np.isfinite(cov)) or np.linalg.eigvalsh(cov).min() <= 0:
        cov = np.diag((1e-3 * np.abs(ls.theta) + 1e-6) ** 2)
    # a noise-free record (an FEM output, a synthetic check) has a covariance at rounding level:
    # walkers started that close coincide, and emcee's moves divide by their zero spread
    cov = cov + np.diag(START_SPREAD_FLOOR**2 * np.ones(2))
    start = rng.multivariate_normal(ls.theta, 0.25 * cov, size=N_WALKERS)
    sampler = ensemble(2, log_prob, rng)
    bar = _progress(max_steps, progress)
    try:
        run = run_adaptive(sampler, start, min_ess=min_ess, max_steps=max_steps, bar=bar,
                           x64=True)
    finally:
        bar.close()
    warns = [] if run.converged else [run.not_converged("posterior")]
    idata = _to_idata(run, ls, target.temper, (mass, mass_sd), rng)
    return run.finish(idata, warns, names=PARAMETERS)


#: R-hat and bulk ESS of every quantity of a posterior (the one function,
#: :func:`dampfit.inference.sampler_run.diagnostics`).
quantity_diagnostics = diagnostics


#: Least spread [1] of the walkers' start ball in θ = (ln p, ln ω_d): 1e-9 relative, far
#: below any posterior width a recording with noise can give, far above float rounding.
START_SPREAD_FLOOR = 1e-9


def ensemble(ndim: int, log_prob, rng: np.random.Generator, n_walkers: int = N_WALKERS):
    """emcee's vectorised ensemble sampler over ``ndim`` parameters with dampfit's moves,
    seeded from ``rng`` (:func:`seed_sampler`).

    The log-probability is called directly, not through emcee's wrapper: that wrapper prints a
    traceback for any exception raised inside the likelihood — including the
    ``KeyboardInterrupt`` of Ctrl-C or SIGTERM — before re-raising it, which broke the CLI's
    one-line promise.
    """
    sampler = emcee.EnsembleSampler(n_walkers, ndim, log_prob, vectorize=True,
                                    moves=default_moves())
    sampler.log_prob_fn = log_prob
    seed_sampler(sampler, rng)
    return sampler


def seed_sampler(sampler: "emcee.EnsembleSampler", rng: np.random.Generator) -> None:
    """Give ``sampler`` its own random stream drawn from ``rng``.

    emcee otherwise copies NumPy's *global* random state, which a fresh process seeds from
    the operating system — the same ``--seed`` then gave different draws in every CLI run.
    (A start array passed to ``run_mcmc`` carries no random state, so this one is kept.)
    """
    sampler.random_state = np.random.RandomState(rng.integers(2**32)).get_state()


def run_adaptive(sampler: "emcee.EnsembleSampler", start: np.ndarray, *, min_ess: float,
                 max_steps: int, block: int = 500, bar=None, x64: bool = False,
                 budget=None) -> SamplerRun:
    """Run ``sampler`` from ``start`` in blocks until the stopping rule of the module
    docstring holds (≥ 50 τ_int, R-hat < 1.01, bulk ESS ≥ ``min_ess``) or ``max_steps``, and
    return the :class:`~dampfit.inference.sampler_run.SamplerRun` of the draws kept.

    The first block has :data:`FIRST_BLOCK` steps; each later one is sized from the current τ
    estimate to what the rule still needs — max(50 τ, 3 τ burn-in + 1.2·min_ess·τ/walkers)
    steps in all — clipped to [:data:`FIRST_BLOCK`/2, ``block``], so a fast-mixing chain stops
    after a few hundred steps instead of a fixed multiple of ``block``. ``bar`` (tqdm) is
    advanced per block; ``x64`` runs each block inside ``jax.enable_x64(True)`` (a JAX
    log-probability called once per half-ensemble). ``budget``
    (:class:`~dampfit.inference.law_sampler.Budget`; None: none) lowers the step limit to its
    ``max_steps`` and, with ``max_seconds`` [s], stops the run between two blocks once that
    wall time has passed; the blocks run before are those of a run without it (same draws for
    a seed). Kept: the draws after a burn-in of 3 τ (at most all but the last 8 steps, so a
    run stopped early keeps its last draws) thinned by τ/4 (:func:`burn_thin`).

    BLAS is held to one thread meanwhile (threadpoolctl): the moves make thousands of tiny
    LAPACK calls (the KDE proposal's triangular solves), and with several processes sharing
    the cores — a study's Dask workers — OpenBLAS's spinning worker threads made each of them
    cost milliseconds instead of microseconds (measured: 7.4 s of a 10 s posterior).
    """
    t_start = time.monotonic()
    limit = int(max_steps if budget is None else min(max_steps, budget.max_steps))
    deadline = (None if budget is None or budget.max_seconds is None
                else t_start + budget.max_seconds)
    with threadpool_limits(limits=1, user_api="blas"):
        steps, tau, unmet, stop = _run_blocks(sampler, start, (min_ess, limit, block), bar,
                                              x64, deadline)
    wall = time.monotonic() - t_start
    if stop is None:
        stop = (Stop.STEP_BUDGET if budget is not None and limit < max_steps and steps >= limit
                else Stop.MAX_STEPS)
    burn, thin = burn_thin(tau)
    burn = min(burn, max(steps - 8, 0))
    return SamplerRun(
        draws=sampler.get_chain(discard=burn, thin=thin),
        log_prob=sampler.get_log_prob(discard=burn, thin=thin),
        blobs=sampler.get_blobs(discard=burn, thin=thin), n_steps=steps,
        n_walkers=sampler.nwalkers, burn_in=burn, thin=thin, autocorr_time=np.asarray(tau),
        acceptance=float(np.mean(sampler.acceptance_fraction)), stop=stop,
        stop_reason=_stop_sentence(stop, steps, wall, budget), unmet=unmet, wall_time_s=wall,
        budget=budget)


#: Steps of the first block of :func:`run_adaptive` (the first estimate of τ).
FIRST_BLOCK = 100


def _stop_sentence(stop: Stop, steps: int, wall: float, budget) -> str:
    """The ``stop_reason`` of a :class:`~dampfit.inference.sampler_run.SamplerRun`."""
    if stop is Stop.CONVERGED:
        return "converged"
    if stop is Stop.WALL_TIME:
        return (f"wall-time budget reached ({wall:.3g} s > {budget.max_seconds:.3g} s = "
                f"{budget.basis}) after {steps} steps; max_steps {steps} reproduces "
                "this stop on any machine")
    if stop is Stop.STEP_BUDGET:
        return f"step budget reached ({steps} steps = {budget.basis})"
    return f"max_steps reached ({steps} steps)"


def _run_blocks(sampler, start, rule, bar, x64, deadline):
    """(steps, τ, the criterion unmet at the last check, :class:`Stop` or None for a run that
    reached its step limit) of the blocks of :func:`run_adaptive`; ``rule`` = (min_ess,
    step limit, largest block)."""
    min_ess, max_steps, block = rule
    first = FIRST_BLOCK
    state, steps = start, 0
    tau = np.full(sampler.ndim, np.nan)
    reason = ""
    n = first
    while steps < max_steps:
        if steps and deadline is not None and time.monotonic() > deadline:
            return steps, np.asarray(tau), reason, Stop.WALL_TIME
        n = int(min(max(n, 1), max_steps - steps))
        with jax.enable_x64(True) if x64 else _nullcontext():
            state = sampler.run_mcmc(state, n, progress=False)
        steps += n
        if bar is not None:
            bar.update(n)
        tau = sampler.get_autocorr_time(tol=0)
        t = float(np.nanmax(tau)) if np.any(np.isfinite(tau)) else np.nan
        if not np.isfinite(t):
            n, reason = block, "autocorrelation time not yet estimable"
            continue
        need = max(50.0 * t, 3.0 * t + 1.2 * min_ess * t / sampler.nwalkers)
        n = int(np.clip(np.ceil(need - steps), first // 2, block))
        _revise_total(bar, min(max_steps, max(steps + n, int(np.ceil(need)))))
        if steps < 50 * t:
            reason = f"chain shorter than 50 autocorrelation times ({t:.0f} steps)"
            continue
        burn, thin = burn_thin(tau)
        rhat, ess = diagnose(sampler.get_chain(discard=burn, thin=thin))
        if rhat < 1.01 and ess >= min_ess:
            return steps, np.asarray(tau), "", Stop.CONVERGED
        reason = f"R-hat {rhat:.3f} (needs < 1.01), bulk ESS {ess:.0f} (needs ≥ {min_ess:.0f})"
    return steps, np.asarray(tau), reason, None


def _revise_total(bar, total: int) -> None:
    """Tell ``bar`` the steps the stopping rule now expects to need (its ETA follows them, not
    ``max_steps``, which a converging chain never reaches)."""
    if bar is not None and hasattr(bar, "total"):
        bar.total = total
        if hasattr(bar, "refresh"):
            bar.refresh()


def burn_thin(tau: np.ndarray) -> tuple[int, int]:
    """Burn-in (3 τ) and thinning (τ/4) [steps] from autocorrelation times ``tau``."""
    t = float(np.nanmax(tau)) if np.all(np.isfinite(tau)) else 50.0
    return int(np.ceil(3 * t)), max(1, int(t / 4))


def _to_idata(run: SamplerRun, ls, temper: float, mass: tuple, rng) -> "az.InferenceData":
    """The physical quantities of every kept draw of ``run`` (``mass`` = (value, sd) [kg])."""
    flat = run.draws.reshape(-1, 2)
    p, wd = np.exp(flat[:, 0]), np.exp(flat[:, 1])
    ab = conditional_amplitudes(np.asarray(run.blobs).reshape(-1, len(BLOB_FIELDS)), rng)
    m = mass_draws(mass[0], mass[1], p.size, rng)
    # physical quantities of every draw (dampfit.physics); u₀ from the acceleration amplitude
    # with the decimation filter's gain removed (eq. M2)
    q = physics.quantities(p, wd, m, accel_amplitude=np.hypot(ab[:, 0], ab[:, 1]) / abs(ls.gain))
    names = ("p", "omega_d", "zeta", "f_n", "f_d", "delta", "Q", "u0")
    post = {name: q[name] for name in names}
    if m is not None:
        post.update({"mass": m, "c": q["c"], "k": q["k"], "c_crit": q["c_crit"]})
    return to_idata(post, run.n_walkers, log_prob=run.log_prob,
                    attrs={"sampler": f"emcee {emcee.__version__}", "n_walkers": run.n_walkers,
                           "likelihood_temper": float(temper)})


def _progress(total: int, enabled: bool):
    from dampfit._progress import progress_bar

    return progress_bar(total, "viscous posterior", enabled=enabled)
