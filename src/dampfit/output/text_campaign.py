"""The terminal table of a campaign summary (several recordings of one damper, issue 12).

:func:`text` is what ``dampfit analyze FILE FILE…`` prints and
:meth:`dampfit.campaign.result.CampaignAnalysis.report` returns: the population c, k, ζ,
f_n (and m₀ in added-mass mode) with 90 % intervals, the predictive interval for a new test,
the between-test spread τ, one row per test (own and partially pooled c, amplitude, outlier
flag) and the verdict sentence. Only the plain-data summary (``"kind": "campaign"``; schema in
:mod:`dampfit.campaign`) is read, so a folder read back by :func:`dampfit.load` prints the same
table. Digits of a value with a 90 % interval follow the interval's width
(:func:`dampfit.output.format.interval`, the one formatter of the text tables and reports).

The helpers that name and select what a campaign shows are public here, because the campaign
report and figures show the same tests under the same names: :func:`labels` (the test names),
:func:`tests` (the test entries), :func:`shown_quantity` (c, or ζ without a mass).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dampfit.output.format import formatted, lookup, quantiles, real, with_interval
from dampfit.physics import UNITS
from dampfit.result.schema import unique_warnings

#: Population quantities of the table, in order (m₀ only in added-mass mode).
POPULATION = ("c", "k", "zeta", "f_n", "m0")
_UNITS = {**UNITS, "m0": "kg"}


# ----------------------------------------------------------------------------- helpers
def _iv(q: Any) -> str:
    """``median [q05, q95]`` with honest digits, or ``—`` without all three."""
    return "—" if quantiles(q) is None else with_interval(q)


def labels(tests: list[dict]) -> list[str]:
    """Names of the tests, told apart: the file names, with as many parent folders as it takes
    when two files share a name (``40cm/run1/data.npy``, ``40cm/run2/data.npy`` →
    ``run1/data.npy``, ``run2/data.npy``)."""
    parts = []
    for i, t in enumerate(tests):
        path = lookup(t, "input", "path")
        parts.append(Path(path).parts if isinstance(path, str) and path
                     else (f"test {i + 1}",))
    depth = 1
    longest = max((len(p) for p in parts), default=1)
    while depth < longest:
        names = ["/".join(p[-depth:]) for p in parts]
        if len(set(names)) == len(names):
            break
        depth += 1
    return [_short(p[-depth:]) for p in parts]


def _short(parts: tuple[str, ...], folder: int = 16, limit: int = 44) -> str:
    """``parts`` joined by ``/``, each folder name cut to its first ``folder`` characters (the
    start tells runs apart: dates, numbers), the whole at most ``limit`` characters."""
    out = [p if len(p) <= folder else p[:folder - 1] + "…" for p in parts[:-1]] + [parts[-1]]
    text = "/".join(out)
    return text if len(text) <= limit else "…" + text[-(limit - 1):]


def tests(s: dict) -> list[dict]:
    """The test entries of a campaign summary that are dicts (an edited summary may hold
    anything else)."""
    entries = s.get("tests")
    return [t for t in entries if isinstance(t, dict)] if isinstance(entries, list) else []


def shown_quantity(s: dict) -> str:
    """The per-test quantity shown: c when the tests carry it (a mass is known), else ζ."""
    entries = tests(s)
    if entries and all(quantiles(lookup(t, "own", "c")) or quantiles(lookup(t, "pooled", "c"))
                       for t in entries):
        return "c"
    return "zeta"


# ----------------------------------------------------------------------------- the table
def text(s: dict[str, Any]) -> str:
    """The terminal table of a campaign summary (see the module)."""
    design = s.get("design") if isinstance(s.get("design"), dict) else {}
    n = design.get("n_tests", len(tests(s)))
    model = design.get("model") or "hierarchical"
    lines = [f"dampfit {s.get('dampfit_version', '?')} — campaign of {n} tests "
             f"({model} model)", _mass_line(s, design)]
    lines += [""] + _population_lines(s) + _test_lines(s) + _modes_lines(s)
    am_res = s.get("added_mass") if isinstance(s.get("added_mass"), dict) else None
    if am_res is not None:
        lines += ["", f"  added mass      1/omega_n^2 = (m0 + dm)/k: m0 = {_iv(am_res.get('m0'))} kg, "
                      f"k = {_iv(am_res.get('k'))} N/m"]
    checks = s.get("checks") if isinstance(s.get("checks"), dict) else {}
    if checks.get("text") or checks.get("verdict"):
        lines += ["", f"  verdict         {checks.get('verdict', '?')}: {checks.get('text', '')}".rstrip()]
    d = s.get("diagnostics") if isinstance(s.get("diagnostics"), dict) else {}
    if d:
        state = "yes" if d.get("converged") is True else "NO"
        r_hat, ess = d.get("max_r_hat"), d.get("min_ess_bulk")
        lines.append(f"  converged       {state} (max R-hat "
                     f"{formatted(r_hat, '.4f', finite_only=True)}, min bulk ESS "
                     f"{formatted(ess, '.0f', finite_only=True)}, {d.get('n_steps', '?')} steps)")
    warns, more = unique_warnings(d.get("warnings"), s.get("warnings"),
                                  text=lambda w: w if isinstance(w, str) else "")
    if warns:
        lines.append("")
        lines += [f"  WARNING: {w}" for w in warns]
    if more:
        lines.append(f"  … and {more} more distinct warnings (see summary.json)")
    return "\n".join(lines)


def _mass_line(s: dict, design: dict) -> str:
    """The mass (or the added masses, or that none was given)."""
    m = s.get("mass") if isinstance(s.get("mass"), dict) else {}
    am = design.get("added_mass") if isinstance(design.get("added_mass"), dict) else None
    if am is not None:
        vals = ", ".join(formatted(v, '.4g', finite_only=True) for v in (am.get("values") or []))
        sd = (f" ± {formatted(am.get('sd'), '.3g', finite_only=True)}"
              if real(am.get("sd")) and am["sd"] > 0 else "")
        return (f"  added masses {vals} kg{sd}; effective mass m0 estimated "
                f"(c and k use m0 = {formatted(m.get('value'), '.6g', finite_only=True)} kg)")
    if real(m.get("value")):
        sd = f" ± {m['sd']:.3g} kg" if real(m.get("sd")) and m["sd"] > 0 else " kg (sd not given)"
        return f"  mass {m['value']:.6g}{sd}"
    return ("  mass not given: c and k cannot be identified (give --mass KG or "
            "--added-mass KG KG…)")


def _population_lines(s: dict) -> list[str]:
    """Population and predictive intervals, the between-test spread and its verdict."""
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    pop = s.get("population") if isinstance(s.get("population"), dict) else {}
    pred = pop.get("predictive") if isinstance(pop.get("predictive"), dict) else {}
    lines = [f"  {'':17s} {'population (median [90 %])':>34s}   {'new test (predictive)':>30s}"]
    for name in POPULATION:
        q = params.get(name)
        if quantiles(q) is None:
            continue
        label = f"{name:6s} [{_UNITS.get(name, '')}]"
        lines.append(f"  {label:17s} {_iv(q):>34s}   {_iv(pred.get(name)):>30s}")
    spread = pop.get("spread") if isinstance(pop.get("spread"), dict) else {}
    zero = pop.get("spread_consistent_with_zero")
    words = {"p": "spread τ of p", "omega": "spread τ of ω_n"}
    for key in ("p", "omega"):
        if quantiles(spread.get(key)) is not None:
            lines.append(f"  {words[key]:17s} {_iv(spread[key]):>34s}   (between-test sd of ln "
                         f"{'p' if key == 'p' else 'ω_n'}, relative)")
    shared = spread.get("omega", {}).get("p_zero") if isinstance(spread.get("omega"), dict) else None
    if real(shared):
        lines.append(f"  {'one frequency law':17s} {'P = ' + format(shared, '.3g'):>34s}   "
                     "(τ_ω = 0 against scatter, Bayes factor)")
    if zero is not None:
        lines.append("  between-test spread " + ("consistent with zero: the tests agree within "
                                                 "their own uncertainty" if zero else
                                                 "NOT consistent with zero"))
    return lines


def _test_lines(s: dict) -> list[str]:
    """One row per test: added mass, amplitude, own and pooled value, outlier flag."""
    entries = tests(s)
    if not entries:
        return []
    what = shown_quantity(s)
    unit = f" [{_UNITS[what]}]" if _UNITS.get(what, "1") != "1" else ""
    head = ["test", "Δm [kg]", "ampl. [m]", f"own {what}{unit}", f"pooled {what}{unit}",
            "outlier"]
    rows = []
    for i, (t, name) in enumerate(zip(entries, labels(entries))):
        dm = t.get("added_mass_kg")
        rows.append([f"{i + 1:>2d} {name}", formatted(dm, '.4g', finite_only=True),
                     formatted(t.get("amplitude_m"), '.3g', finite_only=True),
                     _iv(lookup(t, "own", what)),
                     _iv(lookup(t, "pooled", what)),
                     "OUTLIER" if t.get("outlier") is True else "no"])
    widths = [max(len(r[j]) for r in [head, *rows]) for j in range(len(head))]

    def row(cells: list[str]) -> str:
        return "  " + "  ".join(c.ljust(w) if j in (0, 5) else c.rjust(w)
                               for j, (c, w) in enumerate(zip(cells, widths))).rstrip()

    return ["", row(head)] + [row(r) for r in rows]


#: Longest reason shown for a test whose modes were not analysed [characters].
_REASON_CHARS = 160


def _no_modes(m: dict) -> str:
    """Why a test lists no modes: one mode (the pooled one) by the screen or the evidence,
    or not analysed, with the reason (whitespace folded, at most :data:`_REASON_CHARS`)."""
    evidence = m.get("modes_evidence") if isinstance(m.get("modes_evidence"), dict) else {}
    one = _one_mode(m)
    reason = evidence.get("reason") if one else m.get("reason")
    reason = " ".join(reason.split())[:_REASON_CHARS] if isinstance(reason, str) else ""
    if one:
        return "one mode (the pooled one)" + (f": {reason}" if reason else "")
    return f"not analysed: {reason or 'no modes'}"


def _one_mode(m: dict) -> bool:
    """Whether a test's modes entry says one mode (the pooled one), settled by the screen or
    the evidence."""
    return m.get("n_modes") == 1 and not isinstance(m.get("n_modes"), bool)


def _numbers(numbers: list[int]) -> str:
    """Test numbers as ranges: [1, 2, 3, 5] → "1–3, 5"."""
    runs: list[list[int]] = []
    for n in numbers:
        if runs and n == runs[-1][-1] + 1:
            runs[-1].append(n)
        else:
            runs.append([n])
    return ", ".join(f"{r[0]}–{r[-1]}" if len(r) > 2 else ", ".join(map(str, r)) for r in runs)


def _modes_lines(s: dict) -> list[str]:
    """With ``max_modes`` > 1: every test's modes (f_n, ζ with 90 % intervals), the pooled
    one marked ``*``, or why its modes were not analysed. Tests of one mode (the pooled one)
    share one line when there are several — their reasons, test by test, are in the report
    and summary.json. Nothing for a one-mode campaign."""
    entries = tests(s)
    blocks = [(i, name, t["modes"])
              for i, (t, name) in enumerate(zip(entries, labels(entries)), start=1)
              if isinstance(t.get("modes"), dict)]
    if not blocks:
        return []
    ones = [i for i, _, m in blocks
            if _one_mode(m) and not (isinstance(m.get("modes"), list) and m["modes"])]
    if len(ones) < 2:
        ones = []
    rows = []
    for i, name, m in blocks:
        if i in ones:
            continue
        label = f"{i:>2d} {name}"
        modes = [r for r in m.get("modes") or [] if isinstance(r, dict)] \
            if isinstance(m.get("modes"), list) else []
        if not modes:
            rows.append([label, "", _no_modes(m), ""])
            continue
        for j, r in enumerate(modes):
            star = " *" if r.get("pooled") is True else ""
            rows.append([label if j == 0 else "", f"mode {j + 1}{star}",
                         _iv(r.get("f_n")), _iv(r.get("zeta"))])
    out = ["", "  modes of each test (* = the pooled mode; the others are this test's own)"]
    if rows:
        head = ["test", "mode", "f_n [Hz]", "zeta"]
        widths = [max(len(r[j]) for r in [head, *rows]) for j in range(len(head))]
        for r in [head, *rows]:
            out.append("  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    if ones:
        out.append(f"  tests {_numbers(ones)}: one mode (the pooled one); "
                   "why, test by test: the report, or modes_evidence.reason in summary.json")
    return out
