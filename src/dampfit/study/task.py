r"""One study run, executed on a Dask worker: simulate, estimate, bound. Pure: no file output.

(A campaign study's run simulates a campaign and analyses it jointly instead:
:func:`run_campaign_task`, scored by :mod:`dampfit.study.campaign`.)

:func:`run_task` simulates one recording of a scenario, runs every estimator of the task on
that same recording (:func:`dampfit.study.registry.run`, which never raises for a numerical
failure) and computes the Cramér–Rao lower bound of the design (:func:`dampfit.inference.crlb.bound`).
It returns a plain, JSON-safe record; the client stores it.

The bound's design is the noise-free free decay as simulated: every sample from the release
``t_r`` up to the catch (or the end), white noise of per-sample sd
σ = √(σ_noise² + LSB²/12) (the simulator's noise plus uniform quantization), the true p and
ω_d, an unknown constant offset (``drift_degree=0``) and the mass known exactly. The
acceleration along the motion is (:mod:`dampfit.simulate`, release at rest from u0 [m])

    a(τ) = e^{−pτ}·(A·cos ω_dτ + B·sin ω_dτ),  A = −ω_n²·u0,  B = p·ω_n²·u0/ω_d,

(A from ü(0) = −ω_n²u0; B from the jerk ⃛u(0) = 2p·ω_n²·u0 = −pA + ω_d·B). With the bound's
time origin at the first free sample τ₀, the quadratures there are
e^{−pτ₀}·(A cos ω_dτ₀ + B sin ω_dτ₀) and e^{−pτ₀}·(B cos ω_dτ₀ − A sin ω_dτ₀).
It is the bound of an estimator that uses the whole free decay with white noise; drift and
coloured noise are not in it, so their cost shows as RMSE/CRLB > 1.
"""

from __future__ import annotations

import math
import os
import socket
import time
from typing import Any

import numpy as np

from dampfit._json import finite
from dampfit.study.config import Task, sim_config

__all__ = ["QUANTITIES", "crlb_design", "run_campaign_task", "run_task"]

#: Quantities compared with the truth, with the bound's key for each.
QUANTITIES = ("p", "f_n", "zeta", "c")


def crlb_design(recording, truth: dict[str, Any]) -> dict[str, Any]:
    """Arguments of :func:`dampfit.inference.crlb.bound` for a simulated recording (module docstring).

    Returns ``times`` [s] (from the first free sample), ``sigma`` [m/s²], ``p`` [1/s],
    ``omega_d`` [rad/s], ``a_cos`` and ``a_sin`` [m/s²].
    """
    t = recording.time
    end = truth["t_catch"] if truth["t_catch"] is not None else math.inf
    t = t[(t >= truth["t_release"]) & (t < end)]
    p, wd, wn = truth["p"], truth["omega_d"], truth["omega_n"]
    a, b = -wn**2 * truth["u0"], p * wn**2 * truth["u0"] / wd
    tau0 = float(t[0] - truth["t_release"])
    env, ph = math.exp(-p * tau0), wd * tau0
    lsb = truth["config"]["quantization"]
    return {
        "times": t - t[0],
        "sigma": math.sqrt(truth["noise_sigma"] ** 2 + lsb**2 / 12.0),
        "p": p, "omega_d": wd,
        "a_cos": env * (a * math.cos(ph) + b * math.sin(ph)),
        "a_sin": env * (b * math.cos(ph) - a * math.sin(ph)),
    }




def _bound(recording, truth: dict, mass: float | None) -> tuple[dict[str, float | None], str]:
    from dampfit.inference import crlb
    from dampfit.errors import InputError

    try:
        b = crlb.bound(**crlb_design(recording, truth), mass=mass, mass_sd=0.0, drift_degree=0)
    except InputError as exc:
        return {q: None for q in QUANTITIES}, f"no bound: {exc}"
    return {q: finite(b.get(q, {}).get("sd")) for q in QUANTITIES}, ""


def _covers(lo, hi, true) -> bool | None:
    lo, hi = finite(lo), finite(hi)
    if lo is None or hi is None or true is None:
        return None
    return bool(lo <= true <= hi)


def _row(est, truth: dict, sd: dict, mass_known: bool) -> dict[str, Any]:
    row: dict[str, Any] = {"estimator": est.estimator}
    true = {q: finite(truth[q]) for q in QUANTITIES}
    if not mass_known:
        true["c"] = None
    for q in QUANTITIES:
        value = finite(getattr(est, q, None))
        row[f"est_{q}"] = value
        row[f"true_{q}"] = true[q]
        row[f"crlb_{q}"] = sd[q]
        row[f"err_{q}"] = None if value is None or true[q] is None else value - true[q]
    for q in ("c", "zeta"):
        row[f"{q}_lo"] = finite(getattr(est, f"{q}_lo", None))
        row[f"{q}_hi"] = finite(getattr(est, f"{q}_hi", None))
        row[f"covers_{q}"] = _covers(row[f"{q}_lo"], row[f"{q}_hi"], true[q])
    row["runtime_s"] = finite(est.runtime_s)
    row["ok"] = bool(est.ok) and row["est_p"] is not None
    row["message"] = str(est.message or "")
    return row


def _failed_rows(task: Task, truth: dict | None, message: str) -> list[dict[str, Any]]:
    rows = []
    for name in task.estimators:
        row: dict[str, Any] = {"estimator": name}
        for q in QUANTITIES:
            true = finite(truth[q]) if truth and (q != "c" or task.mass_known) else None
            row.update({f"est_{q}": None, f"true_{q}": true, f"crlb_{q}": None, f"err_{q}": None})
        for q in ("c", "zeta"):
            row.update({f"{q}_lo": None, f"{q}_hi": None, f"covers_{q}": None})
        row.update({"runtime_s": None, "ok": False, "message": message})
        rows.append(row)
    return rows


def run_task(task: Task) -> dict[str, Any]:
    """Simulate ``task``'s recording, run its estimators, bound it; return a JSON-safe record.

    The record holds ``scenario``, ``replicate``, ``seed``, provenance (``pid``, ``host``,
    ``started`` [s since the epoch], ``elapsed`` [s]), ``crlb_note`` and ``rows``: one dict per
    estimator with ``est_*``, ``true_*``, ``crlb_*`` (bound sd) and ``err_*`` (estimate −
    truth) for p [1/s], f_n [Hz], ζ [1] and c [N·s/m], the 90 % intervals ``c_lo``…``zeta_hi``
    with ``covers_c``/``covers_zeta``, ``runtime_s``, ``ok`` and ``message``. A simulation or
    recording the estimators cannot use becomes rows with ``ok = False`` (data, not an error).
    A campaign study's task goes to :func:`run_campaign_task`.
    """
    if task.campaign is not None:
        return run_campaign_task(task)
    from dampfit.study import registry
    from dampfit import simulate as sim

    started = time.time()
    record: dict[str, Any] = {"scenario": task.scenario, "replicate": task.replicate,
                              "seed": task.seed, "pid": os.getpid(), "host": socket.gethostname(),
                              "started": started, "crlb_note": ""}
    mass = task.mass if task.mass_known else None
    truth = None
    try:
        rec, truth = sim.recording(sim_config(task.params, task.mass, task.seed))
        sd, record["crlb_note"] = _bound(rec, truth, mass)
        # the estimators' seed: a second stream of the run's seed sequence
        est_seed = int(np.random.SeedSequence(task.seed).generate_state(1)[0])
        results = registry.run(list(task.estimators), rec, mass, seed=est_seed)
        record["rows"] = [_row(e, truth, sd, task.mass_known) for e in results]
    except Exception as exc:  # noqa: BLE001 - one unusable run must not stop a study
        record["rows"] = _failed_rows(task, truth, f"run failed: {type(exc).__name__}: {exc}")
    record["elapsed"] = time.time() - started
    return record


def _header(task: Task, started: float) -> dict[str, Any]:
    return {"scenario": task.scenario, "replicate": task.replicate, "seed": task.seed,
            "pid": os.getpid(), "host": socket.gethostname(), "started": started,
            "crlb_note": ""}


def run_campaign_task(task: Task) -> dict[str, Any]:
    """Simulate ``task``'s campaign, analyse it jointly, score it; return a JSON-safe record.

    The record has the keys of :func:`run_task` (``crlb_note`` is "no bound for a campaign"),
    with one row, estimator ``campaign``: the truth (``true_c`` [N·s/m], ``true_k`` [N/m],
    ``true_m0`` [kg], ``true_zeta`` [1], ``true_spread`` [1], the new test's ``true_new_c``),
    the population medians ``est_*`` with their 90 % intervals ``*_lo``/``*_hi``, the
    coverage flags ``covers_*``, the spread ``spread_q05``…``spread_q95``,
    ``spread_zero_consistent`` and ``spread_zero_ok``, the diagnostics (``converged``,
    ``n_steps``, ``max_r_hat``, ``min_ess_bulk``), ``verdict``, ``runtime_s`` [s], ``ok``,
    ``refused`` (the refusal of the simulator or the analysis: a result, not a crash) and
    ``message`` (:mod:`dampfit.study.campaign`). The recordings use the run's seed, the
    sampler and the new test's draw a separate stream of it
    (:func:`dampfit.study.campaign.streams`): the same task gives the same record.
    """
    from dampfit.study import campaign

    started = time.time()
    record = _header(task, started)
    record["crlb_note"] = "no bound for a campaign"
    settings = task.campaign or {}
    n, spread, dm, u0 = campaign.per_test(task.params, task.mass)
    analysis_seed, z_new = campaign.streams(task.seed)
    base = sim_config(task.params, task.mass, seed=0)  # validated with the configuration
    try:
        row = campaign.run(base, n_tests=n, c_spread=spread, added_mass=dm, amplitudes=u0,
                           mass_known=task.mass_known, mass_sd=settings.get("mass_sd", 0.0),
                           added_mass_sd=settings.get("added_mass_sd", 0.0), sim_seed=task.seed,
                           analysis_seed=analysis_seed, z_new=z_new,
                           max_steps=settings.get("max_steps", 20000),
                           min_ess=settings.get("min_ess", 1000.0))
    except Exception as exc:  # noqa: BLE001 - one unusable run must not stop a study
        true = campaign.truth(base, task.mass_known, dm is not None)
        row = {**campaign.empty_row(n, dm is not None, true, spread, z_new),
               "message": f"run failed: {type(exc).__name__}: {exc}"}
    record["rows"] = [row]
    record["elapsed"] = time.time() - started
    return record
