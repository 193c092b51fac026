"""Figures of a campaign summary (several recordings of one damper, issue 12).

Everything here reads only the plain-data summary of a campaign
(:meth:`dampfit.campaign.analysis.CampaignAnalysis.summary`, ``"kind": "campaign"``; schema in
:mod:`dampfit.campaign`), so a result folder read back by :func:`dampfit.load` draws the
same figures as the live analysis (its terminal table is :mod:`dampfit.output.text_campaign`):

* :func:`forest_figure` (``forest.png``) — per-test c, own and pooled 90 % intervals, with the
  population band and the (wider) predictive band for a new test;
* :func:`added_mass_figure` (``added_mass.png``, added-mass mode only) — 1/ω_n² against the added
  mass Δm with the fitted line 1/ω_n² = (m₀ + Δm)/k, which crosses zero at Δm = −m₀;
* :func:`save_figures` writes both (atomically, :func:`dampfit.output.figures.save_png`).

matplotlib is imported inside the figure functions only. Digits of a value with a 90 %
interval follow the interval's width (:func:`dampfit.output.format.interval`). The test names
(:func:`labels`) are those of the table and the report
(:func:`dampfit.output.text_campaign.labels`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dampfit.output.format import interval
from dampfit.output.format import quantiles as _q
from dampfit.output.text_campaign import labels as labels
from dampfit.output.text_campaign import shown_quantity as _shown_quantity
from dampfit.output.text_campaign import tests as _tests
from dampfit.physics import UNITS

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["FIGURES", "added_mass_figure", "forest_figure", "labels", "save_figures"]

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

_UNITS = {**UNITS, "m0": "kg"}


# ----------------------------------------------------------------------------- helpers
def _real(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _get(d: Any, *keys: str) -> Any:
    for key in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(key)
    return d


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
