"""Renderings of the plain-data summary (``Analysis.summary()``): text for the terminal.

Only the summary dict is read here, so anything that has a ``summary.json`` can be rendered
again without re-running the analysis.

Honest digits: a value printed with its 90 % interval gets its digits from the interval's
width — enough decimals that the width shows two significant digits, so a narrow interval is
never printed as ``1.72 [1.72, 1.72]`` and a wide one does not pretend to six digits: the one
formatter :mod:`dampfit.output.format`, which the reports use too (a least-squares value gets
its posterior's digits, a baseline those of its own expected spread). Every quantity a line
names is printed with its value (ζ_eq of a non-viscous law too), a baseline that rests on too
few cycles or disagrees with the posterior beyond its expected spread is marked as such, and a
mass without a standard deviation says so instead of printing ``± 0``.

The campaign's table is :mod:`dampfit.output.text_campaign`.
"""

from __future__ import annotations

import html
from typing import Any

from dampfit.output import damper as damper_rows
from dampfit.output.format import baseline, estimate, formatted, interval, with_interval
from dampfit.physics import UNITS

#: Row label of each posterior quantity: name and unit (:data:`dampfit.physics.UNITS`).
_LABELS = {name: f"{name:6s} [{UNITS[name]}]"
           for name in ("c", "k", "u0", "zeta", "f_n", "p", "delta")}


def _baseline_mark(b: dict[str, Any]) -> str:
    """The caveat printed after a baseline: too little support, or disagreement."""
    marks = []
    if b.get("supported") is False:
        # every reason the baseline gives (estimators.baselines: too few cycles, a decay
        # within the noise, an end below the noise); the cycle count in short form
        why = b.get("support_reason")
        reasons = [r.strip() for r in why.split(";") if r.strip()] if isinstance(why, str) else []
        used, win = b.get("n_cycles_used"), b.get("n_cycles_window")
        if isinstance(used, (int, float)) and isinstance(win, (int, float)) and (
                not reasons or any(r.startswith("rests on only") for r in reasons)):
            whole = abs(used - round(used)) < 1e-9  # log decrement: whole cycles
            of = f"{win:.0f}" if whole or win >= 10 else f"{win:.1f}"
            rest = [r for r in reasons if not r.startswith("rests on only")]
            marks.append(f"only {_cycles(used)} of {of} cycles — not reliable"
                         + "".join(f"; {r}" for r in rest))
        else:
            marks.append("not reliable" + (": " + "; ".join(reasons) if reasons else ""))
    if b.get("agrees_with_posterior") is False:
        marks.append("disagrees with the posterior beyond its expected spread")
    return "".join(f" ({m})" for m in marks)


def _cycles(n: float) -> str:
    return f"{n:.0f}" if abs(n - round(n)) < 1e-9 or n >= 10 else f"{n:.1f}"


def _law_state(s: dict[str, Any], law: str) -> str:
    """" (…)" when the law's posterior is not a converged emcee run, else ""."""
    models = (s.get("damping_models") or {}).get("models") or {}
    post = (models.get(law) or {}).get("posterior") or {}
    if post.get("ill_conditioned"):
        return " (ill-conditioned: Laplace approximation, intervals approximate)"
    if post.get("method") == "emcee" and post.get("converged") is False:
        return f" (posterior NOT converged: {post.get('stop_reason') or 'see warnings'})"
    return ""


#: A frequency change along the decay [1] below this is not printed as a backbone line.
BACKBONE_PRINT = 0.002


def _backbone_lines(s: dict) -> list[str]:
    """The backbone f(A) and the drift-followed viscous estimate, when the frequency drifts.

    Printed when the windowed damped frequency changes by more than ``BACKBONE_PRINT`` from
    the smallest to the largest amplitude with a 90 % interval that excludes no change: then
    a constant-frequency model mistakes phase error for damping, and the viscous law with
    frequency-drift phase terms (``damping_models.models.viscous``) is the estimate to read.
    """
    curve = s.get("amplitude_curve") or {}
    trend = (curve.get("backbone") or {}).get("frequency_trend")
    if not isinstance(trend, dict) or trend.get("rel_change") is None:
        return []
    rel, sd = trend["rel_change"], trend.get("rel_change_sd") or 0.0
    if abs(rel) < BACKBONE_PRINT or abs(rel) < 1.645 * sd:
        return []
    kind = "softening" if rel < 0 else "hardening"
    out = [f"  backbone        f_d changes {100 * rel:+.2f} % [{100 * (rel - 1.645 * sd):+.2f}, "
           f"{100 * (rel + 1.645 * sd):+.2f}] from the smallest to the largest amplitude ({kind})"]
    visc = (((s.get("damping_models") or {}).get("models") or {}).get("viscous") or {})
    params = visc.get("parameters") or {}
    parts = [f"{name} = {with_interval(params[name])}{unit}"
             for name, unit in (("zeta", ""), ("c", " " + UNITS["c"])) if isinstance(params.get(name), dict)
             and params[name].get("q50") is not None]
    if parts:
        out.append("  drift followed (viscous, frequency drift modelled)  " + ", ".join(parts))
    return out


def damper_lines(s: dict[str, Any]) -> list[str]:
    """The recommended-damper block (:mod:`dampfit.output.damper`), first of the results; []
    for a summary without one (an older folder)."""
    d = s.get("damper")
    if not isinstance(d, dict):
        return []
    return [f"  {damper_rows.title(d)}"] + [f"    {label:17s} {text}"
                                           for label, text in damper_rows.rows(d)]


def text(s: dict[str, Any]) -> str:
    """A readable multi-line table of a summary dict: the recommended damper first, then the
    other estimates, each named for what it is."""
    lead = damper_lines(s)
    if lead:
        lead += ["", "  other estimates (not the recommendation; each named for what it is)"]
    lines = (_head_lines(s) + [""] + lead + _posterior_lines(s) + [""]
             + _estimate_lines(s))
    nm = s["noise_model"]
    lines.append(
        f"  noise           sigma = {nm['sigma']:.3g} m/s^2 per sample at {nm['sample_rate_hz']:.4g} Hz, "
        f"spectral factor r = {nm['psd_ratio_at_f0']:.3g}"
    )
    if isinstance(s.get("model_checks"), dict):
        lines.append(_damping_law_line(s))
        lines.extend(_backbone_lines(s))
    lines.extend(_modes_lines(s))
    d = s["diagnostics"]
    state = "yes" if d["converged"] else "NO"
    lines.append(
        f"  converged       {state} (max R-hat {formatted(d['max_r_hat'], '.4f')}, min bulk ESS "
        f"{formatted(d['min_ess_bulk'], '.0f')}, {d['n_steps']} steps x {d['n_walkers']} walkers)"
    )
    if d["warnings"]:
        lines.append("")
        lines += [f"  WARNING: {w}" for w in d["warnings"]]
    lines.extend(_assumption_lines(s))
    return "\n".join(lines)


#: Rows of each mode's block (:func:`_modes_lines`): key, label; c and k for the mass's mode.
_MODE_ROWS = (("f_n", "f_n    [Hz]"), ("zeta", "zeta   [1]"), ("eta", "eta    [1]"),
              ("delta", "Lambda [1]"), ("Q", "Q      [1]"),
              ("c", "c      [N s/m] (this mode's viscous c)"), ("k", "k      [N/m]"))


def _modes_lines(s: dict[str, Any]) -> list[str]:
    """One block per mode when the recording has several (summary's ``modes``): f_n, ζ,
    η = 2ζ, Λ (log decrement), Q with 90 % intervals; c and k only for the mass's mode;
    then P(K) and the Rayleigh statement. Nothing for one mode (it is the table above)."""
    modes = s.get("modes")
    if not isinstance(modes, list) or s.get("n_modes") in (None, 1) or len(modes) < 2:
        return _seen_lines(s)
    ev = s.get("modes_evidence") if isinstance(s.get("modes_evidence"), dict) else {}
    probs = [f"P(K = {r.get('n_modes')}) = {r.get('probability'):.2g}"
             for r in ev.get("evidence") or [] if isinstance(r, dict)
             and isinstance(r.get("probability"), (int, float)) and r["probability"] >= 0.001]
    lines = ["", f"  {len(modes)} modes" + (f" ({', '.join(probs)})" if probs else "")]
    for i, mode in enumerate(modes):
        if not isinstance(mode, dict):
            continue
        mark = "  (the mass's mode)" if mode.get("mass_mode") is True else ""
        lines.append(f"  mode {_index(mode, i)}{mark}")
        for key, label in _MODE_ROWS:
            q = mode.get(key)
            if not isinstance(q, dict) or not all(isinstance(q.get(x), (int, float))
                                                  for x in ("q05", "q50", "q95")):
                continue
            med, lo, hi = interval(q["q50"], q["q05"], q["q95"])
            label, _, what = label.partition(" (")
            lines.append(f"    {label:13s} {med:>12s}   [{lo:>11s}, {hi:>11s}]"
                         f"   R-hat {formatted(q.get('r_hat'), '.4f')}"
                         + (f"   ({what}" if what else ""))
    ray = s.get("rayleigh")
    if isinstance(ray, dict) and isinstance(ray.get("statement"), str):
        lines.append(f"  Rayleigh        alpha = {with_interval(ray.get('alpha') or {})} 1/s, "
                     f"beta = {with_interval(ray.get('beta') or {})} s; {ray['statement']}")
    return lines + _seen_lines(s)


def _index(mode: dict, i: int) -> str:
    """A mode's number: its component ``index`` (the numbering --mode-of-mass and the decks
    use), else its place."""
    n = mode.get("index")
    return str(n) if isinstance(n, int) and not isinstance(n, bool) else str(i + 1)


def _seen_lines(s: dict[str, Any]) -> list[str]:
    """The components seen but not modes (summary's ``modes_seen``): f_n and why; no ζ row."""
    seen = [e for e in s.get("modes_seen") or [] if isinstance(e, dict)] \
        if isinstance(s.get("modes_seen"), list) else []
    if not seen:
        return []
    lines = ["", "  seen, not modes (no zeta, no Rayleigh, no deck)"]
    for e in seen:
        f = (e.get("f_n") or {}).get("q50") if isinstance(e.get("f_n"), dict) else None
        at = f"{f:.5g} Hz" if isinstance(f, (int, float)) else "?"
        lines.append(f"    {at:>12s}  {e.get('kind')}: {e.get('reason')}")
    return lines


def _rate(inp: dict[str, Any]) -> str:
    """The sample rate [Hz] of ``input``, and the rate analysed if it was decimated."""
    dec = inp.get("decimated")
    if isinstance(dec, dict) and isinstance(dec.get("from_hz"), (int, float)):
        return f"{dec['from_hz']:.4g} Hz, decimated to {inp['sample_rate_hz']:.4g} Hz"
    return f"{inp['sample_rate_hz']:.4g} Hz"


def _head_lines(s: dict[str, Any]) -> list[str]:
    """Input, window, band and mass."""
    inp, win, band = s["input"], s["window"], s["band"]
    lines = [
        f"dampfit {s['dampfit_version']} — {inp['path'] or '(array)'}",
        f"  {inp['format']}, {inp['n_samples']} samples at {_rate(inp)} "
        f"({inp['duration_s']:.4g} s), axis {inp['axis']}",
        f"  free-decay window {win['start_s']:.3f}–{win['end_s']:.3f} s "
        f"({win['n_cycles']:.1f} cycles){'' if win['auto'] else ' (given)'}, "
        f"band {band['low_hz']:.4g}–{band['high_hz']:.4g} Hz, f0 = {s['dominant_frequency_hz']:.5g} Hz",
    ]
    end = win.get("end_reason")
    if win["auto"] and isinstance(end, str) and end:  # why (signal.window.END_REASONS)
        lines.append(f"  window ends     {end}")
    m = s["mass"]
    if m["value"] is None:
        lines.append("  mass not given: c and k cannot be identified (give --mass KG)")
    elif m.get("sd"):
        lines.append(f"  mass {m['value']:.6g} ± {m['sd']:.3g} kg")
    else:
        lines.append(f"  mass {m['value']:.6g} kg (sd not given)")
    return lines


def _posterior_lines(s: dict[str, Any]) -> list[str]:
    """The posterior table: median, 90 % interval (honest digits), sd, R-hat, ESS."""
    lines = [f"  {damper_rows.other_label(s)}",
             f"  {'':15s} {'median':>12s}   {'90 % interval':^27s} {'sd':>10s} "
             f"{'R-hat':>7s} {'ESS':>6s}"]
    for name in ("c", "k", "u0", "zeta", "f_n", "p"):
        q = s["parameters"].get(name)
        if q is None:
            continue
        med, lo, hi = interval(q["q50"], q["q05"], q["q95"])
        lines.append(
            f"  {_LABELS[name]:15s} {med:>12s}   [{lo:>11s}, {hi:>11s}]"
            f" {formatted(q['sd'], '.3g'):>10s} {formatted(q['r_hat'], '.4f'):>7s}"
            f" {formatted(q['ess_bulk'], '.0f'):>6s}"
            + ("   reaches 0: no decay measured" if q.get("reaches_zero") is True else "")
        )
    return lines


def _estimate_lines(s: dict[str, Any]) -> list[str]:
    """Least squares (with the posterior's digits) and the baselines (with their own)."""
    ls = s["least_squares"]
    lines = ["  least squares (viscous)  " + ", ".join(
        f"{k} = {estimate(s, k, ls.get(k))}" for k in ("c", "k", "u0", "zeta", "f_n")
        if ls.get(k) is not None
    ) + ("" if ls["converged"] else "   (NOT converged)")]
    for key, label in (("log_decrement", "log decrement (seed paper baseline)"),
                       ("envelope_pipeline", "envelope (seed paper baseline)")):
        b = s["baselines"].get(key)
        if b is None:
            lines.append(f"  {label:15s} not computed")
            continue
        extra = f" over {b['n_cycles']} cycles" if b.get("n_cycles") else ""
        c = f"c = {baseline(b, 'c')}, " if b.get("c") is not None else ""  # no mass: no c
        lines.append(f"  {label:15s} {c}zeta = {baseline(b, 'zeta')}"
                     f"{extra}{_baseline_mark(b)}")
    return lines


def _damping_law_line(s: dict[str, Any]) -> str:
    """The damping-law verdict, and the equivalent viscous c (or why it is not given)."""
    mc = s["model_checks"]
    amp = mc.get("amplitude_dependence") or {}
    verdict = mc.get("verdict") or ("amplitude-dependent" if amp.get("detected") else "adequate")
    pv = f"P(one viscous c) = {formatted(amp.get('p_viscous'), '.2g')}"
    law = mc.get("verdict_law") or (mc.get("preferred_model") if "verdict_law" not in mc
                                    else None)
    reasons = mc.get("verdict_reasons")
    first = reasons[0] if isinstance(reasons, list) and reasons and isinstance(
        reasons[0], str) else None
    line = "  damping law     " + {
        "adequate": (f"viscous adequate ({first}; {pv})" if first and first.startswith(
            "no amplitude dependence") else f"viscous adequate (no amplitude dependence, {pv})"),
        "amplitude-dependent": (f"{law} preferred (amplitude-dependent, {pv})" if law else
                                f"amplitude-dependent; no damping law describes it reliably "
                                f"({pv})"),
        "misfit": f"MISFIT: no damping law describes this waveform ({pv}); see the warning",
        "inconclusive": (f"inconclusive: {first or 'the evidence is too weak either way'} "
                         f"({_evidence_words(s, amp.get('p_viscous'))})"),
    }.get(verdict, f"{verdict} ({pv})")
    d = s.get("damper")
    if isinstance(d, dict) and d.get("status") in ("recommended", "viscous-stands"):
        return line  # its linear equivalent at the design amplitude is in the damper block
    ceq = s.get("c_equivalent")
    why = (s.get("missing") or {}).get("c_equivalent") if isinstance(
        s.get("missing"), dict) else None
    if ceq is None and isinstance(why, str):
        line += f"\n  c_equivalent    not given: {why}"
    if isinstance(ceq, dict):
        extra = ""
        if ceq.get("extrapolated") is True:
            rng = ceq.get("recorded_amplitude_range_m")
            ok = isinstance(rng, list) and len(rng) == 2 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) for x in rng)
            extra = (f", EXTRAPOLATED beyond the recorded {formatted(rng[0], '.3g')}–"
                     f"{formatted(rng[1], '.3g')} m"
                     if ok else ", EXTRAPOLATED beyond the recorded amplitudes")
        where = (f"({ceq['model']} law at {formatted(ceq['amplitude_m'], '.3g')} m displacement "
                 f"amplitude{extra}){_law_state(s, ceq['model'])}")
        if isinstance(ceq.get("c"), dict) and ceq["c"].get("q50") is not None:
            line += f"\n  c_equivalent    {with_interval(ceq['c'])} {UNITS['c']} {where}"
            where = ""
        if isinstance(ceq.get("zeta"), dict) and ceq["zeta"].get("q50") is not None:
            line += f"\n  zeta_eq         {with_interval(ceq['zeta'])} {where}".rstrip()
    return line


def _evidence_words(s: dict[str, Any], p_viscous: Any) -> str:
    """What the laws' evidence alone says, without contradicting an open verdict: which way it
    leans and how strongly (P(one viscous c) against the most probable other law)."""
    rows = (s.get("damping_models") or {}).get("comparison")
    rows = [r for r in rows if isinstance(r, dict) and isinstance(r.get("weight"), (int, float))
            and r.get("model") != "viscous"] if isinstance(rows, list) else []
    other = max(rows, key=lambda r: r["weight"], default=None)
    if not isinstance(p_viscous, (int, float)):
        return "no law evidence"
    alt = (f"; most probable other law {other['model']}, P = {other['weight']:.2g}"
           if other is not None else "")
    lean = ("the laws' evidence alone leans to one viscous c" if p_viscous >= 0.5
            else "the laws' evidence alone is split")
    return f"{lean}: P(one viscous c) = {p_viscous:.2g}{alt}; not enough for a verdict"


def _rows(s: dict[str, Any]) -> list[tuple[str, str, str, str]]:
    """(quantity, median, 90 % interval, unit) of the headline quantities present in ``s``."""
    out = []
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    for name in ("c", "k", "u0", "zeta", "f_n"):
        q = params.get(name)
        if not isinstance(q, dict):
            continue
        med, lo, hi = interval(q.get("q50"), q.get("q05"), q.get("q95"))
        out.append((name, med, f"[{lo}, {hi}]", UNITS[name]))
    return out


def _verdict(s: dict[str, Any]) -> str | None:
    mc = s.get("model_checks")
    v = mc.get("verdict") if isinstance(mc, dict) else None
    return v if isinstance(v, str) else None


def headline(s: dict[str, Any]) -> str:
    """One line: the recommended damper (else c, k and ζ of the viscous posterior, named so
    when no damper is recommended) with their 90 % intervals, the verdict and convergence."""
    lead = damper_rows.short(s.get("damper"))
    parts = [lead] if lead else []
    if not lead or s["damper"].get("status") == "none":
        parts += [f"{'viscous ' if lead else ''}{name} = {med} {iv} {unit}".rstrip()
                  for name, med, iv, unit in _rows(s) if name in ("c", "k", "zeta")]
    v = _verdict(s)
    if v:
        parts.append(f"verdict {v}")
    d = s.get("diagnostics")
    if isinstance(d, dict) and d.get("converged") is False:
        parts.append("NOT converged")
    return ", ".join(parts) or "no parameters"


def html_table(s: dict[str, Any]) -> str:
    """The recommended damper (its rows, :mod:`dampfit.output.damper`) and below it a short
    HTML table of the viscous quantities (median, 90 % interval, unit), the verdict
    and whether the result converged — what a notebook shows for an analysis. Every value is
    escaped (a summary.json may have been edited)."""
    e = html.escape
    d = s.get("damper")
    lead = ""
    if isinstance(d, dict):
        body = "".join(f"<tr><td>{e(label)}</td><td>{e(text)}</td></tr>"
                       for label, text in damper_rows.rows(d))
        lead = (f"<p><b>{e(damper_rows.title(d))}</b></p><table><tbody>{body}</tbody></table>"
                f"<p>{e(damper_rows.other_label(s))}:</p>")
    rows = "".join(f"<tr><td>{e(n)}</td><td>{e(m)}</td><td>{e(i)}</td><td>{e(u)}</td></tr>"
                   for n, m, i, u in _rows(s))
    foot = []
    v = _verdict(s)
    if v:
        foot.append(f"damping law verdict: <b>{e(v)}</b>")
    d = s.get("diagnostics")
    if isinstance(d, dict) and isinstance(d.get("converged"), bool):
        foot.append("converged" if d["converged"] else "<b>NOT converged</b>")
    return (lead + "<table><thead><tr><th>quantity</th><th>median</th><th>90 % interval</th>"
            f"<th>unit</th></tr></thead><tbody>{rows}</tbody></table>"
            + (f"<p>{'; '.join(foot)}</p>" if foot else ""))


#: Words of a reader's or the preparation's note that records an assumption changing a number.
_ASSUMED = ("assumed", "presumed", "converted", "--rate", "skipped a", "repeats",
            "goes backwards", "axis auto", "read as", "handheld start")


def _assumption_lines(s: dict[str, Any]) -> list[str]:
    """The assumptions that change a number, one a line, at the end of the table: units
    guessed or converted, the time base (``--rate``, a preamble skipped, segments), the axis
    chosen, the mass sd missing (the notes are in summary.json as well)."""
    inp = s.get("input") if isinstance(s.get("input"), dict) else {}
    pre = s.get("preprocessing") if isinstance(s.get("preprocessing"), dict) else {}
    notes = [*(inp.get("notes") or []), *(pre.get("notes") or [])]
    out = [n for n in notes if isinstance(n, str) and any(w in n for w in _ASSUMED)]
    m = s.get("mass")
    if isinstance(m, dict) and isinstance(m.get("value"), (int, float)) and not m.get("sd"):
        out.append("mass sd not given: the intervals of c and k treat the mass as exact "
                   "(give --mass-sd KG)")
    return ["", "  assumptions"] + [f"    {n}" for n in dict.fromkeys(out)] if out else []
