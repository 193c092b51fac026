"""The report's section on several modes (issue 21): one row per mode in every damping convention.

:func:`modes_blocks` renders the summary's ``n_modes``, ``modes``, ``modes_evidence`` and
``rayleigh`` when the recording has several modes (``n_modes`` ≥ 2); for one mode it is empty
and the report is what it was before the modes existed (the one mode is the result table).

* the per-mode table in the conventions damping measurements are reported in (ISO 10846,
  ASTM E756, the log decrement of the seed paper): f_n [Hz], the damping ratio ζ [1], the
  loss factor η = 2ζ [1], the logarithmic decrement Λ = 2πζ/√(1−ζ²) [1] and the inverse
  quality factor Q⁻¹ = 1/Q = 2ζ [1], each the posterior median with its 90 % interval (digits
  from :mod:`dampfit.output.format`), and each mode's Cramér–Rao bound on the sd of ζ;
* c and k of the mode the mass belongs to;
* P(K) for every number of modes K tried, with the reason each was kept or rejected;
* the separation of each pair of modes and whether it was flagged as close;
* the Rayleigh α, β (with intervals) and the misfit statement;
* the ``modes`` figure (:mod:`dampfit.output.figures.modes`).

An edited summary.json may hold anything: every value is read by type, and every string is
escaped by the renderer (:mod:`dampfit.output.document`).
"""

from __future__ import annotations

from typing import Any

from dampfit.output.document import Block
from dampfit.output.report.values import (finite, figure, get, isnum, number, spec,
                                          with_interval)

#: The CRLB inflation above which a pair is flagged: the value of
#: :data:`dampfit.inference.modes_close.FLAG_INFLATION` (the report imports no numeric code;
#: a test holds the two equal).
FLAG_INFLATION = 1.25
#: … within these separations (:data:`dampfit.inference.modes_close.CLOSE_HALF_POWER`,
#: ``CLOSE_CELLS``; a test holds them equal).
CLOSE_HALF_POWER = 5.0
CLOSE_CELLS = 5.0

#: The per-mode table's damping columns: summary key, heading.
CONVENTIONS = (("zeta", "ζ, damping ratio [1]"), ("eta", "η = 2ζ, loss factor [1]"),
               ("delta", "Λ, log decrement [1]"), ("Q_inv", "Q⁻¹ = 1/Q, inverse quality factor [1]"))


def several_modes(s: dict) -> list[Any] | None:
    """The summary's ``modes`` list when the recording has several modes (``n_modes`` a whole
    number ≥ 2 and at least two entries), else None."""
    n, modes = s.get("n_modes"), s.get("modes")
    if isinstance(n, int) and not isinstance(n, bool) and n >= 2 and isinstance(modes, list) \
            and len(modes) >= 2:
        return modes
    return None


def inverse_q(q: Any) -> dict[str, float] | None:
    """The quantiles of Q⁻¹ = 1/Q from those of the quality factor Q [1] (1/x reverses the
    order: q05 of 1/Q is 1/q95 of Q), or None unless all three are finite and positive."""
    if not isinstance(q, dict) or not all(finite(q.get(k)) and q[k] > 0
                                          for k in ("q05", "q50", "q95")):
        return None
    return {"q50": 1.0 / q["q50"], "q05": 1.0 / q["q95"], "q95": 1.0 / q["q05"]}


def modes_blocks(s: dict) -> list[Block]:
    """The "Modes" section of the report (module docstring); [] for one mode."""
    modes = several_modes(s)
    if modes is None:
        seen = _seen(s)
        return [("h2", "Modes")] + seen if seen else []
    ev = s.get("modes_evidence") if isinstance(s.get("modes_evidence"), dict) else {}
    b: list[Block] = [("h2", "Modes"), ("p", [
        f"The recording holds {len(modes)} identified modes ({number(ev.get('reason'))}; up to "
        f"{number(ev.get('max_modes'))} tried). Each mode: posterior median and 90 % "
        "equal-tailed interval, in every convention damping is reported in; η = 2ζ, "
        "Λ = 2πζ/√(1−ζ²) (the decrement per cycle of the decay), Q⁻¹ = 1/Q = 2ζ. CRLB sd: "
        "the Cramér–Rao bound on the standard deviation of ζ for this recording's noise."])]
    b.append(_table(modes))
    b += _mass_mode(modes)
    b += _seen(s) + _evidence(ev) + _pairs(ev) + _rayleigh(s.get("rayleigh"))
    notes = [[n] for n in ev.get("notes") or [] if isinstance(n, str)] \
        if isinstance(ev.get("notes"), list) else []
    if notes:
        b += [("p", ["Notes of the modal analysis:"]), ("ul", notes)]
    return b + [figure("modes")]


def _table(modes: list[Any]) -> Block:
    head = ["mode", "f_n, natural frequency [Hz]"] + [h for _, h in CONVENTIONS]
    head += ["CRLB sd of ζ [1]", "sd / CRLB sd", "max R-hat"]
    rows = []
    for i, mode in enumerate(modes):
        if not isinstance(mode, dict):
            rows.append([str(i + 1)] + ["—"] * (len(head) - 1))
            continue
        qs = {k: mode.get(k) for k, _ in CONVENTIONS}
        qs["Q_inv"] = inverse_q(mode.get("Q"))
        crlb = get(mode, "crlb_sd", "zeta")
        sd = get(mode, "zeta", "sd")
        ratio = sd / crlb if finite(crlb) and crlb > 0 and finite(sd) else None
        hats = [q.get("r_hat") for q in (mode.get(k) for k in ("f_n", "zeta", "eta", "delta", "Q"))
                if isinstance(q, dict) and finite(q.get("r_hat"))]
        name = _number(mode, i) + (" (the mass's mode)" if mode.get("mass_mode") is True else "")
        rows.append([name, with_interval(mode.get("f_n"))]
                    + [with_interval(qs[k]) for k, _ in CONVENTIONS]
                    + [number(crlb, 3) if isnum(crlb) else "—", spec(ratio, ".2f"),
                       spec(max(hats), ".4f") if hats else "—"])
    return ("table", head, rows)


def _mass_mode(modes: list[Any]) -> list[Block]:
    """c and k of the mode the mass belongs to (the other modes have no modal mass)."""
    for i, mode in enumerate(modes):
        if isinstance(mode, dict) and mode.get("mass_mode") is True:
            parts = [f"{sym} = {with_interval(mode.get(k), unit)}"
                     for k, sym, unit in (("c", "c", "N·s/m"), ("k", "k", "N/m"))
                     if isinstance(mode.get(k), dict)]
            if parts:
                return [("p", [("b", f"Mode {_number(mode, i)} is the mode of the mass: "),
                               "; ".join(parts) + ". The other modes report ζ and f_n only "
                               "(no modal mass is invented for them)."])]
    return []


def _number(mode: dict, i: int) -> str:
    """A mode's number: its component ``index`` (as --mode-of-mass and the decks number
    them), else its place in the list."""
    n = mode.get("index")
    return str(n) if isinstance(n, int) and not isinstance(n, bool) else str(i + 1)


def _seen(s: dict) -> list[Block]:
    """The components seen but not modes (``modes_seen``): f_n, kind and reason; no ζ row,
    no Rayleigh, no deck."""
    seen = s.get("modes_seen")
    rows = [[with_interval(e.get("f_n")) if isinstance(e.get("f_n"), dict) else "—",
             number(e.get("kind")), number(e.get("reason"))]
            for e in (seen if isinstance(seen, list) else []) if isinstance(e, dict)]
    if not rows:
        return []
    return [("h3", "Seen, not modes"),
            ("p", ["Components the modal fit needed that lack the evidence of a mode (a "
                   "harmonic, a sideband, the fundamental's split, or a posterior that does "
                   "not identify them); they get no damping row, no Rayleigh and no deck."]),
            ("table", ["f_n [Hz]", "kind", "why"], rows)]


def _evidence(ev: dict) -> list[Block]:
    """P(K) for every K tried, with why each was kept or rejected; the one-mode screen."""
    out: list[Block] = [("h3", "Number of modes")]
    screen = ev.get("screen")
    if isinstance(screen, dict) and isinstance(screen.get("reason"), str):
        out.append(("p", ["Screen of the one-mode residual: ", screen["reason"], "."]))
    rows = []
    for r in ev.get("evidence") or [] if isinstance(ev.get("evidence"), list) else []:
        if not isinstance(r, dict):
            continue
        why = r.get("reason") if isinstance(r.get("reason"), str) and r.get("reason") else (
            "kept: the most probable" if r.get("n_modes") == ev.get("n_modes") else "—")
        rows.append([number(r.get("n_modes")), spec(r.get("probability"), ".3g"),
                     spec(r.get("ln_evidence"), ".1f"), number(r.get("admissible")),
                     number(r.get("f_d_hz"), 5), number(why)])
    if rows:
        out.append(("table", ["K, modes", "P(K)", "ln evidence", "admissible",
                              "damped frequencies [Hz]", "note"], rows))
    else:
        out.append(("p", ["P(K) not in summary.json."]))
    return out


def _pairs(ev: dict) -> list[Block]:
    """Each pair of modes: its separation and whether it was flagged as close."""
    rows = []
    for r in ev.get("pairs") or [] if isinstance(ev.get("pairs"), list) else []:
        if not isinstance(r, dict):
            continue
        pair = r.get("modes")
        name = " and ".join(number(m) for m in pair) if isinstance(pair, list) else number(pair)
        flag = r.get("flagged")
        rows.append([name, number(r.get("separation_hz"), 4),
                     number(r.get("separation_half_power"), 3),
                     number(r.get("separation_resolution"), 3),
                     f"{spec(r.get('inflation_f_n'), '.3g')}, {spec(r.get('inflation_zeta'), '.3g')}",
                     "CLOSE: intervals degraded (see the warnings at the top)" if flag is True
                     else number(flag)])
    if not rows:
        return []
    return [("h3", "Close modes"), ("p", [
        "Separation Δf of each pair in hertz, in half-power bandwidths (Δf over the mean of "
        "the two modes' 2ζ·f_n) and in frequency-resolution cells (Δf·T, T the analysed "
        "window); the CRLB inflation is how many times wider the pair's bound on f_n and on "
        "ζ is than for a lone mode, and a pair is flagged as close when it lies within "
        f"{CLOSE_HALF_POWER:g} half-power bandwidths or {CLOSE_CELLS:g} resolution cells and "
        f"either inflation exceeds {FLAG_INFLATION}."]),
        ("table", ["modes", "separation [Hz]", "in half-power bandwidths",
                   "in resolution cells 1/T", "CRLB inflation (f_n, ζ)", "flagged"], rows)]


def _rayleigh(ray: Any) -> list[Block]:
    """Rayleigh α, β with intervals and the misfit statement (the FEM hand-off)."""
    out: list[Block] = [("h3", "Rayleigh damping")]
    if not isinstance(ray, dict):
        return out + [("p", ["Not in summary.json."])]
    out.append(("p", [
        "Mass- and stiffness-proportional damping ζ(ω) = α/(2ω) + βω/2 that reproduces the "
        "modes' ζ at their ω (", ("code", "dampfit export --format opensees|lsdyna|calculix"),
        " writes it): ", ("b", f"α = {with_interval(ray.get('alpha'), '1/s')}"), ", ",
        ("b", f"β = {with_interval(ray.get('beta'), 's')}"), "; ",
        number(ray.get("statement")), "."]))
    facts = [f"{label} {spec(ray.get(k), fmt)}" for k, label, fmt in (
        ("max_relative_misfit", "max relative misfit", ".3g"), ("chi2", "χ²", ".3g"),
        ("dof", "degrees of freedom", ".0f"), ("p_value", "p-value", ".3g"))
        if finite(ray.get(k))]
    if facts and isnum(ray.get("dof")) and ray["dof"] > 0:
        out.append(("p", ["Misfit: " + ", ".join(facts) + "."]))
    fitted, measured = ray.get("zeta_fitted"), ray.get("zeta_measured")
    if isinstance(fitted, list) and isinstance(measured, list) and fitted:
        rows = [[str(i + 1), with_interval(m) if isinstance(m, dict) else "—",
                 with_interval(f) if isinstance(f, dict) else "—"]
                for i, (m, f) in enumerate(zip(measured, fitted))]
        out.append(("table", ["mode", "ζ measured [1]", "ζ of α, β [1]"], rows))
    warns = [[w] for w in ray.get("warnings") or [] if isinstance(w, str)] \
        if isinstance(ray.get("warnings"), list) else []
    return out + ([("ul", warns)] if warns else [])

