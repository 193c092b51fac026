"""The recommended damper (summary.json's ``damper``) as labelled rows, for every output.

The terminal (:mod:`dampfit.output.text`), the notebook table and the report
(:mod:`dampfit.output.report`) all lead with these rows, so they say the same thing in the same
words: which number goes into the FEM model, the law and its coefficients with 90 % intervals
(digits from :mod:`dampfit.output.format`), the range they were measured over, the equivalent
linear c at the design amplitude and where it holds, and why (or why no damper, and what to
try). Only the summary dict is read; an edited summary may hold anything.
"""

from __future__ import annotations

import math
from typing import Any

from dampfit.output.format import interval, lookup, quantiles


def _num(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _g(x: Any, digits: int = 3) -> str:
    return f"{x:.{digits}g}" if _num(x) else "—"


def _iv(q: Any, unit: str = "") -> str | None:
    """``median [q05, q95] unit`` of a quantile dict, or None."""
    qs = quantiles(q)
    if qs is None:
        return None
    m, lo, hi = interval(*qs)
    unit = "" if unit in ("", "1") else f" {unit}"
    return f"{m} [{lo}, {hi}]{unit}"


def _pair(v: Any, unit: str) -> str | None:
    if isinstance(v, list) and len(v) == 2 and all(_num(x) for x in v):
        return f"{_g(v[0])}–{_g(v[1])} {unit}"
    return None


def title(d: dict[str, Any]) -> str:
    """The block's heading: what the recording supports, in one line."""
    status, law, verdict = d.get("status"), d.get("law"), d.get("verdict")
    if status == "recommended" and law == "viscous":
        return "RECOMMENDED DAMPER: one viscous dashpot c (verdict adequate) — enter this in the model"
    if status == "recommended" and isinstance(law, str):
        return (f"RECOMMENDED DAMPER: the {law} law (damping depends on amplitude) — enter this "
                "in the model")
    if status == "viscous-stands":
        return (f"RECOMMENDED DAMPER: one viscous dashpot c, for the measured range only "
                f"(verdict {verdict})")
    return f"NO DAMPER RECOMMENDED (verdict {verdict})"


def _coefficient_rows(d: dict[str, Any]) -> list[tuple[str, str]]:
    out = []
    for key in ("coefficients", "per_unit_mass"):
        coef = d.get(key) if isinstance(d.get(key), dict) else {}
        for name, q in coef.items():
            if not isinstance(q, dict):
                continue
            unit = q.get("unit") if isinstance(q.get("unit"), str) else ""
            text = _iv(q, unit)
            if text is None:
                continue
            sym = q.get("symbol") if isinstance(q.get("symbol"), str) else str(name)
            out.append((f"{sym}", text + ("  (per kg of mass: no mass given)"
                                          if key == "per_unit_mass" else "")))
    return out


def _linear_row(d: dict[str, Any]) -> tuple[str, str] | None:
    """The equivalent linear c (or ζ without a mass) at the design amplitude, and where it
    holds within ±10 % of the law."""
    design = d.get("design_amplitude") if isinstance(d.get("design_amplitude"), dict) else {}
    a = design.get("displacement_m")
    source = design.get("source") if isinstance(design.get("source"), str) else ""
    c = _iv(d.get("c_linear"), "N s/m")
    z = _iv(d.get("zeta_linear"))
    if c is None and z is None or not _num(a):
        return None
    text = (f"c = {c}" if c is not None else f"zeta = {z} (no mass: no c)")
    text += f" at {_g(a)} m displacement amplitude ({source})"
    span = _pair(d.get("linear_within_10pct_m"), "m")
    if d.get("law") == "viscous":
        text += "; linear law: the same c at every amplitude"
    elif span:
        eq = "c_eq(A)" if c is not None else "zeta_eq(A)"
        text += f"; within ±10 % of the law's {eq} for {span} displacement"
    return ("linear equivalent", text)


def _deck_row(d: dict[str, Any]) -> tuple[str, str] | None:
    """What ``dampfit export`` will write, from ``decay_check`` (the law's own free decay
    against the measured envelope): the law, or the measured force–velocity curve where the
    law misses the decay."""
    chk = d.get("decay_check")
    law = d["law"][:40] if isinstance(d.get("law"), str) else "recommended"
    if not isinstance(chk, dict):
        return None
    if chk.get("checked") is not True:
        why = chk.get("reason") if isinstance(chk.get("reason"), str) else "no reason recorded"
        return ("FEM deck", f"this law (not checked against the measured decay: {why[:200]})")
    rms, scatter = chk.get("rms"), chk.get("scatter")
    if not (_num(rms) and _num(scatter) and math.isfinite(rms) and math.isfinite(scatter)):
        return None
    nums = (f"{100 * rms:.2g} % rms of ln|u| about the measured trend, the measurement "
            f"scatters {100 * scatter:.2g} %")
    if chk.get("follows") is True:
        return ("FEM deck", f"this law: its own free decay follows the measured envelope ({nums})")
    return ("FEM deck", f"the measured force-velocity curve, not this law: the law's own free "
            f"decay misses the measured envelope ({nums}); 'dampfit export' fits the curve "
            f"and writes it where it comes closer ('--law {law}' writes the law)")


def rows(d: Any) -> list[tuple[str, str]]:
    """(label, text) rows of the damper section ``d`` (nothing when it is not a dict)."""
    if not isinstance(d, dict):
        return []
    out: list[tuple[str, str]] = []
    if d.get("status") in ("recommended", "viscous-stands"):
        if isinstance(d.get("force"), str):
            out.append(("force law", d["force"]))
        out += _coefficient_rows(d)
        k = _iv(d.get("k"), "N/m")
        mass = lookup(d, "mass", "value")
        if k is not None:
            out.append(("k", k + (f" with m = {_g(mass, 6)} kg" if _num(mass) else "")))
        rng = d.get("measured_range") if isinstance(d.get("measured_range"), dict) else {}
        parts = [p for p in (_pair(rng.get("displacement_m"), "m displacement"),
                             _pair(rng.get("velocity_m_s"), "m/s velocity")) if p]
        if parts:
            out.append(("measured over", " and ".join(parts) + " amplitude"))
        lin = _linear_row(d)
        if lin:
            out.append(lin)
        deck = _deck_row(d)
        if deck:
            out.append(deck)
    for key, label in (("reason", "why"), ("not_ruled_out", "not ruled out"), ("try", "try"),
                       ("missing", "missing")):
        if isinstance(d.get(key), str) and d[key]:
            out.append((label, d[key]))
    note = lookup(d, "posterior", "note")
    if isinstance(note, str) and note:
        out.append(("posterior", note))
    return out


def other_label(s: dict[str, Any]) -> str:
    """What the viscous posterior table is, given the damper: the recommended c itself, or one
    c that is not adequate here (or not trustworthy under a misfit)."""
    d = s.get("damper") if isinstance(s.get("damper"), dict) else None
    if d is None:
        return "posterior"
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    one = "c" if isinstance(params.get("c"), dict) else "zeta"  # no mass: no c
    if d.get("law") == "viscous":
        return f"viscous posterior (the recommended {one})"
    if d.get("verdict") == "misfit":
        return f"viscous posterior (one {one}; not trustworthy here)"
    return f"viscous posterior (one {one}; not adequate here)"


def short(d: Any) -> str | None:
    """One line: the recommended law and its coefficients (or "no damper recommended"), None
    without a damper section."""
    if not isinstance(d, dict):
        return None
    if d.get("status") not in ("recommended", "viscous-stands"):
        return f"no damper recommended ({d.get('verdict')})"
    parts = [f"{label} = {text.split('  (')[0]}" for label, text in _coefficient_rows(d)]
    return f"{d.get('law')} damper " + ", ".join(parts)
