"""Renderings of a campaign summary (several recordings of one damper, issue 12).

Everything here reads only the plain-data summary of a campaign
(:meth:`dampfit.campaign.analysis.CampaignAnalysis.summary`, ``"kind": "campaign"``; schema in
:mod:`dampfit.campaign`), so a result folder read back by :func:`dampfit.load` renders the
same text as the live analysis:

* :func:`text` — the terminal table of ``dampfit analyze FILE FILE…``: the population c, k, ζ,
  f_n (and m₀ in added-mass mode) with 90 % intervals, the predictive interval for a new test,
  the between-test spread τ, one row per test (own and partially pooled c, amplitude, outlier
  flag) and the verdict sentence;
* :data:`FIGURES` — the caption of each campaign figure (``forest.png``, ``added_mass.png``),
  which :mod:`dampfit.output.figures.campaign` draws;
* :func:`labels` — the tests' names, told apart.

Digits of a value with a 90 % interval follow the interval's width
(:func:`dampfit.output.text.interval`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from dampfit.output.text import interval
from dampfit.result.schema import unique_warnings
from dampfit.physics import UNITS

__all__ = ["FIGURES", "is_campaign", "labels", "text"]

#: File stem → caption of each campaign figure (the report shows the caption under it).
FIGURES = {
    "forest": "Forest plot of the damping coefficient c of each test: the test alone (own "
              "posterior, thin) and partially pooled by the hierarchical model (thick), each "
              "median with its 90 % interval; outliers in red. Shaded: the 90 % interval of the "
              "population c (dark) and the 90 % predictive interval of c for a new test (light).",
    "added_mass": "Added-mass method: 1/ω_n² [s²] of each test against its added mass Δm [kg] "
                  "(± 1 sd) and the fitted line 1/ω_n² = (m₀ + Δm)/k, which crosses zero at "
                  "Δm = −m₀ (the effective mass, shaded with its 90 % interval).",
}

#: Population quantities of the table, in order (m₀ only in added-mass mode).
POPULATION = ("c", "k", "zeta", "f_n", "m0")
_UNITS = {**UNITS, "m0": "kg"}


def is_campaign(s: Any) -> bool:
    """True if ``s`` is the summary dict of a campaign (``"kind": "campaign"``)."""
    return isinstance(s, dict) and s.get("kind") == "campaign"


# ----------------------------------------------------------------------------- helpers
def _real(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _get(d: Any, *keys: str) -> Any:
    for key in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(key)
    return d


def _q(q: Any) -> tuple[Any, Any, Any] | None:
    """(q50, q05, q95) of a quantile dict, or None if any is missing."""
    if not isinstance(q, dict) or not all(_real(q.get(k)) for k in ("q50", "q05", "q95")):
        return None
    return q["q50"], q["q05"], q["q95"]


def _iv(q: Any) -> str:
    """``median [q05, q95]`` with honest digits, or ``—``."""
    v = _q(q)
    if v is None:
        return "—"
    m, lo, hi = interval(*v)
    return f"{m} [{lo}, {hi}]"


def _g(x: Any, digits: int = 4) -> str:
    return f"{x:.{digits}g}" if _real(x) else "—"


def labels(tests: list[dict]) -> list[str]:
    """Names of the tests, told apart: the file names, with as many parent folders as it takes
    when two files share a name (``40cm/run1/data.npy``, ``40cm/run2/data.npy`` →
    ``run1/data.npy``, ``run2/data.npy``)."""
    parts = []
    for i, t in enumerate(tests):
        path = _get(t, "input", "path")
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


def _tests(s: dict) -> list[dict]:
    tests = s.get("tests")
    return [t for t in tests if isinstance(t, dict)] if isinstance(tests, list) else []


def _shown_quantity(s: dict) -> str:
    """The per-test quantity shown: c when the tests carry it (a mass is known), else ζ."""
    tests = _tests(s)
    if tests and all(_q(_get(t, "own", "c")) or _q(_get(t, "pooled", "c")) for t in tests):
        return "c"
    return "zeta"


# ----------------------------------------------------------------------------- text
def text(s: dict[str, Any]) -> str:
    """The terminal table of a campaign summary (see the module)."""
    design = s.get("design") if isinstance(s.get("design"), dict) else {}
    n = design.get("n_tests", len(_tests(s)))
    model = design.get("model") or "hierarchical"
    lines = [f"dampfit {s.get('dampfit_version', '?')} — campaign of {n} tests "
             f"({model} model)"]
    m = s.get("mass") if isinstance(s.get("mass"), dict) else {}
    am = design.get("added_mass") if isinstance(design.get("added_mass"), dict) else None
    if am is not None:
        vals = ", ".join(_g(v, 4) for v in (am.get("values") or []))
        sd = f" ± {_g(am.get('sd'), 3)}" if _real(am.get("sd")) and am["sd"] > 0 else ""
        lines.append(f"  added masses {vals} kg{sd}; effective mass m0 estimated "
                     f"(c and k use m0 = {_g(m.get('value'), 6)} kg)")
    elif _real(m.get("value")):
        sd = f" ± {m['sd']:.3g} kg" if _real(m.get("sd")) and m["sd"] > 0 else " kg (sd not given)"
        lines.append(f"  mass {m['value']:.6g}{sd}")
    else:
        lines.append("  mass not given: c and k cannot be identified (give --mass KG or "
                     "--added-mass KG KG…)")

    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    pop = s.get("population") if isinstance(s.get("population"), dict) else {}
    pred = pop.get("predictive") if isinstance(pop.get("predictive"), dict) else {}
    head = f"  {'':17s} {'population (median [90 %])':>34s}   {'new test (predictive)':>30s}"
    lines += ["", head]
    for name in POPULATION:
        q = params.get(name)
        if _q(q) is None:
            continue
        label = f"{name:6s} [{_UNITS.get(name, '')}]"
        lines.append(f"  {label:17s} {_iv(q):>34s}   {_iv(pred.get(name)):>30s}")
    spread = pop.get("spread") if isinstance(pop.get("spread"), dict) else {}
    zero = pop.get("spread_consistent_with_zero")
    words = {"p": "spread τ of p", "omega": "spread τ of ω_n"}
    for key in ("p", "omega"):
        if _q(spread.get(key)) is not None:
            lines.append(f"  {words[key]:17s} {_iv(spread[key]):>34s}   (between-test sd of ln "
                         f"{'p' if key == 'p' else 'ω_n'}, relative)")
    shared = spread.get("omega", {}).get("p_zero") if isinstance(spread.get("omega"), dict) else None
    if _real(shared):
        lines.append(f"  {'one frequency law':17s} {'P = ' + format(shared, '.3g'):>34s}   "
                     "(τ_ω = 0 against scatter, Bayes factor)")
    if zero is not None:
        lines.append("  between-test spread " + ("consistent with zero: the tests agree within "
                                                 "their own uncertainty" if zero else
                                                 "NOT consistent with zero"))

    tests = _tests(s)
    if tests:
        what = _shown_quantity(s)
        unit = f" [{_UNITS[what]}]" if _UNITS.get(what, "1") != "1" else ""
        head = ["test", "Δm [kg]", "ampl. [m]", f"own {what}{unit}", f"pooled {what}{unit}",
                "outlier"]
        rows = []
        for i, (t, name) in enumerate(zip(tests, labels(tests))):
            dm = t.get("added_mass_kg")
            rows.append([f"{i + 1:>2d} {name}", _g(dm, 4) if _real(dm) else "—",
                         _g(t.get("amplitude_m"), 3), _iv(_get(t, "own", what)),
                         _iv(_get(t, "pooled", what)),
                         "OUTLIER" if t.get("outlier") is True else "no"])
        widths = [max(len(r[j]) for r in [head, *rows]) for j in range(len(head))]

        def row(cells: list[str]) -> str:
            return "  " + "  ".join(c.ljust(w) if j in (0, 5) else c.rjust(w)
                                   for j, (c, w) in enumerate(zip(cells, widths))).rstrip()

        lines += ["", row(head)] + [row(r) for r in rows]

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
                     f"{f'{r_hat:.4f}' if _real(r_hat) else '—'}, min bulk ESS "
                     f"{f'{ess:.0f}' if _real(ess) else '—'}, {d.get('n_steps', '?')} steps)")
    warns, more = unique_warnings(d.get("warnings"), s.get("warnings"),
                                  text=lambda w: w if isinstance(w, str) else "")
    if warns:
        lines.append("")
        lines += [f"  WARNING: {w}" for w in warns]
    if more:
        lines.append(f"  … and {more} more distinct warnings (see summary.json)")
    return "\n".join(lines)
