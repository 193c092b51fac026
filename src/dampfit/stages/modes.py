"""The several-modes stage (issue 21): one function for a single recording
(:func:`dampfit.pipeline.analyze`), each test of a campaign (:mod:`dampfit.campaign.modes`)
and the study's modal estimators (:mod:`dampfit.study.modal`).

In order, on the prepared signal of the one-mode path:

1. with the one-mode least squares given (``one_mode``), the cheap screen
   :func:`dampfit.inference.modes_gate.screen` (≈ 0.01–0.05 s) looks at its residual in the
   modal band: when nothing stands out of the noise the recording is one mode and nothing
   else runs (the screen errs towards running the selection: its module docstring);
2. the number of modes K = 1 … ``max_modes`` by evidence
   (:func:`dampfit.inference.modes_select.select`), or fixed by ``n_modes``;
3. the posterior of every mode (:func:`dampfit.inference.modes_posterior.sample`, within its
   work budget) and its plain-data summary with bounds, close pairs, Rayleigh α, β and each
   mode's least squares (:func:`~dampfit.inference.modes_posterior.modal_summary`). With
   ``one_mode`` given, K = 1 is that analysis and no second sampler runs;
   Before it, with ``one_mode`` given: when every component but one is a harmonic of a
   stronger one, or — under an amplitude-dependent or misfit one-mode verdict — a close
   partner of the one-mode frequency, the recording is one mode, with the reason
   (:func:`one_mode_after_all`);
4. a close pair at the one-mode frequency that may be one amplitude-dependent mode split in
   two is explained in a warning (:func:`dampfit.inference.modes_close.split_pair`).

Bad options are one-line :class:`~dampfit.errors.InputError` before any fit (a
``mode_of_mass`` beyond the K found: after the selection). A recording the modal analysis
cannot handle (too short, too few samples per cycle of the highest mode, no mode fitted) is
not an error: ``n_modes`` is None and the evidence's ``reason`` says why.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from dampfit import physics
from dampfit._json import jsonable
from dampfit._options import DEFAULT_MAX_MODES, SamplerSettings
from dampfit.errors import InputError
from dampfit.signal import prepare

#: One-mode damping verdicts (:mod:`dampfit.damping`) under which any close pair at the
#: one-mode frequency may be that mode split in two (:func:`~dampfit.inference.modes_close.split_pair`).
SPLIT_VERDICTS = ("amplitude-dependent", "misfit")


@dataclass(frozen=True)
class ModesStage:
    """What :func:`modes_stage` found.

    ``n_modes`` K (None: not analysed, ``evidence["reason"]`` says why); ``summary`` the
    JSON-safe :func:`~dampfit.inference.modes_posterior.modal_summary` with ``sampling``
    (None when no modal posterior ran); ``evidence`` summary.json's ``modes_evidence``
    (``max_modes``, ``screen``, P(K) and ln Z of every K tried, ``reason``, ``seconds``; with a
    posterior also ``pairs``, ``notes``, ``sampling``); ``warnings``; ``selection``
    (:class:`~dampfit.inference.modes_select.ModeSelection`) and ``posterior``
    (:class:`~dampfit.inference.modes_posterior.ModalPosterior`, its ``idata`` for
    posterior.nc), None when not run; ``dominant`` the 0-based index of the mode at the
    one-mode frequency (None without ``one_mode`` or a modal posterior; the mass's mode
    unless ``mode_of_mass`` names another); ``split`` the warnings (also in ``warnings``)
    that a close pair may be the one-mode analysis's mode split in two; ``seconds`` [s] the
    stage's wall time; ``seen`` summary.json's ``modes_seen``: the components that are not
    modes (:mod:`dampfit.inference.modes_checks`), with ``kind`` and ``reason``. ``n_modes``
    counts the identified modes only (the evidence's K is ``evidence["n_components"]``)."""

    n_modes: int | None
    evidence: dict[str, Any]
    summary: dict[str, Any] | None = None
    warnings: tuple[str, ...] = ()
    selection: Any = None
    posterior: Any = None
    dominant: int | None = None
    split: tuple[str, ...] = ()
    seconds: float = 0.0
    seen: tuple[dict, ...] = ()


class OneMode(NamedTuple):
    """The one-mode analysis the modes stage follows: its least squares' ``p`` [1/s] and
    ``omega_d`` [rad/s], its damping-law ``verdict`` and ``law`` = (FitData, LawFit) of that
    verdict's preferred law (the four travel together; a plain ``(p, omega_d)`` pair is one
    with neither)."""

    p: float
    omega_d: float
    verdict: str | None = None
    law: Any = None


def modes_stage(prep: prepare.Prepared, *, max_modes: int = DEFAULT_MAX_MODES,
                n_modes: int | None = None, band: tuple[float, float] | None = None,
                mass: physics.Mass | float | None = None, mode_of_mass: int | None = None,
                sampler: SamplerSettings = SamplerSettings(),
                one_mode: OneMode | tuple[float, float] | None = None) -> ModesStage:
    """Several modes in the window of ``prep`` (see the module docstring).

    ``max_modes`` the most modes looked for (1: nothing is done, "not looked for"), or
    ``n_modes`` a fixed K; ``band`` [Hz] the modal band (MS1 by default); ``mass``
    (:class:`~dampfit.physics.Mass`, checked when it was made; a bare number [kg] is
    ``Mass(number)``) gives c [N·s/m] and k [N/m] of the mode ``mode_of_mass`` (1-based; the
    fundamental at the one-mode frequency by default); ``sampler`` the
    :class:`~dampfit._options.SamplerSettings` of the modal posterior (its budget is counted
    in steps, :func:`dampfit.inference.modes_posterior.budget`, so the numbers do not depend
    on the machine's load); ``one_mode`` the one-mode analysis (:class:`OneMode`): its least
    squares' (p, ω_d) screen the residual first, make K = 1 that analysis, and name the mode
    a split pair would be; its ``verdict`` (amplitude-dependent or misfit: any close pair
    there is explained) and ``law``: when the stage ends with one mode under such a verdict,
    a pair inside the fundamental's resolution cell that fits better
    (:func:`unresolved_pair_note`) is flagged.
    """
    from dampfit.inference import modes_close, modes_gate, modes_posterior, modes_select
    from dampfit.inference.modes import check_max_modes, check_mode_of_mass

    start = time.perf_counter()
    limit = check_max_modes(max_modes if n_modes is None else n_modes)
    check_mode_of_mass(mode_of_mass, limit)
    if not isinstance(mass, physics.Mass):
        mass = physics.Mass(mass)
    if one_mode is not None:
        one_mode = OneMode(*one_mode)
    verdict = None if one_mode is None else one_mode.verdict

    def done(k: int | None, evidence: dict, warnings=(), **kw) -> ModesStage:
        # against the components found (not analysed: one mode, as reported)
        check_mode_of_mass(mode_of_mass, evidence.get("n_components") or k or 1)
        if k == 1 and one_mode is not None and verdict in SPLIT_VERDICTS and \
                one_mode.law is not None:
            pair, note = unresolved_pair_note(one_mode.law, one_mode, verdict)
            if pair is not None:
                evidence["unresolved_pair"] = pair
                warnings = (*warnings, note)
        evidence.update(max_modes=limit, seconds=time.perf_counter() - start)
        return ModesStage(n_modes=k, evidence=jsonable(evidence), warnings=tuple(warnings),
                          seconds=time.perf_counter() - start, **kw)

    if limit == 1 and n_modes is None:
        return done(1, {"screen": None, "reason": "several modes not looked for (max modes 1)"})
    gate = None
    try:
        if one_mode is not None and n_modes is None:
            gate = modes_gate.screen(prep, one_mode[0], one_mode[1], band)
            if not gate.passed:
                return done(1, {"screen": gate.summary(), "reason": gate.reason})
        sel = modes_select.select(prep, max_modes=limit, band=band, n_modes=n_modes)
    except InputError as exc:
        why = f"several modes not analysed: {exc}"
        return done(None, {"screen": None if gate is None else gate.summary(), "reason": why},
                    (why,))
    evidence = {"screen": None if gate is None else gate.summary(), **sel.summary()}
    if sel.n_modes == 1 and one_mode is not None:
        evidence["reason"] = "one mode by evidence"
        return done(1, evidence, sel.warnings, selection=sel)
    single = None if one_mode is None or n_modes is not None else \
        one_mode_after_all(sel, one_mode[1] / (2 * math.pi), verdict)
    if single is not None:
        evidence.update(reason=single[0], **single[1])
        return done(1, evidence, [w for w in sel.warnings if "harmonic" not in w]
                    + [single[0]], selection=sel, seen=folded(sel, single[1]))
    dominant = partners = None
    if one_mode is not None:  # the fundamental the recording was released in: the mass's
        dominant = fundamental(sel, one_mode[1] / (2 * math.pi))
        partners = split_partners(sel, dominant, verdict)
    post = modes_posterior.sample(
        sel, mass=mass.value, mass_sd=mass.sd, seed=sampler.seed, min_ess=sampler.min_ess,
        max_steps=sampler.max_steps,
        mode_of_mass=mode_of_mass if mode_of_mass is not None or dominant is None
        else dominant + 1, budget=modes_posterior.budget(sel.n_modes))
    out = modes_posterior.modal_summary(sel, post, keep=dominant, split=partners or ())
    out["sampling"] = {"posterior_converged": post.converged, **post.sampling()}
    warns, split = list(out["warnings"]), []
    if dominant is not None:
        split = modes_close.split_pair(post.summary(), out["pairs"], dominant,
                                       amplitude_dependent=verdict in SPLIT_VERDICTS)
    k = sel.n_modes
    evidence.update(reason=(f"{k} component{'s' if k > 1 else ''} by evidence"
                            if n_modes is None else f"{n_modes} components fixed")
                    + f", {out['n_modes']} identified as modes", pairs=out["pairs"],
                    notes=out["notes"], sampling=post.sampling(), n_components=k)
    return done(out["n_modes"], evidence, warns + split, summary=jsonable(out), selection=sel,
                posterior=post, dominant=dominant, split=tuple(split),
                seen=tuple(jsonable(out["modes_seen"])))


def unresolved_pair_note(law, one_mode: tuple[float, float], verdict: str):
    """(summary.json's ``modes_evidence.unresolved_pair``, its warning) when two viscous
    modes inside the fundamental's resolution cell fit the one-mode samples better than the
    preferred damping law ``law`` = (FitData, LawFit)
    (:func:`dampfit.inference.modes_checks.unresolved_pair`), else (None, None)."""
    from dampfit.inference import modes_checks

    fd, fit = law
    res = np.asarray(fit.residuals, dtype=float)
    got = modes_checks.unresolved_pair(fd.tau, fd.y, fd.drift, float(one_mode[0]),
                                       float(one_mode[1]), float(res @ res), fit.k)
    if got is None:
        return None, None
    f1, f2 = got["f_hz"]
    return {**got, "law": fit.model}, (
        f"the {verdict} verdict may be two modes the record does not resolve: two viscous "
        f"modes at {f1:.5g} and {f2:.5g} Hz ({got['separation_cells']:.2g} resolution cells "
        f"apart) fit better than the {fit.model} law (BIC {got['delta_bic']:.3g}); an "
        "unresolved pair, not a single amplitude-dependent mode, until a longer or "
        "less damped record separates them")


def fundamental(sel, f1: float) -> int:
    """0-based component of the selection nearest (in its least-squares damped frequency)
    to the one-mode analysis's frequency ``f1`` [Hz]: the fundamental the recording was
    released in, the mass's mode unless the user names another."""
    f = np.asarray(sel.chosen.fit.f_d, dtype=float)
    return int(np.argmin(np.abs(f - f1)))


def split_partners(sel, d: int, verdict: str | None) -> list[int]:
    """0-based components that are the fundamental ``d`` split in pieces: closer than
    :data:`~dampfit.inference.modes_close.SPLIT_HALF_POWER` half-power bandwidths (C1, the
    least squares' pairs) to it when the one-mode ``verdict`` says its damping changes with
    amplitude (or misfit); under any verdict, those within that or
    :data:`~dampfit.inference.modes_checks.DRIFT_CELLS` resolution cells that one mode with a
    drifting frequency fits as well (:func:`drift_partners`)."""
    from dampfit.inference import modes_close

    if verdict not in SPLIT_VERDICTS:
        return sorted(drift_partners(sel, d))
    out = []
    for row in modes_close.selection_pairs(sel)[0]:
        i, j = (m - 1 for m in row["modes"])
        if d in (i, j) and row["separation_half_power"] < modes_close.SPLIT_HALF_POWER:
            out.append(j if i == d else i)
    return out


def drift_partners(sel, d: int) -> dict[int, dict]:
    """{0-based partner: chirp} of the components near the fundamental ``d`` (within
    :data:`~dampfit.inference.modes_close.SPLIT_HALF_POWER` half-power bandwidths or
    :data:`~dampfit.inference.modes_checks.DRIFT_CELLS` resolution cells) that, with it,
    fit no better than one mode whose frequency drifts linearly
    (:func:`dampfit.inference.modes_checks.drift_split`): a drifting fundamental split in
    two, or two modes closer than the record resolves; neither is a mode of its own."""
    from dampfit.inference import modes_checks, modes_close

    fit, fd = sel.chosen.fit, sel.fit_data
    out = {}
    for row in modes_close.selection_pairs(sel)[0]:
        i, j = (m - 1 for m in row["modes"])
        near = row["separation_half_power"] < modes_close.SPLIT_HALF_POWER or \
            row["separation_resolution"] < modes_checks.DRIFT_CELLS
        if d not in (i, j) or not near:
            continue
        chirp = modes_checks.drift_split(fd.tau, fd.y, fd.drift, fit.p, fit.omega_d, i, j)
        if chirp is not None:
            out[j if i == d else i] = chirp
    return out


def one_mode_after_all(sel, f1: float, verdict: str | None) -> tuple[str, dict] | None:
    """(reason, evidence entries) when every component the evidence chose but one is not a
    mode of its own, else None (they stay modes; a harmonic or a split pair beside two
    genuine modes is a warning).

    Not modes: **harmonics** — at a whole multiple of a stronger component's damped
    frequency within one resolution cell 1/T
    (:func:`dampfit.inference.modes_select.harmonic_components`; a pendulum's large swing
    puts its 3rd harmonic in the acceleration); and, when the one-mode ``verdict`` says the
    damping changes with amplitude (or misfit), **split partners** — components closer than
    :data:`~dampfit.inference.modes_close.SPLIT_HALF_POWER` half-power bandwidths (C1) to the
    one at the one-mode frequency ``f1`` [Hz]: a sum of viscous modes reproduces a
    non-exponential envelope by beating close partners or with broad components overlapping
    the peak (the real 30 cm cantilever run 21-08-55, paper/modes.md). Decided on the
    least-squares values (their pairs, :func:`~dampfit.inference.modes_close.selection_pairs`),
    before any modal posterior runs."""
    from dampfit.inference import modes_close, modes_select

    fit = sel.chosen.fit
    if sel.n_modes < 2:
        return None
    f = fit.f_d
    harm = [h for h in modes_select.harmonic_components(fit, sel.span)
            if h["cells"] < modes_select.HARMONIC_CELLS]
    split = split_partners(sel, fundamental(sel, f1), verdict)
    gone = {h["index"] for h in harm} | set(split)
    if sel.n_modes - len(gone) != 1:
        return None
    parts, entries = [], {}
    if harm:
        parts.append("harmonics of a nonlinear oscillation (a large swing, friction, a "
                     "stiffening spring): " + ", ".join(
                         f"{f[h['index']]:.5g} Hz = {h['multiple']} x {f[h['of']]:.5g} Hz"
                         for h in harm))
        entries["harmonics"] = [{"index": h["index"] + 1, "f_d_hz": float(f[h["index"]]),
                                 "multiple": h["multiple"],
                                 "of_hz": float(f[h["of"]]), "cells": h["cells"]} for h in harm]
    if split:
        why = (f"amplitude-dependent damping ({verdict})" if verdict in SPLIT_VERDICTS else
               "drifting frequency (one mode with a linear frequency drift fits as well) or "
               "an unresolved pair")
        parts.append(f"the one mode split by its {why}: "
                     + ", ".join(f"{f[j]:.5g} Hz" for j in split) + f" beside {f1:.5g} Hz, "
                     f"closer than {modes_close.SPLIT_HALF_POWER:g} half-power bandwidths")
        entries["split"] = [{"index": j + 1, "f_d_hz": float(f[j])} for j in split]
    n = len(gone)
    reason = (f"one mode: the evidence's other component{'s' if n > 1 else ''} "
              f"{'are' if n > 1 else 'is'} not {'modes' if n > 1 else 'a mode'} — "
              + "; ".join(parts))
    return reason, entries


def folded(sel, entries: dict) -> tuple[dict, ...]:
    """summary.json's ``modes_seen`` of the components :func:`one_mode_after_all` folded
    back into one mode (``entries`` its evidence entries), with the least squares' Laplace
    90 % intervals (no modal posterior ran): ``index`` (1-based component), ``f_n`` and
    ``zeta`` {"q50", "q05", "q95", "unit"}, ``kind`` ("harmonic" or "split"), ``reason``."""
    try:
        est = sel.chosen.laplace_intervals()
    except (AttributeError, ValueError):
        est = None
    out = []
    for kind, rows in (("harmonic", entries.get("harmonics", ())),
                       ("split", entries.get("split", ()))):
        for e in rows:
            i = e["index"] - 1
            why = (f"{e['f_d_hz']:.5g} Hz = {e['multiple']} x {e['of_hz']:.5g} Hz within "
                   "a resolution cell, decaying as fast as a harmonic: not a mode"
                   if kind == "harmonic" else
                   f"{e['f_d_hz']:.5g} Hz: the fundamental split by its amplitude-dependent "
                   "damping or drifting frequency, or an unresolved pair")
            out.append({"index": e["index"], "kind": kind, "reason": why,
                        "f_n": None if est is None else _interval(est[i]["f_n"], "Hz"),
                        "zeta": None if est is None else _interval(est[i]["zeta"], "1")})
    return tuple(jsonable(out))


def _interval(v, unit: str) -> dict:
    return {"q50": float(v[0]), "q05": float(v[1]), "q95": float(v[2]), "unit": unit,
            "source": "least squares (Laplace)"}


def modes_disagreement(modes: list[dict], dominant: int | None, ls) -> list[str]:
    """A warning (in a list; [] when they agree) that the modal posterior of the fundamental
    (0-based component ``dominant``) and the one-mode least squares ``ls`` (``p`` [1/s],
    ``omega_d`` [rad/s]) disagree: the one-mode ζ or f_n outside the modal 90 % interval.
    Stated, never resolved silently: the headline and the mass's c, k stay the one-mode
    analysis's (:func:`one_mode_values`)."""
    pos = next((n for n, r in enumerate(modes)
                if dominant is not None and r.get("index") == dominant + 1), None)
    if pos is None:
        return []
    row = modes[pos]
    q = physics.quantities(float(ls.p), float(ls.omega_d))
    out = []
    for name, value, unit in (("zeta", float(q["zeta"]), ""), ("f_n", float(q["f_n"]), " Hz")):
        iv = row.get(name) or {}
        lo, hi = iv.get("q05"), iv.get("q95")
        if isinstance(lo, float) and isinstance(hi, float) and not lo <= value <= hi:
            out.append(f"{name} {value:.4g}{unit} of the one-mode analysis, "
                       f"{iv['q50']:.4g} [{lo:.4g}, {hi:.4g}]{unit} of the modal one")
    if not out:
        return []
    return [f"the one-mode and the modal analyses disagree on the fundamental (mode "
            f"{dominant + 1}): " + "; ".join(out) + f". The headline, the damper and "
            f"modes[{pos}].c, k are the one-mode analysis's; the modal posterior's are "
            f"modes[{pos}].c_modal, k_modal"]


#: The quantities of the mass's mode taken from the one-mode analysis (``parameters``).
ONE_MODE_QUANTITIES = ("c", "k", "c_crit", "u0", "mass")


def one_mode_values(rows: list[dict], params: dict) -> list[dict]:
    """summary.json's ``modes`` with the mass's mode carrying the one-mode analysis's c, k,
    c_crit, u0 and mass (``params``: summary.json's ``parameters``) when it is the
    fundamental (``"fundamental": True``): the headline c equals that mode's c, and the
    deck, the report and summary.json name one mode with one set of values. The modal
    posterior's own values of that mode are kept as ``c_modal``, ``k_modal``."""
    out = []
    for row in rows:
        row = dict(row)
        if row.get("mass_mode") and row.get("fundamental"):
            for name in ONE_MODE_QUANTITIES:
                if name in row and name in ("c", "k"):
                    row[f"{name}_modal"] = row[name]
                if params.get(name) is not None:
                    row[name] = params[name]
            row["mass_values"] = "one-mode analysis (parameters)"
        out.append(row)
    return out
