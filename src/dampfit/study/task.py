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

Several modes (a scenario with ``modes``): the true modes are numbered 1 … K by frequency and
every run gives one row per estimator and true mode, with a ``mode`` column. The bound of each
mode is the K-mode bound (:func:`dampfit.inference.crlb.bound_modes`) on the same samples and
σ, every mode's quadratures at τ₀ as above (an extra mode of acceleration
R·A₁·e^{−pτ}·cos(ω_dτ + φ) has A = R·A₁·cos φ, B = −R·A₁·sin φ at the release), the other
modes and the offset as nuisance and c only for the mass's mode. A several-mode estimator
(:mod:`dampfit.study.modal`) is compared mode by mode, its found modes paired one to one with
the true ones by nearest frequency (:func:`dampfit.study.modal.match`); a true mode it did not
find is a row with ``ok = False`` ("mode 2 not found: K = 1"), and ``n_modes`` is the K it
found. A one-mode estimator gives one row, for the mass's mode (the simulated m, k, c).
A one-mode scenario keeps its one-mode bound and rows (``mode`` = 1).
"""

from __future__ import annotations

import math
import os
import socket
import time
from typing import Any

import numpy as np

from dampfit._json import finite
from dampfit._options import DEFAULT_MAX_STEPS, DEFAULT_MIN_ESS, SamplerSettings
from dampfit.study.config import Task, sim_config

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



def true_modes(truth: dict[str, Any]) -> list[dict[str, Any]]:
    """The simulated modes by frequency: f_n [Hz], ζ [1], p [1/s], ω_d [rad/s], acceleration
    envelope at release ``accel_amplitude`` [m/s²] and ``phase`` [rad] (None for the mass's
    mode), ``primary`` (the mass's mode). One mode (the truth's own) without extra modes."""
    if "modes" in truth:
        return sorted(truth["modes"], key=lambda m: m["f_n"])
    return [{"f_n": truth["f_n"], "zeta": truth["zeta"], "p": truth["p"],
             "omega_d": truth["omega_d"], "accel_amplitude": None, "phase": None, "primary": True}]


def crlb_design_modes(recording, truth: dict[str, Any]) -> dict[str, Any]:
    """Arguments of :func:`dampfit.inference.crlb.bound_modes` for a simulated several-mode
    recording (module docstring): ``times`` [s] and ``sigma`` [m/s²] as :func:`crlb_design`,
    ``modes`` [(p [1/s], ω_d [rad/s], a_cos, a_sin [m/s²])] by frequency and ``mode_of_mass``
    (0-based index of the mass's mode)."""
    one = crlb_design(recording, truth)
    tau0 = float(recording.time[recording.time >= truth["t_release"]][0] - truth["t_release"])
    design, i_mass = [], 0
    for i, m in enumerate(true_modes(truth)):
        if m["primary"]:
            design.append((one["p"], one["omega_d"], one["a_cos"], one["a_sin"]))
            i_mass = i
            continue
        p, wd = m["p"], m["omega_d"]
        a, b = m["accel_amplitude"] * math.cos(m["phase"]), -m["accel_amplitude"] * math.sin(m["phase"])
        env, ph = math.exp(-p * tau0), wd * tau0
        design.append((p, wd, env * (a * math.cos(ph) + b * math.sin(ph)),
                       env * (b * math.cos(ph) - a * math.sin(ph))))
    return {"times": one["times"], "sigma": one["sigma"], "modes": design, "mode_of_mass": i_mass}


def _bounds(recording, truth: dict, mass: float | None) -> tuple[list[dict[str, float | None]], str]:
    """Bound sds of every true mode (by frequency): the one-mode bound without extra modes."""
    from dampfit.inference import crlb
    from dampfit.errors import InputError

    modes = true_modes(truth)
    try:
        if len(modes) == 1:
            b = [crlb.bound(**crlb_design(recording, truth), mass=mass, mass_sd=0.0,
                            drift_degree=0)]
        else:
            d = crlb_design_modes(recording, truth)
            b = crlb.bound_modes(d["times"], d["sigma"], d["modes"], drift_degree=0, mass=mass,
                                 mode_of_mass=d["mode_of_mass"])
    except InputError as exc:
        return [{q: None for q in QUANTITIES} for _ in modes], f"no bound: {exc}"
    return [{q: finite(e.get(q, {}).get("sd")) for q in QUANTITIES} for e in b], ""


def _covers(lo, hi, true) -> bool | None:
    lo, hi = finite(lo), finite(hi)
    if lo is None or hi is None or true is None:
        return None
    return bool(lo <= true <= hi)


def _true(truth: dict | None, mode: dict | None, mass_known: bool) -> dict[str, float | None]:
    """True p, f_n, ζ (and c: the mass's mode with a known mass only) of one mode."""
    if truth is None:
        return {q: None for q in QUANTITIES}
    if mode is None or mode["primary"]:
        out = {q: finite(truth[q]) for q in QUANTITIES}
    else:
        out = {q: finite(mode[q]) for q in ("p", "f_n", "zeta")} | {"c": None}
    if not mass_known:
        out["c"] = None
    return out


def _row(est, true: dict, sd: dict, mode: int) -> dict[str, Any]:
    """One row: ``est`` (an :class:`~dampfit.study.registry.Estimate` or None: not found)
    against the ``true`` values and bound sds ``sd`` of true mode ``mode`` (1-based)."""
    row: dict[str, Any] = {"estimator": est.estimator, "mode": mode}
    for q in QUANTITIES:
        value = finite(getattr(est, q, None)) if q != "c" or true["c"] is not None else None
        row[f"est_{q}"] = value
        row[f"true_{q}"] = true[q]
        row[f"crlb_{q}"] = sd[q]
        row[f"err_{q}"] = None if value is None or true[q] is None else value - true[q]
    for q in ("c", "zeta"):
        keep = q != "c" or row["est_c"] is not None
        row[f"{q}_lo"] = finite(getattr(est, f"{q}_lo", None)) if keep else None
        row[f"{q}_hi"] = finite(getattr(est, f"{q}_hi", None)) if keep else None
        row[f"covers_{q}"] = _covers(row[f"{q}_lo"], row[f"{q}_hi"], true[q])
    row["runtime_s"] = finite(est.runtime_s)
    row["ok"] = bool(est.ok) and row["est_p"] is not None
    row["message"] = str(est.message or "")
    return row


def _mode_rows(name: str, estimates: list, truth: dict, sds: list[dict],
               mass_known: bool) -> list[dict]:
    """Rows of the several-mode estimator ``name``: one per true mode, its found modes paired
    by nearest frequency (:func:`dampfit.study.modal.match`); an unpaired true mode is
    ``ok = False`` with why (not found, or the estimator's failure)."""
    from dataclasses import replace

    from dampfit.study import modal, registry

    modes = true_modes(truth)
    found = [e for e in estimates if finite(e.f_n) is not None]
    pairs = modal.match([e.f_n for e in found], [m["f_n"] for m in modes])
    first = estimates[0] if estimates else registry.failed_estimate(name, "no mode found")
    rows = []
    for i, m in enumerate(modes):
        if i in pairs:
            est = found[pairs[i]]
        else:
            why = (f"mode {i + 1} not found: K = {len(found)}" if found
                   else first.message or "no mode found")
            est = replace(first, p=math.nan, f_n=math.nan, zeta=math.nan, c=None, c_lo=None,
                          c_hi=None, zeta_lo=None, zeta_hi=None, ok=False, message=why)
        rows.append({**_row(est, _true(truth, m, mass_known), sds[i], i + 1),
                     "n_modes": len(found)})
    return rows


def _primary(truth: dict) -> int:
    """Index (0-based, by frequency) of the mass's mode."""
    return next(i for i, m in enumerate(true_modes(truth)) if m["primary"])


def _param_modes(task: Task) -> tuple[int, int]:
    """(number of true modes, 0-based index of the mass's mode by frequency) from the task's
    parameters alone (a run whose simulation failed)."""
    extra = [m[0] for m in task.params.get("modes", [])]
    return 1 + len(extra), sum(f < task.params["f_n"] for f in extra)


def _failed_rows(task: Task, truth: dict | None, message: str) -> list[dict[str, Any]]:
    from dampfit.study import modal

    n, primary = _param_modes(task)
    modes = true_modes(truth) if truth else [None] * n
    rows = []
    for name in task.estimators:
        which = range(n) if name in modal.MODE_ESTIMATORS else [primary]
        for i in which:
            true = _true(truth, modes[i], task.mass_known)
            row: dict[str, Any] = {"estimator": name, "mode": i + 1}
            for q in QUANTITIES:
                row.update({f"est_{q}": None, f"true_{q}": true[q], f"crlb_{q}": None,
                            f"err_{q}": None})
            for q in ("c", "zeta"):
                row.update({f"{q}_lo": None, f"{q}_hi": None, f"covers_{q}": None})
            row.update({"runtime_s": None, "ok": False, "message": message})
            rows.append(row)
    return rows


def _estimate(task: Task, rec, truth: dict, sds: list[dict], mass: float | None,
              seed: int) -> list[dict[str, Any]]:
    """Rows of every estimator of ``task`` on ``rec`` (in the task's order)."""
    from dampfit.study import modal, registry

    one = [n for n in task.estimators if n not in modal.MODE_ESTIMATORS]
    several = [n for n in task.estimators if n in modal.MODE_ESTIMATORS]
    results: dict[str, Any] = {}
    if one:
        results.update(zip(one, registry.run(one, rec, mass, seed=seed)))
    if several:
        results.update(zip(several, modal.run(several, rec, mass, seed=seed,
                                              max_modes=task.max_modes)))
    i = _primary(truth)
    rows = []
    for name in task.estimators:
        if name in modal.MODE_ESTIMATORS:
            rows.extend(_mode_rows(name, results[name], truth, sds, task.mass_known))
        else:
            rows.append(_row(results[name], _true(truth, None, task.mass_known), sds[i], i + 1))
    return rows


def run_task(task: Task) -> dict[str, Any]:
    """Simulate ``task``'s recording, run its estimators, bound it; return a JSON-safe record.

    The record holds ``scenario``, ``replicate``, ``seed``, provenance (``pid``, ``host``,
    ``started`` [s since the epoch], ``elapsed`` [s]), ``crlb_note`` and ``rows``: one dict per
    estimator and true mode (module docstring; a one-mode estimator: the mass's mode only)
    with ``estimator``, ``mode`` (1-based by frequency), ``est_*``, ``true_*``, ``crlb_*``
    (bound sd) and ``err_*`` (estimate − truth) for p [1/s], f_n [Hz], ζ [1] and c [N·s/m],
    the 90 % intervals ``c_lo``…``zeta_hi`` with ``covers_c``/``covers_zeta``, ``runtime_s``,
    ``ok``, ``message`` and, for a several-mode estimator, ``n_modes`` (the K it found). A simulation or
    recording the estimators cannot use becomes rows with ``ok = False`` (data, not an error).
    A campaign study's task goes to :func:`run_campaign_task`.
    """
    if task.campaign is not None:
        return run_campaign_task(task)
    from dampfit import simulate as sim

    started = time.time()
    record: dict[str, Any] = {"scenario": task.scenario, "replicate": task.replicate,
                              "seed": task.seed, "pid": os.getpid(), "host": socket.gethostname(),
                              "started": started, "crlb_note": ""}
    mass = task.mass if task.mass_known else None
    truth = None
    try:
        rec, truth = sim.recording(sim_config(task.params, task.mass, task.seed))
        sds, record["crlb_note"] = _bounds(rec, truth, mass)
        # the estimators' seed: a second stream of the run's seed sequence
        est_seed = int(np.random.SeedSequence(task.seed).generate_state(1)[0])
        record["rows"] = _estimate(task, rec, truth, sds, mass, est_seed)
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
        design = campaign.Design(n, spread, dm, u0, settings.get("added_mass_sd", 0.0))
        row = campaign.run(base, design, mass_known=task.mass_known,
                           mass_sd=settings.get("mass_sd", 0.0), sim_seed=task.seed, z_new=z_new,
                           sampler=SamplerSettings(
                               seed=analysis_seed,
                               max_steps=settings.get("max_steps", DEFAULT_MAX_STEPS),
                               min_ess=settings.get("min_ess", DEFAULT_MIN_ESS)))
    except Exception as exc:  # noqa: BLE001 - one unusable run must not stop a study
        true = campaign.truth(base, task.mass_known, dm is not None)
        row = {**campaign.empty_row(n, dm is not None, true, spread, z_new),
               "message": f"run failed: {type(exc).__name__}: {exc}"}
    record["rows"] = [row]
    record["elapsed"] = time.time() - started
    return record
