"""Renderings of a campaign summary (several recordings of one damper, issue 12).

Everything here reads only the plain-data summary of a campaign
(:meth:`dampfit.campaign.analysis.CampaignAnalysis.summary`, ``"kind": "campaign"``; schema in
:mod:`dampfit.campaign`), so a result folder read back by :func:`dampfit.load` renders the
same text and figures as the live analysis:

* :func:`text` — the terminal table of ``dampfit analyze FILE FILE…``: the population c, k, ζ,
  f_n (and m₀ in added-mass mode) with 90 % intervals, the predictive interval for a new test,
  the between-test spread τ, one row per test (own and partially pooled c, amplitude, outlier
  flag) and the verdict sentence;
* :func:`forest_figure` (``forest.png``) — per-test c, own and pooled 90 % intervals, with the
  population band and the (wider) predictive band for a new test;
* :func:`added_mass_figure` (``added_mass.png``, added-mass mode only) — 1/ω_n² against the added
  mass Δm with the fitted line 1/ω_n² = (m₀ + Δm)/k, which crosses zero at Δm = −m₀;
* :func:`save_figures` writes both (atomically, :func:`dampfit.output.figures.save_png`).

matplotlib is imported inside the figure functions only. Digits of a value with a 90 %
interval follow the interval's width (:func:`dampfit.output.text.interval`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dampfit.output.text import interval
from dampfit.result.schema import unique_warnings
from dampfit.physics import UNITS

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["FIGURES", "added_mass_figure", "forest_figure", "is_campaign", "labels",
           "save_figures", "text"]

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


# ----------------------------------------------------------------------------- figures
# Fixed layouts with the layout helpers of the analysis figures (:mod:`dampfit.output.figures`,
# imported as ``L``): margins [in] from the measured tick labels, titles and legend, no layout
# engine.


def forest_figure(s: dict[str, Any]) -> "Figure | None":
    """Forest plot of per-test c (ζ without a mass): own and pooled 90 % intervals, the
    population band and the predictive band for a new test (see :data:`FIGURES`). None when
    the summary has no tests."""
    tests = _tests(s)
    if not tests:
        return None
    what = _shown_quantity(s)
    sym = {"c": "c", "zeta": "ζ"}[what]
    unit = _UNITS[what].replace(" ", "·")
    from dampfit.output import figures as L

    fig = L._new_figure(8.0, 1.8 + 0.45 * len(tests))
    ax = fig.add_subplot()
    pred = _q(_get(s, "population", "predictive", what))
    pop = _q(_get(s, "parameters", what))
    if pred is not None:
        ax.axvspan(pred[1], pred[2], color="tab:blue", alpha=0.12,
                   label="new test, 90 % predictive")
    if pop is not None:
        ax.axvspan(pop[1], pop[2], color="tab:blue", alpha=0.30, label="population, 90 %")
        ax.axvline(pop[0], color="tab:blue", lw=1.0)
    names, ticks = labels(tests), []
    for i, t in enumerate(tests):
        y = len(tests) - 1 - i
        colour = "tab:red" if t.get("outlier") is True else "black"
        own, pooled = _q(_get(t, "own", what)), _q(_get(t, "pooled", what))
        if own is not None:
            ax.plot([own[1], own[2]], [y + 0.15] * 2, color=colour, lw=1.0, alpha=0.7)
            ax.plot(own[0], y + 0.15, "o", mfc="white", mec=colour, ms=5,
                    label="test alone" if i == 0 else None)
        if pooled is not None:
            ax.plot([pooled[1], pooled[2]], [y - 0.15] * 2, color=colour, lw=2.5)
            ax.plot(pooled[0], y - 0.15, "s", color=colour, ms=5,
                    label="partially pooled" if i == 0 else None)
        amp = t.get("amplitude_m")
        tag = f" (A = {amp * 1e3:.3g} mm)" if _real(amp) else ""
        ticks.append(f"{i + 1}: {names[i]}{tag}")
    ax.set_yticks(range(len(tests) - 1, -1, -1), ticks, fontsize=8)
    ax.set_ylim(-0.8, len(tests) - 0.2)
    ax.set_xlabel(f"{sym} [{unit}]" if unit != "1" else sym)
    L._title(ax, f"{sym} of each test, population and predictive interval")
    ax.grid(axis="x", alpha=0.3)
    leg = fig.legend(fontsize=7, loc="lower center", ncols=4)  # below the axes
    rows = -(-len(leg.texts) // 4)
    legend = rows * L._line(7) + (0.5 * (rows - 1) + 1.3) * 7 * L._PT if rows else 0.0
    L._place(L._gridspec(ax), left=L._EDGE + L._TICK + max(L._text_width(t, 8) for t in ticks),
             right=0.25, top=L._EDGE + L._above(ax), bottom=L._x_room() + legend)
    return fig


def added_mass_figure(s: dict[str, Any]) -> "Figure | None":
    """1/ω_n² against Δm with the fitted line and m₀ (see :data:`FIGURES`); None when the
    summary is not of the added-mass design."""
    am = s.get("added_mass")
    if not isinstance(am, dict):
        return None
    pts = [p for p in (am.get("points") or []) if isinstance(p, dict)
           and _real(p.get("added_mass_kg")) and _real(p.get("omega_n2")) and p["omega_n2"] > 0]
    if not pts:
        return None
    from dampfit.output import figures as L

    fig = L._new_figure(6.0, 4.2)
    ax = fig.add_subplot()
    x = [p["added_mass_kg"] for p in pts]
    y = [1.0 / p["omega_n2"] for p in pts]
    err = [p["omega_n2_sd"] / p["omega_n2"] ** 2 if _real(p.get("omega_n2_sd")) else 0.0
           for p in pts]
    ax.errorbar(x, y, yerr=err, fmt="o", color="black", ms=5, capsize=3, label="tests (± 1 sd)")
    m0 = _q(am.get("m0")) or _q(_get(s, "parameters", "m0"))
    line = am.get("line") if isinstance(am.get("line"), dict) else {}
    lo = min(x + ([-m0[2]] if m0 else []))
    hi = max(x)
    if _real(line.get("intercept")) and _real(line.get("slope")):
        span = hi - lo if hi > lo else 1.0
        xs = [lo - 0.05 * span, hi + 0.05 * span]
        ax.plot(xs, [line["intercept"] + line["slope"] * v for v in xs], color="tab:blue",
                label="1/ω_n² = (m₀ + Δm)/k")
    if m0 is not None:
        ax.axvspan(-m0[2], -m0[1], color="tab:orange", alpha=0.25,
                   label=f"−m₀, 90 % (m₀ = {interval(*m0)[0]} kg)")
        ax.axvline(-m0[0], color="tab:orange", lw=1.0)
    ax.axhline(0.0, color="grey", lw=0.6)
    ax.set_xlabel("added mass Δm [kg]")
    ax.set_ylabel("1/ω_n² [s²]")
    L._title(ax, "Added-mass method")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    L._place(L._gridspec(ax), left=L._y_room([ax]), right=0.25, top=L._EDGE + L._above(ax),
             bottom=L._x_room())
    return fig


#: Figure functions by file stem.
_DRAW = {"forest": forest_figure, "added_mass": added_mass_figure}


def save_figures(s: dict[str, Any], outdir: str | os.PathLike, *, dpi: int = 110
                 ) -> dict[str, Path]:
    """Write ``forest.png`` and (added-mass design) ``added_mass.png`` of campaign summary
    ``s`` into ``outdir`` (atomically); a figure that does not apply is not written and an
    older file of its name is removed. Returns ``{name: path}`` of the files written."""
    from dampfit.output.figures import save_png

    outdir = Path(outdir)
    written: dict[str, Path] = {}
    for name, draw in _DRAW.items():
        path = outdir / f"{name}.png"
        fig = draw(s)
        if fig is None:
            path.unlink(missing_ok=True)  # never leave a stale figure of an earlier run
            continue
        save_png(fig, path, dpi)
        written[name] = path
    return written
