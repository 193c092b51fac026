r"""Several-mode estimators for studies: one :class:`~dampfit.study.registry.Estimate` per mode
found, and the one-to-one matching of found modes to the true ones.

Each estimator ``(prep, mass, *, seed, shared) -> list[Estimate]`` sees the same
:class:`~dampfit.signal.prepare.Prepared` recording as the one-mode estimators of
:mod:`dampfit.study.registry` and returns its modes by frequency, each with p [1/s], f_n [Hz],
ζ [1] and, with the mass m [kg], c = 2·m·p [N·s/m] (seed paper eq. 3) as if the mode were the
mass's (the study keeps c only on the row of the simulated mass's mode). ``shared`` holds the
order selection (:func:`dampfit.inference.modes_select.select`, K = 1 … ``max_modes`` by
evidence), computed once per recording for the estimators that use it; the reported
``runtime_s`` [s] of each includes it. The estimators (:data:`MODE_ESTIMATORS`):

``modes_bayes``          the modes stage's posterior at the evidence-chosen K
                         (:func:`dampfit.inference.modes_posterior.sample`, as
                         :func:`dampfit.stages.modes_stage`, with ``min_ess`` =
                         :data:`~dampfit.study.registry.BAYES_MIN_ESS` and the mass exact):
                         medians and 90 % credible intervals; ``ok`` False when the chain did
                         not converge (the numbers are still reported);
``modes_least_squares``  the K-mode least squares at the chosen K: its optimum and 90 % normal
                         intervals in the logs from the tempered Laplace covariance of
                         θ = (ln p_1, ln ω_d,1, …) (eq. MS3) by the delta method,
                         ∂ln ζ/∂(ln p, ln ω_d) = (1 − ζ², −(1 − ζ²)), ∂ln p = (1, 0):
                         ζ·exp(±1.645·sd(ln ζ)), p·exp(±1.645·sd(ln p));
``modes_pencil``         the subspace baseline (:func:`dampfit.estimators.subspace.subspace_modes`,
                         matrix pencil with its own order rule); no interval.

:func:`run` prepares a recording once and runs the named estimators, a failure of one of them
becoming one ``ok=False`` estimate with the reason (as :func:`dampfit.study.registry.run`).
:func:`match` pairs found and true modes one to one by nearest frequency.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import replace
from typing import Callable, Iterable

import numpy as np

from dampfit import physics
from dampfit.errors import InputError
from dampfit.signal import prepare
from dampfit.signal.prepare import Prepared
from dampfit.io.recording import Recording
from dampfit.study.config.study import DEFAULT_MAX_MODES
from dampfit.study.registry import (BAYES_MIN_ESS, Z90, Estimate, estimate_from,
                                    failed_estimate)



class Shared:
    """What the several-mode estimators of one recording share: the order selection of
    ``prep`` up to ``max_modes`` modes, computed on first use (or its error, re-raised), the
    wall time [s] it took (``seconds``) and how often it was asked for (``calls``)."""

    def __init__(self, prep: Prepared, max_modes: int):
        self.prep, self.max_modes = prep, max_modes
        self.seconds, self.calls = 0.0, 0
        self._selection = None
        self._error: Exception | None = None

    def selection(self):
        """The :class:`~dampfit.inference.modes_select.ModeSelection` of ``prep``."""
        self.calls += 1
        if self._selection is None and self._error is None:
            from dampfit.inference import modes_select

            t0 = time.perf_counter()
            try:
                self._selection = modes_select.select(self.prep, max_modes=self.max_modes)
            except Exception as exc:  # noqa: BLE001 - the same failure for every estimator
                self._error = exc
            self.seconds = time.perf_counter() - t0
        if self._error is not None:
            raise self._error
        return self._selection


class _Clock:
    """Wall time [s] of one estimator from now: its own, plus the shared selection's if it
    asked for the selection (whichever estimator happened to compute it)."""

    def __init__(self, shared: Shared):
        self.shared, self.t0 = shared, time.perf_counter()
        self.before, self.calls = shared.seconds, shared.calls

    def seconds(self) -> float:
        s = self.shared
        own = time.perf_counter() - self.t0 - (s.seconds - self.before)
        return own + (s.seconds if s.calls > self.calls else 0.0)


#: name -> estimator(prep, mass, *, seed, shared) -> list[Estimate] (by frequency)
MODE_ESTIMATORS: dict[str, Callable[..., list[Estimate]]] = {}


def _estimator(name: str):
    """Register ``fn`` under ``name``; every estimate's ``runtime_s`` [s] is the estimator's own
    wall time plus, if it used it, the shared selection's."""

    def wrap(fn):
        @functools.wraps(fn)
        def timed(prep: Prepared, mass: float | None, *, seed: int, shared: Shared) -> list[Estimate]:
            clock = _Clock(shared)
            out = fn(prep, mass, seed=seed, shared=shared)
            return [replace(e, runtime_s=clock.seconds()) for e in out]

        MODE_ESTIMATORS[name] = timed
        return timed

    return wrap


@_estimator("modes_bayes")
def modes_bayes(prep: Prepared, mass: float | None, *, seed: int, shared: Shared) -> list[Estimate]:
    """The several-mode posterior at the chosen K (module docstring): per mode the medians of
    p [1/s], f_n [Hz], ζ [1] and their 5 % and 95 % quantiles; c = 2·m·p [N·s/m] of the p
    quantiles (exact for an exactly known mass)."""
    from dampfit.inference import modes_posterior

    post = modes_posterior.sample(shared.selection(), mass=mass, seed=seed, min_ess=BAYES_MIN_ESS)
    ok = bool(post.converged)
    msg = "" if ok else "; ".join(post.warnings) or "did not converge"
    out = []
    for row in post.summary():
        p, f_n, z = row["p"], row["f_n"], row["zeta"]
        c = None if mass is None else [float(physics.damping_coefficient(mass, p[k]))
                                       for k in ("q50", "q05", "q95")]
        out.append(Estimate("modes_bayes", float(p["q50"]), float(f_n["q50"]), float(z["q50"]),
                            *(c or (None, None, None)), float(z["q05"]), float(z["q95"]), ok,
                            msg, 0.0))
    return out


@_estimator("modes_least_squares")
def modes_least_squares(prep: Prepared, mass: float | None, *, seed: int,
                        shared: Shared) -> list[Estimate]:
    """The K-mode least squares at the evidence-chosen K with 90 % normal intervals in the logs
    (module docstring); ``ok`` False when its fit did not converge."""
    res = shared.selection().chosen
    fit = res.fit
    if fit is None:
        raise InputError(f"no {res.n_modes}-mode least-squares fit: {res.reason}")
    return [estimate_from("modes_least_squares", m["p"][0], m["omega_d"] / (2 * np.pi), mass,
                          ok=bool(fit.converged),
                          message="" if fit.converged else str(fit.message),
                          p_int=m["p"][1:], zeta_int=m["zeta"][1:])
            for m in res.laplace_intervals(Z90)]


@_estimator("modes_pencil")
def modes_pencil(prep: Prepared, mass: float | None, *, seed: int, shared: Shared) -> list[Estimate]:
    """The subspace baseline (:func:`dampfit.estimators.subspace.subspace_modes` up to
    ``shared.max_modes`` modes); no interval."""
    from dampfit.estimators.subspace import subspace_modes

    return [estimate_from("modes_pencil", m.p, m.f_d, mass)
            for m in subspace_modes(prep, max_modes=shared.max_modes)]


def run(names: Iterable[str], recording: Recording, mass: float | None = None, *, seed: int = 0,
        max_modes: int = DEFAULT_MAX_MODES) -> list[list[Estimate]]:
    """Prepare ``recording`` once and run each named several-mode estimator on it.

    ``mass`` [kg] for c; ``seed`` for the posterior; ``max_modes`` the largest K tried. Returns
    per name its estimates by frequency, or one ``ok=False`` estimate (NaN frequency) with the
    reason if it raised. An unknown name, a bad mass or ``max_modes``, or an unusable recording
    (:func:`dampfit.signal.prepare.prepare`) raise :class:`InputError`.
    """
    from dampfit.inference.modes import check_max_modes

    names = list(names)
    unknown = [n for n in names if n not in MODE_ESTIMATORS]
    if unknown:
        raise InputError(f"unknown several-mode estimator(s) {', '.join(map(repr, unknown))}; "
                         f"valid: {', '.join(MODE_ESTIMATORS)}")
    mass = physics.check_mass(mass)[0]
    shared = Shared(prepare.prepare(recording), check_max_modes(max_modes))
    out = []
    for name in names:
        clock = _Clock(shared)
        try:
            out.append(MODE_ESTIMATORS[name](shared.prep, mass, seed=seed, shared=shared))
        except Exception as exc:  # noqa: BLE001 - failure is data in a comparison study
            msg = f"{type(exc).__name__}: {exc}".strip()
            out.append([failed_estimate(name, msg, clock.seconds())])
    return out


def match(found_f: list[float], true_f: list[float]) -> dict[int, int]:
    """One-to-one pairing of found and true modes by nearest frequency: ``{true index: found
    index}`` minimising the sum of |ln(f_found/f_true)| (:func:`scipy.optimize.linear_sum_assignment`);
    found modes with a non-finite or non-positive frequency [Hz] are left out. With fewer found
    than true modes some true modes stay unpaired, with more some found ones."""
    from scipy.optimize import linear_sum_assignment

    usable = [j for j, f in enumerate(found_f) if math.isfinite(f) and f > 0]
    if not usable or not true_f:
        return {}
    cost = np.abs(np.log(np.asarray([found_f[j] for j in usable])[None, :]
                         / np.asarray(true_f, dtype=float)[:, None]))
    rows, cols = linear_sum_assignment(cost)
    return {int(i): usable[int(j)] for i, j in zip(rows, cols)}
