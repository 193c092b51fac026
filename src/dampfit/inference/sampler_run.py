r"""The one result of an emcee run, the one diagnostics function, the one emcee → arviz reshape.

Every sampler of dampfit — the one-mode posterior (:mod:`dampfit.inference.posterior`), a
damping law's (:mod:`dampfit.inference.law_sampler`), the several-mode posterior
(:mod:`dampfit.inference.modes_posterior`) and a campaign's hyper-posterior
(:mod:`dampfit.campaign.sampling`) — runs emcee through
:func:`dampfit.inference.posterior.run_adaptive`, which returns a :class:`SamplerRun`:

* the draws kept after burn-in (3 τ) and thinning (τ/4): ``draws`` (draw, walker, k) in the
  sampler's coordinates, ``log_prob`` (draw, walker) and emcee's per-draw ``blobs``;
* ``n_steps``, ``n_walkers``, ``burn_in``, ``thin`` [steps], the integrated autocorrelation
  times ``autocorr_time`` [steps] per dimension and the mean ``acceptance`` [1];
* why it stopped: ``stop`` (:class:`Stop`, with its :attr:`Stop.remedy`), the sentence
  ``stop_reason`` and, for a run that did not converge, ``unmet``: the criterion of the
  stopping rule still unmet at its last check;
* ``wall_time_s`` [s] and the ``budget`` it ran under;
* once the sampler has turned the draws into physical quantities: ``idata`` (arviz), their
  R-hat and bulk ESS (:func:`diagnostics`, walkers as chains), the worst of them
  (``max_r_hat``, ``min_ess_bulk``) and the sampler's ``warnings`` (:meth:`SamplerRun.finish`).

arviz is imported on first use only (:mod:`dampfit._arviz`).
"""

from __future__ import annotations

import enum
import math
import warnings as _warnings
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np


class Stop(enum.Enum):
    """Why an emcee run stopped; :attr:`remedy` says what to do about a run that did not
    converge."""

    CONVERGED = "converged"
    MAX_STEPS = "max_steps reached"
    STEP_BUDGET = "step budget reached"
    WALL_TIME = "wall-time budget reached"
    NOT_SAMPLED = "ill-conditioned: not sampled with emcee"
    #: a campaign: the importance weights of its exact per-test likelihoods (eq. C6) are
    #: too uneven, though the chains converged
    WEIGHTS = "importance weights too uneven"

    @property
    def remedy(self) -> str:
        """One sentence: what gives a converged run (empty for :attr:`CONVERGED`)."""
        return _REMEDIES[self]


_REMEDIES = {
    Stop.CONVERGED: "",
    Stop.MAX_STEPS: "raise the step limit (--max-steps) or shorten the window to the clean decay",
    Stop.STEP_BUDGET: ("the run is bounded by a multiple of the viscous sampler's steps: a "
                       "posterior this slow to mix is itself a sign the law or modes do not fit"),
    Stop.WALL_TIME: ("a wall-time limit depends on the machine: run with max_steps set to the "
                     "steps taken to reproduce this stop, or without the limit"),
    Stop.NOT_SAMPLED: ("the data cannot tell the law's parameters apart: read the Laplace "
                       "intervals as approximate, or prefer the simpler law"),
    Stop.WEIGHTS: ("a test's likelihood is far from its Laplace form: check the tests the "
                   "warnings name (window, damping law) or analyse them one by one"),
}


@dataclass(frozen=True)
class SamplerRun:
    """One emcee run and its diagnostics (module docstring). ``converged`` is ``stop is
    Stop.CONVERGED``."""

    draws: np.ndarray
    log_prob: np.ndarray
    blobs: np.ndarray | None
    n_steps: int
    n_walkers: int
    burn_in: int
    thin: int
    autocorr_time: np.ndarray
    acceptance: float
    stop: Stop
    stop_reason: str
    unmet: str = ""
    wall_time_s: float = float("nan")
    budget: Any = None  # dampfit.inference.law_sampler.Budget, or None
    idata: Any = None
    #: name → {"r_hat": [1], "ess_bulk": [draws]} (a list of them per mode for a per-mode
    #: quantity) of every quantity in ``idata.posterior`` (:func:`diagnostics`)
    diagnostics: dict = field(default_factory=dict)
    max_r_hat: float = float("nan")
    min_ess_bulk: float = float("nan")
    warnings: tuple[str, ...] = ()

    @property
    def converged(self) -> bool:
        return self.stop is Stop.CONVERGED

    @property
    def remedy(self) -> str:
        return self.stop.remedy

    def not_converged(self, what: str, consequence: str = "") -> str:
        """The one warning of a run that did not converge: ``what`` ("posterior", "modal
        posterior", …), the steps, why it stopped (``stop_reason``; the criterion unmet),
        the ``consequence`` for the results, and what to do (:attr:`remedy`)."""
        why = (self.stop_reason + (f"; {self.unmet}" if self.unmet else "")
               + (f"; what to do: {self.remedy}" if self.remedy else ""))
        return (f"{what} NOT converged after {self.n_steps} steps ({why})"
                + (f": {consequence}" if consequence else ""))

    def finish(self, idata, warnings=(), names=None, **kw) -> "SamplerRun":
        """This run with its ``idata``, the :func:`diagnostics` of it, the worst R-hat and ESS
        over ``names`` (None: every quantity; :func:`worst`) and the sampler's ``warnings``;
        ``kw`` passes further fields (``diagnostics`` of a subset, …)."""
        diag = kw.pop("diagnostics", None)
        diag = diagnostics(idata) if diag is None else diag
        max_rhat, min_ess = worst(diag, names)
        return replace(self, idata=idata, diagnostics=diag, max_r_hat=max_rhat,
                       min_ess_bulk=min_ess, warnings=tuple(warnings), **kw)

    def sampling(self) -> dict:
        """JSON-safe facts about the run: ``converged``, ``max_r_hat`` [1], ``min_ess_bulk``
        [draws], ``n_steps``, ``burn_in``, ``thin`` [steps], ``n_walkers``,
        ``acceptance_fraction`` [1], ``wall_time_s`` [s], ``stop_reason`` and ``budget``
        (:meth:`~dampfit.inference.law_sampler.Budget.summary`, None without one)."""
        return {"converged": bool(self.converged), "max_r_hat": self.max_r_hat,
                "min_ess_bulk": self.min_ess_bulk, "n_steps": int(self.n_steps),
                "burn_in": int(self.burn_in), "thin": int(self.thin),
                "n_walkers": int(self.n_walkers),
                "acceptance_fraction": self.acceptance,
                "wall_time_s": self.wall_time_s if math.isfinite(self.wall_time_s) else None,
                "stop_reason": self.stop_reason or None,
                "budget": None if self.budget is None else self.budget.summary()}


def _fact(name: str) -> property:
    return property(lambda self: getattr(self.run, name),
                    doc=f"The run's ``{name}`` (:class:`SamplerRun`).")


class ReadsRun:
    """Mixin of a sampler's result that holds its :class:`SamplerRun` as ``run``: the run's
    facts read through (``post.converged`` is ``post.run.converged``), so they exist once."""

    idata = _fact("idata")
    converged = _fact("converged")
    n_steps = _fact("n_steps")
    n_walkers = _fact("n_walkers")
    burn_in = _fact("burn_in")
    thin = _fact("thin")
    autocorr_time = _fact("autocorr_time")
    acceptance = _fact("acceptance")
    max_r_hat = _fact("max_r_hat")
    min_ess_bulk = _fact("min_ess_bulk")
    diagnostics = _fact("diagnostics")
    warnings = _fact("warnings")
    wall_time_s = _fact("wall_time_s")
    stop_reason = _fact("stop_reason")
    budget = _fact("budget")


def diagnostics(idata, *, scalars_only: bool = False) -> dict:
    """Rank-normalised R-hat [1] and bulk ESS [draws] of every quantity in
    ``idata.posterior`` (arviz, walkers as chains): ``{name: {"r_hat", "ess_bulk"}}``, a list
    of such dicts for a quantity with a further dimension (one per mode). ``scalars_only``
    keeps the (chain, draw) quantities whose draws are all finite (a campaign: ln τ_ω = −inf
    under its shared-frequency model). A constant quantity (the mass without an uncertainty)
    has R-hat NaN."""
    from dampfit._arviz import arviz

    post = idata.posterior
    if scalars_only:
        post = post[[v for v, x in post.data_vars.items()
                     if x.ndim == 2 and np.all(np.isfinite(x.values))]]
    az = arviz()
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore")  # constant draws: R-hat is NaN, with a warning
        rhat = az.rhat(post)
        ess = az.ess(post, method="bulk")
    out: dict = {}
    for name, x in post.data_vars.items():
        r, e = np.atleast_1d(rhat[name].values), np.atleast_1d(ess[name].values)
        rows = [{"r_hat": float(a), "ess_bulk": float(b)} for a, b in zip(r, e)]
        out[str(name)] = rows if x.ndim > 2 else rows[0]
    return out


def diagnose(chain: np.ndarray) -> tuple[float, float]:
    """Worst rank-normalised R-hat and bulk ESS over the dimensions of a (draw, walker, k)
    chain in the sampler's coordinates, walkers taken as chains: the stopping rule's check
    (:func:`dampfit.inference.posterior.run_adaptive`); (inf, 0) below 8 draws."""
    from dampfit._arviz import arviz

    if chain.shape[0] < 8:
        return np.inf, 0.0
    x = np.transpose(chain, (1, 0, 2))  # (chain, draw, dim)
    az = arviz()
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        rh = [float(az.rhat(x[..., i])) for i in range(x.shape[-1])]
        es = [float(az.ess(x[..., i], method="bulk")) for i in range(x.shape[-1])]
    return max(rh), min(es)


def worst(diag: dict, names=None) -> tuple[float, float]:
    """(largest R-hat, smallest bulk ESS) over the finite entries of ``diag``
    (:func:`diagnostics`) for ``names`` (None: all), NaN where there is none."""
    picked = [diag[n] for n in (diag if names is None else names) if n in diag]
    flat = [d for v in picked for d in (v if isinstance(v, list) else [v])]
    rh = [d["r_hat"] for d in flat if math.isfinite(d["r_hat"])]
    es = [d["ess_bulk"] for d in flat if math.isfinite(d["ess_bulk"])]
    return max(rh, default=math.nan), min(es, default=math.nan)


def to_idata(post: dict, n_walkers: int, *, log_prob=None, dims=None, coords=None,
             attrs=None):
    """arviz InferenceData of ``post`` (name → flat draws in emcee's (draw, walker) order,
    with any further axes after the first) as (chain = walker, draw, …), the per-draw
    ``log_prob`` (draw, walker) as ``sample_stats.lp``; ``dims``, ``coords``, ``attrs`` as
    :func:`arviz.from_dict` takes them."""
    from dampfit._arviz import arviz

    def shape(v):
        v = np.asarray(v, dtype=float)
        v = v.reshape((v.shape[0] // n_walkers, n_walkers) + v.shape[1:])
        return np.swapaxes(v, 0, 1)

    stats = None if log_prob is None else {"lp": np.asarray(log_prob).T}
    with _warnings.catch_warnings():  # short chains: (chain, draw) is right by construction
        _warnings.simplefilter("ignore")
        return arviz().from_dict(posterior={k: shape(v) for k, v in post.items()},
                                 sample_stats=stats, dims=dims, coords=coords, attrs=attrs)
