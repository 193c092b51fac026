"""The model checks of a single-recording report: which damping law, and how well it fits.

:func:`model_checks` opens with the adequacy verdict (:data:`dampfit.damping.checks.VERDICTS`)
in plain words (:data:`VERDICT_WORDS`) and its reasons, then one short table of the damping
laws (weight, parameters with units, ζ_eq) and one of the fit checks per law, and the evidence
of an amplitude dependence; :func:`amplitude` is the amplitude-dependence section with the
ζ(A) and f(A) figure (``amplitude.png``, :mod:`dampfit.output.figures`).
"""

from __future__ import annotations

from pathlib import Path

from dampfit.output.document import Block, read_png
from dampfit.output.report.reproduce import not_computed
from dampfit.output.report.values import (UNITS, figure, finite, generic, get, isnum, label_of,
                                          number, spec, with_interval)


#: The adequacy verdicts (:data:`dampfit.damping.checks.VERDICTS`) in plain words — the rule
#: of :func:`dampfit.damping.checks.adequacy`, which needs evidence both ways; ``{c}`` is c, or
#: ζ without a mass (no c was computed).
VERDICT_WORDS = {
    "adequate": "one viscous damping ({c}) describes the whole decay: the data rule out "
                "a change of ζ by 1.25× or more over the recorded amplitudes, and the residual "
                "is white at f₀.",
    "amplitude-dependent": "damping depends on amplitude — the windowed ζ(A) slope shows it, or "
                           "decisive evidence for a damping law that the windows confirm; the "
                           "{law} law describes it best, and it is the recommended damper at "
                           "the top. A single viscous {c} holds at one amplitude only.",
    "amplitude-dependent-nolaw": "damping depends on amplitude (the windowed ζ(A) slope shows "
                                 "it), but no damping law describes it reliably (each sits on a "
                                 "prior bound or is ill-conditioned). A single viscous {c} holds "
                                 "at one amplitude only.",
    "misfit": "the free-decay model does not describe this waveform and no damping law explains "
              "it, so {c} and its interval are not trustworthy; check the window and the set-up.",
    "inconclusive": "the recording cannot tell whether one viscous {c} is adequate: either it "
                    "could not have seen a dependence (the amplitudes span too little, or the "
                    "residual is structured at f₀), or the evidence of one is weak, or no decay "
                    "was measured — the first reason below says which.",
}
#: The adequacy criteria (``model_checks.adequacy.criteria``) in plain words.
CRITERIA_WORDS = {
    "slope_decisive": "the windowed ζ(A) slope is decisive", "slope_weak": "the windowed slope is weak evidence",
    "slope_null": "the windowed slope rules out a change of ζ that matters",
    "dependence_bounded": "the data rule out a change of ζ that matters (windowed slope or "
                          "power law)",
    "white_at_f0": "the viscous residual is white at f₀",
    "law_evidence": "the evidence favours a non-viscous law",
    "law_usable": "that law can carry a verdict (not on a prior bound, not ill-conditioned)",
    "law_decisive": "the evidence for a non-viscous law is decisive and the windows confirm it",
    "frequency_drift": "the frequency drifts with amplitude",
    "viscous_misfit": "the viscous fit is a misfit", "best_law_misfit": "the best law is a misfit",
    "pipeline_misfit": "the constant-frequency fit is a misfit",
    "phase_drift": "the frequency drifts along the decay", "few_cycles": "too few cycles",
    "no_decay": "no decay measured (forced or self-sustained vibration?)",
}
#: Per-unit-mass forms of the four built-in laws' coefficients, shown after the law's own
#: coefficients (which each law names in summary.json: ``damping_models.models.<law>.
#: coefficients``, :attr:`dampfit.model.laws.Law.coefficients`); a registered law's are
#: ``NAME/m``.
_PER_MASS = ("mu_c", "beta", "gamma")
_MC_KNOWN = ("warning", "verdict", "verdict_reasons", "verdict_law", "preferred_model",
             "chosen_model", "requested_model", "single_viscous_c_adequate", "residual_whiteness",
             "amplitude_dependence", "adequacy", "decay")


def _laws(s: dict) -> list[Block]:
    """One short table of the damping laws: weight, parameters with units, ζ_eq at a_ref."""
    dm = s.get("damping_models")
    if not isinstance(dm, dict) or not isinstance(dm.get("models"), dict):
        return []
    comp = dm.get("comparison") if isinstance(dm.get("comparison"), list) else []
    weights = {r["model"]: r for r in comp if isinstance(r, dict) and isinstance(r.get("model"), str)}
    chosen, preferred = dm.get("chosen_model"), dm.get("preferred_model")
    aref = dm.get("reference_amplitude_m")
    rows = []
    for law, m in dm["models"].items():
        if not isinstance(m, dict):
            continue
        par = m.get("parameters") if isinstance(m.get("parameters"), dict) else {}
        own = _coefficients(m)
        keys = list(own) + [k for k in _PER_MASS + tuple(f"{n}/m" for n in own) if k not in own]
        shown = [(k, par[k]) for k in keys if isinstance(par.get(k), dict)]
        if "k" not in par:  # no mass: the viscous part is the decay rate p₀ (ζ for viscous)
            lead = "zeta" if law == "viscous" else "p0"
            shown = ([(lead, par[lead])] if isinstance(par.get(lead), dict) else []) + shown
        text = "; ".join(f"{own.get(k) or _SYMBOL.get(k, k)} = "
                         f"{with_interval(q, q.get('unit') or '')}"
                         for k, q in shown) or "—"
        w = get(weights, law, "weight")
        post = m.get("posterior") if isinstance(m.get("posterior"), dict) else {}
        note = [x for x, on in (("chosen", law == chosen), ("preferred", law == preferred
                                                           and law != chosen)) if on]
        if post.get("ill_conditioned"):
            why = str(post.get("ill_conditioned_reason") or "")
            for k in par:  # the reason names parameters by their keys
                why = why.replace(k, label_of(k)) if "_" in k else why
            note.append("ill-conditioned" + (f": {why}" if why else "")
                        + " (Laplace approximation, intervals approximate)")
        if post.get("converged") is False:
            note.append("posterior NOT converged")
        rows.append([law, spec(w, ".3g") if finite(w) else "—", text,
                     with_interval(par.get("zeta_eq_ref")), "; ".join(note) or "—"])
    if not rows:
        return []
    where = f" at the reference amplitude {number(aref, 3)} m" if finite(aref) else ""
    return [("h3", "Damping laws compared"),
            ("table", ["law", "weight [1]", "parameters (median [90 %])", f"ζ_eq{where} [1]",
                       "note"], rows),
            ("p", ["Weight: posterior probability of each law from its log evidence; parameters "
                   "with their units; ζ_eq the energy-equivalent viscous damping ratio."])]


def _c_or_zeta(s: dict) -> str:
    """"c", or "ζ" when no mass was given (then no c was computed)."""
    return "c" if isnum(get(s, "mass", "value")) else "ζ"


def _coefficients(entry: dict) -> dict[str, str]:
    """The law's own coefficients (name → symbol) as its summary entry names them; the four
    built-in laws' for an older summary.json without them."""
    listed = entry.get("coefficients")
    if isinstance(listed, list):
        out = {c["name"]: c.get("symbol") if isinstance(c.get("symbol"), str) else c["name"]
               for c in listed if isinstance(c, dict) and isinstance(c.get("name"), str)}
        if out:
            return out
    return {k: _SYMBOL[k] for k in ("c", "F_c", "c2", "c_alpha", "alpha")}


_SYMBOL = {"p0": "p₀", "c": "c", "F_c": "F_c", "mu_c": "μ_c", "c2": "c₂", "beta": "β", "c_alpha": "c_α",
           "gamma": "γ", "alpha": "α", "zeta": "ζ"}


def _fit_checks(mc: dict) -> list[Block]:
    """Per law: Ljung–Box p at f₀, r, r / r_white, residual size — one table."""
    white = mc.get("residual_whiteness") if isinstance(mc.get("residual_whiteness"), dict) else {}
    lb = white.get("ljung_box_at_f0") if isinstance(white.get("ljung_box_at_f0"), dict) else {}
    fc = get(mc, "adequacy", "fit_checks")
    fc = fc if isinstance(fc, dict) else {}
    names = list(dict.fromkeys(list(fc) + list(lb)))
    rows = []
    for law in names:
        f = fc.get(law) if isinstance(fc.get(law), dict) else {}
        b = lb.get(law) if isinstance(lb.get(law), dict) else {}
        p = f.get("ljung_box_p", b.get("p_value"))
        frac = f.get("resid_fraction")
        rex = f.get("r_excess")
        rows.append([label_of(law).replace("viscous pipeline", "constant-frequency viscous"),
                     number(p, 2), number(b.get("n_cycles")), number(f.get("r_raw"), 3),
                     ("< 1 (no excess)" if finite(rex) and rex < 1 else number(rex, 3)),
                     number(100 * frac, 3) if finite(frac) else "—", number(f.get("noise_excess"), 3)])
    if not rows:
        return []
    return [("h3", "Fit checks per law"),
            ("table", ["fit", "Ljung–Box p at f₀", "cycles", "r", "r / r for white noise",
                       "residual [% of signal]", "residual / sensor noise"], rows),
            ("p", ["A small Ljung–Box p means the residual, demodulated at f₀ and averaged per "
                   "cycle, is structured: the envelope (damping law) leaves misfit; one viscous "
                   "c is called adequate only with p ≥ 0.01 for the viscous fit. r is the "
                   "Whittle factor of that fit's residuals (see “Noise model”). r / r for white "
                   "noise below 1 means less residual power near f₀ than white sensor noise "
                   "would leave (noise coloured away from f₀): it is no evidence either way, "
                   "and the likelihood then uses the white-noise value; only values above 3 "
                   "count against a fit."])]


def _amplitude_evidence(mc: dict) -> list[Block]:
    amp = mc.get("amplitude_dependence") if isinstance(mc.get("amplitude_dependence"), dict) else {}
    rows = []
    if isnum(amp.get("p_viscous")):
        rows.append(["P(one viscous c | data)", number(amp["p_viscous"], 2),
                     "posterior probability of the viscous law among all laws"])
    if isnum(amp.get("ln_bayes_factor_nonlinear_vs_viscous")):
        rows.append(["ln Bayes factor, non-viscous vs viscous",
                     number(amp["ln_bayes_factor_nonlinear_vs_viscous"], 3), "> 0 favours a non-viscous law"])
    ws = amp.get("window_slope")
    if isinstance(ws, dict) and finite(ws.get("s")):
        lo, hi = ws.get("s_q05"), ws.get("s_q95")
        rows.append(["windowed slope d ln p / d ln a", f"{ws['s']:.2g} [{number(lo, 2)}, {number(hi, 2)}]",
                     f"from {number(ws.get('n_windows'))} independent windows; 0 for one viscous c"])
    sl = amp.get("slope_ln_p_vs_ln_amplitude")
    if isinstance(sl, dict) and finite(sl.get("q50")):
        rows.append(["law slope d ln p / d ln a", with_interval(sl), number(sl.get("source"))])
    if finite(amp.get("amplitude_start_m")) and finite(amp.get("amplitude_end_m")):
        rows.append(["displacement amplitude", f"{number(amp['amplitude_start_m'], 3)} → "
                     f"{number(amp['amplitude_end_m'], 3)} m", "start → end of the window"])
    za = amp.get("zeta_at_start_and_end")
    if isinstance(za, dict):
        for k, what in (("zeta_eq_start", "ζ_eq at the start"), ("zeta_eq_end", "ζ_eq at the end")):
            if isinstance(za.get(k), dict):
                rows.append([what, with_interval(za[k]), "chosen law, posterior median [90 %]"])
    known = ("detected", "criterion", "p_viscous", "ln_bayes_factor_nonlinear_vs_viscous",
             "window_slope", "slope_ln_p_vs_ln_amplitude", "amplitude_start_m", "amplitude_end_m",
             "zeta_at_start_and_end", "evidence_detected")
    rest = {k: v for k, v in amp.items() if k not in known}
    out: list[Block] = []
    if rows or rest:
        out.append(("h3", "Amplitude dependence of the decay rate"))
    if rows:
        out.append(("table", ["evidence", "value", "meaning"], rows))
    return out + (generic(rest) if rest else [])


def _c_equivalent(s: dict) -> list[Block]:
    ce = s.get("c_equivalent")
    why = get(s, "missing", "c_equivalent")
    if ce is None and isinstance(why, str) and why:
        return [("p", [("b", "Equivalent viscous damping not given: "), why, "."])]
    if not isinstance(ce, dict):
        return []
    items = []
    for k, unit in (("c", UNITS["c"]), ("zeta", UNITS["zeta"])):
        if isinstance(ce.get(k), dict):
            items.append(f"{'c_eq' if k == 'c' else 'ζ_eq'} = "
                         f"{with_interval(ce[k], ce[k].get('unit') or unit)}")
    if not items:
        return []
    where = f" at {number(ce.get('amplitude_m'), 3)} m displacement amplitude" \
        if finite(ce.get("amplitude_m")) else ""
    out: list[Block] = [("p", [("b", "Equivalent viscous damping"),
                               f" of the {number(ce.get('model'))} law{where}: " + ", ".join(items)
                               + " (median [90 %]); use it only near that amplitude."])]
    if ce.get("extrapolated") is True:
        rng = ce.get("recorded_amplitude_range_m")
        span = (f" {number(rng[0], 3)}–{number(rng[1], 3)} m" if isinstance(rng, list)
                and len(rng) == 2 else "")
        out.append(("p", [("b", "Extrapolated: "), "that amplitude is outside the recorded "
                          f"displacement amplitudes{span}; the law is used beyond the data."]))
    return out


def model_checks(s: dict, directory: Path) -> list[Block]:
    """The "Model checks" section: the verdict in plain words and its reasons, the decay and
    the criteria that hold, the equivalent viscous c, the damping laws, the fit checks and the
    evidence of an amplitude dependence; any entry not known here generically."""
    mc = s.get("model_checks")
    if not isinstance(mc, dict):
        return not_computed("model_checks", s, directory)
    out: list[Block] = []
    verdict = mc.get("verdict")
    if verdict is not None:
        law = mc.get("verdict_law") or ("non-viscous" if "verdict_law" in mc
                                        else mc.get("preferred_model") or "non-viscous")
        key = ("amplitude-dependent-nolaw" if verdict == "amplitude-dependent"
               and "verdict_law" in mc and not mc.get("verdict_law") else verdict)
        words = VERDICT_WORDS.get(key, "") if isinstance(key, str) else ""
        out.append(("p", [("b", f"Verdict: {number(verdict)}")]
                    + ([" — " + words.format(law=number(law), c=_c_or_zeta(s))] if words
                       else [])))
        reasons = mc.get("verdict_reasons")
        if isinstance(reasons, list) and reasons:
            out += [("p", ["Why:"]), ("ul", [[number(r)] for r in reasons])]
    decay = mc.get("decay")
    if isinstance(decay, dict) and finite(decay.get("z")):
        out.append(("p", [f"Decay measured: {'yes' if decay.get('resolved') else 'NO'} "
                          f"(likelihood-ratio z = {number(decay['z'], 3)} against no decay; "
                          "above 1.64 the 90 % interval of p excludes 0)."]))
    crit = get(mc, "adequacy", "criteria")
    if isinstance(crit, dict):
        held = [CRITERIA_WORDS.get(k, label_of(k)) for k, v in crit.items() if v is True]
        out.append(("p", ["Criteria that hold: " + ("; ".join(held) if held else "none") + "."]))
    if any(mc.get(k) is not None for k in ("requested_model", "preferred_model", "chosen_model")):
        parts = [f"{what}: {number(mc[k])}" for k, what in (
            ("requested_model", "requested"), ("preferred_model", "preferred by the evidence"),
            ("chosen_model", "reported")) if mc.get(k) is not None]
        out.append(("p", ["Damping law — " + "; ".join(parts) + "."]))
    if mc.get("warning"):
        out.append(("p", ["The model-check warning is in the box at the top."]))
    out += _c_equivalent(s) + _laws(s) + _fit_checks(mc) + _amplitude_evidence(mc)
    white = mc.get("residual_whiteness")
    if isinstance(white, dict):
        rest = {k: v for k, v in white.items() if k not in (
            "psd_ratio_common", "psd_ratio_by_model", "psd_ratio_viscous_pipeline",
            "ljung_box_at_f0", "note")}
        if rest:
            out += [("h3", "Residual whiteness")] + generic(rest)
    elif "residual_whiteness" in mc:
        out += [("h3", "Residual whiteness"), ("p", ["not computed"])]
    rest = {k: v for k, v in mc.items() if k not in _MC_KNOWN}
    return out + ([("h3", "Other model checks")] + generic(rest) if rest else [])


def amplitude(s: dict, directory: Path) -> list[Block]:
    """The "Amplitude dependence" section: the windowed fits, the backbone f(A) and the ζ(A)
    and f(A) figure (``amplitude.png``)."""
    curve = s.get("amplitude_curve")
    if not isinstance(curve, dict):
        if read_png(directory, "amplitude"):
            return [figure("amplitude")]
        return not_computed("amplitude_curve", s, directory)
    wins = curve.get("windows") if isinstance(curve.get("windows"), list) else []
    text = []
    if wins:
        text.append(f"{len(wins)} windowed viscous fits of {number(curve.get('window_cycles'), 3)} "
                    "cycles each (50 % overlap), each giving ζ and the damped frequency at its "
                    "displacement amplitude; the values are in summary.json (amplitude curve).")
    if finite(curve.get("reference_amplitude_m")):
        text.append(f"Reference amplitude of the equivalent c: "
                    f"{number(curve['reference_amplitude_m'], 3)} m.")
    bb = curve.get("backbone") if isinstance(curve.get("backbone"), dict) else {}
    ft = bb.get("frequency_trend") or get(s, "model_checks", "adequacy", "frequency_trend")
    if isinstance(ft, dict) and finite(ft.get("rel_change")) and finite(ft.get("rel_change_sd")):
        text.append(f"Backbone f(A): the damped frequency changes {100 * ft['rel_change']:+.2g} % "
                    f"(± {100 * ft['rel_change_sd']:.2g} %) from the smallest to the largest "
                    "amplitude (0 for a linear oscillator; < 0 softening, > 0 hardening).")
    if isnum(bb.get("phase_terms")) and bb["phase_terms"] > 0:
        text.append(f"The viscous law follows that drift with {bb['phase_terms']} Legendre phase "
                    "terms, so its p, ζ and c are not biased by it.")
    out: list[Block] = [("p", [" ".join(text)])] if text else []
    out.append(figure("amplitude"))
    rest_bb = {k: v for k, v in bb.items() if k not in ("frequency_trend", "phase_terms", "note")}
    if rest_bb:
        out += [("h4", "Backbone")] + generic(rest_bb)
    known = ("window_cycles", "windows", "slope", "amplitude_grid_m", "models", "band",
             "preferred_model", "chosen_model", "mass_kg", "reference_amplitude_m", "note",
             "backbone")
    rest = {k: v for k, v in curve.items() if k not in known}
    return out + (generic(rest) if rest else [])
