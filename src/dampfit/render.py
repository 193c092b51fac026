"""Renderings of the plain-data summary (``Analysis.summary()``): text for the terminal.

Only the summary dict is read here, so anything that has a ``summary.json`` can be rendered
again without re-running the analysis.
"""

from __future__ import annotations

from typing import Any

__all__ = ["text"]

_LABELS = {
    "c": "c      [N s/m]", "k": "k      [N/m]", "u0": "u0     [m]", "zeta": "zeta   [1]",
    "f_n": "f_n    [Hz]", "p": "p      [1/s]", "delta": "delta  [1]",
}


def _g(x: Any, digits: int = 5) -> str:
    return "—" if x is None else f"{x:.{digits}g}"


def _f(x: Any, fmt: str) -> str:
    """Fixed-point: R-hat 1.0099 must not print as "1.01" next to a "< 1.01" rule."""
    return "—" if x is None else format(x, fmt)


def text(s: dict[str, Any]) -> str:
    """A readable multi-line table of a summary dict."""
    inp, win, band = s["input"], s["window"], s["band"]
    lines = [
        f"dampfit {s['dampfit_version']} — {inp['path'] or '(array)'}",
        f"  {inp['format']}, {inp['n_samples']} samples at {inp['sample_rate_hz']:.4g} Hz "
        f"({inp['duration_s']:.4g} s), axis {inp['axis']}",
        f"  free-decay window {win['start_s']:.3f}–{win['end_s']:.3f} s "
        f"({win['n_cycles']:.1f} cycles){'' if win['auto'] else ' (given)'}, "
        f"band {band['low_hz']:.4g}–{band['high_hz']:.4g} Hz, f0 = {s['dominant_frequency_hz']:.5g} Hz",
    ]
    m = s["mass"]
    lines.append(
        f"  mass {m['value']:.6g} ± {m['sd']:.3g} kg" if m["value"] is not None
        else "  mass not given: c and k cannot be identified (give --mass KG)"
    )
    lines += ["", f"  {'posterior':15s} {'median':>12s}   {'90 % interval':^27s} {'sd':>10s} {'R-hat':>7s} {'ESS':>6s}"]
    for name in ("c", "k", "u0", "zeta", "f_n", "p"):
        q = s["parameters"].get(name)
        if q is None:
            continue
        lines.append(
            f"  {_LABELS[name]:15s} {_g(q['q50'], 6):>12s}   [{_g(q['q05'], 6):>11s}, {_g(q['q95'], 6):>11s}]"
            f" {_g(q['sd'], 3):>10s} {_f(q['r_hat'], '.4f'):>7s} {_f(q['ess_bulk'], '.0f'):>6s}"
        )
    ls = s["least_squares"]
    lines += ["", "  least squares   " + ", ".join(
        f"{k} = {_g(ls.get(k), 6)}" for k in ("c", "k", "u0", "zeta", "f_n") if ls.get(k) is not None
    ) + ("" if ls["converged"] else "   (NOT converged)")]
    for key, label in (("log_decrement", "log decrement "), ("envelope_pipeline", "envelope (paper)")):
        b = s["baselines"].get(key)
        if b is None:
            lines.append(f"  {label:15s} not computed")
            continue
        extra = f" over {b['n_cycles']} cycles" if b.get("n_cycles") else ""
        lines.append(f"  {label:15s} c = {_g(b['c'], 6)}, zeta = {_g(b['zeta'], 6)}{extra}")
    nm = s["noise_model"]
    lines.append(
        f"  noise           sigma = {nm['sigma']:.3g} m/s^2 per sample at {nm['sample_rate_hz']:.4g} Hz, "
        f"spectral factor r = {nm['psd_ratio_at_f0']:.3g}"
    )
    mc = s.get("model_checks")
    if isinstance(mc, dict):
        amp = mc.get("amplitude_dependence") or {}
        verdict = ("amplitude-dependent" if amp.get("detected") else "no amplitude dependence")
        line = (f"  damping law     {mc.get('preferred_model')} preferred ({verdict}, "
                f"P(one viscous c) = {_g(amp.get('p_viscous'), 2)})")
        ceq = s.get("c_equivalent")
        if isinstance(ceq, dict) and isinstance(ceq.get("c"), dict):
            q = ceq["c"]
            line += (f"\n  c_equivalent    {_g(q['q50'], 6)} N s/m [{_g(q['q05'], 6)}, "
                     f"{_g(q['q95'], 6)}] ({ceq['model']} law at {_g(ceq['amplitude_m'], 3)} m "
                     "displacement amplitude)")
        lines.append(line)
    d = s["diagnostics"]
    state = "yes" if d["converged"] else "NO"
    lines.append(
        f"  converged       {state} (max R-hat {_f(d['max_r_hat'], '.4f')}, min bulk ESS "
        f"{_f(d['min_ess_bulk'], '.0f')}, {d['n_steps']} steps x {d['n_walkers']} walkers)"
    )
    if d["warnings"]:
        lines.append("")
        lines += [f"  WARNING: {w}" for w in d["warnings"]]
    return "\n".join(lines)
