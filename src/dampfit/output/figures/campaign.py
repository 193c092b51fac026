"""The campaign figures (several recordings of one damper), drawn from the campaign summary.

* :func:`forest_figure` (``forest.png``) — per-test c, own and pooled 90 % intervals, with the
  population band and the (wider) predictive band for a new test;
* :func:`added_mass_figure` (``added_mass.png``, added-mass mode only) — 1/ω_n² against the
  added mass Δm with the fitted line 1/ω_n² = (m₀ + Δm)/k, which crosses zero at Δm = −m₀;
* :func:`save_figures` writes both (atomically, :func:`dampfit.output.figures.png.save_png`).

Everything here reads only the plain-data summary of a campaign (``"kind": "campaign"``;
schema in :mod:`dampfit.campaign`), so a folder read back by :func:`dampfit.load` draws the
same figures as the live analysis. Their captions are
:data:`dampfit.output.campaign.FIGURES`. Fixed layouts (:mod:`dampfit.output.figures.layout`):
margins [in] from the measured tick labels, titles and legend, no layout engine. Digits of a
value with a 90 % interval follow the interval's width (:func:`dampfit.output.text.interval`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dampfit.output.text_campaign import labels, shown_quantity
from dampfit.output.text_campaign import tests as campaign_tests
from dampfit.output.figures import layout as L
from dampfit.output.figures.png import save_png
from dampfit.output.format import interval, lookup, quantiles
from dampfit.physics import UNITS
from dampfit.result.folder import real

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure


def forest_figure(s: dict[str, Any]) -> "Figure | None":
    """Forest plot of per-test c (ζ without a mass): own and pooled 90 % intervals, the
    population band and the predictive band for a new test (see :data:`FIGURES`). None when
    the summary has no tests."""
    tests = campaign_tests(s)
    if not tests:
        return None
    what = shown_quantity(s)
    sym = {"c": "c", "zeta": "ζ"}[what]
    unit = UNITS[what].replace(" ", "·")
    fig = L.new_figure(8.0, 1.8 + 0.45 * len(tests))
    ax = fig.add_subplot()
    pred = quantiles(lookup(s, "population", "predictive", what))
    pop = quantiles(lookup(s, "parameters", what))
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
        own, pooled = quantiles(lookup(t, "own", what)), quantiles(lookup(t, "pooled", what))
        if own is not None:
            ax.plot([own[1], own[2]], [y + 0.15] * 2, color=colour, lw=1.0, alpha=0.7)
            ax.plot(own[0], y + 0.15, "o", mfc="white", mec=colour, ms=5,
                    label="test alone" if i == 0 else None)
        if pooled is not None:
            ax.plot([pooled[1], pooled[2]], [y - 0.15] * 2, color=colour, lw=2.5)
            ax.plot(pooled[0], y - 0.15, "s", color=colour, ms=5,
                    label="partially pooled" if i == 0 else None)
        amp = t.get("amplitude_m")
        tag = f" (A = {amp * 1e3:.3g} mm)" if real(amp) else ""
        ticks.append(f"{i + 1}: {names[i]}{tag}")
    ax.set_yticks(range(len(tests) - 1, -1, -1), ticks, fontsize=8)
    ax.set_ylim(-0.8, len(tests) - 0.2)
    ax.set_xlabel(f"{sym} [{unit}]" if unit != "1" else sym)
    L.title(ax, f"{sym} of each test, population and predictive interval")
    ax.grid(axis="x", alpha=0.3)
    leg = fig.legend(fontsize=7, loc="lower center", ncols=4)  # below the axes
    rows = -(-len(leg.texts) // 4)
    legend = rows * L.line(7) + (0.5 * (rows - 1) + 1.3) * 7 * L.PT if rows else 0.0
    L.place(L.gridspec(ax), left=L.EDGE + L.TICK + max(L.text_width(t, 8) for t in ticks),
             right=0.25, top=L.EDGE + L.above(ax), bottom=L.x_room() + legend)
    return fig


def added_mass_figure(s: dict[str, Any]) -> "Figure | None":
    """1/ω_n² against Δm with the fitted line and m₀ (see :data:`FIGURES`); None when the
    summary is not of the added-mass design."""
    am = s.get("added_mass")
    if not isinstance(am, dict):
        return None
    pts = [p for p in (am.get("points") or []) if isinstance(p, dict)
           and real(p.get("added_mass_kg")) and real(p.get("omega_n2")) and p["omega_n2"] > 0]
    if not pts:
        return None
    fig = L.new_figure(6.0, 4.2)
    ax = fig.add_subplot()
    x = [p["added_mass_kg"] for p in pts]
    y = [1.0 / p["omega_n2"] for p in pts]
    err = [p["omega_n2_sd"] / p["omega_n2"] ** 2 if real(p.get("omega_n2_sd")) else 0.0
           for p in pts]
    ax.errorbar(x, y, yerr=err, fmt="o", color="black", ms=5, capsize=3, label="tests (± 1 sd)")
    m0 = quantiles(am.get("m0")) or quantiles(lookup(s, "parameters", "m0"))
    line = am.get("line") if isinstance(am.get("line"), dict) else {}
    lo = min(x + ([-m0[2]] if m0 else []))
    hi = max(x)
    if real(line.get("intercept")) and real(line.get("slope")):
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
    L.title(ax, "Added-mass method")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    L.place(L.gridspec(ax), left=L.y_room([ax]), right=0.25, top=L.EDGE + L.above(ax),
             bottom=L.x_room())
    return fig


#: Figure functions by file stem.
DRAW = {"forest": forest_figure, "added_mass": added_mass_figure}


def save_figures(s: dict[str, Any], outdir: str | os.PathLike, *, dpi: int = 110,
                 skip=()) -> dict[str, Path]:
    """Write ``forest.png`` and (added-mass design) ``added_mass.png`` of campaign summary
    ``s`` into ``outdir`` (atomically), but those named in ``skip``; a figure that does not
    apply is not written and an older file of its name is removed. Returns ``{name: path}``
    of the files written."""
    outdir = Path(outdir)
    written: dict[str, Path] = {}
    for name, draw in DRAW.items():
        if name in skip:
            continue
        path = outdir / f"{name}.png"
        fig = draw(s)
        if fig is None:
            path.unlink(missing_ok=True)  # never leave a stale figure of an earlier run
            continue
        save_png(fig, path, dpi)
        written[name] = path
    return written
