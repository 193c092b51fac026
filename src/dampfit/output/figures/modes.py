"""The figure of several modes (issue 21): the spectrum with every identified mode marked.

* :func:`modes_figure` (``modes.png``) — the single-sided amplitude spectrum of the selected
  signal (the signals' ``spectrum`` figure arrays, in dB re its peak) with each mode of the
  summary's ``modes`` marked: its natural frequency f_n [Hz] as a line at the posterior median
  and its 90 % interval as a band, labelled with f_n and the damping ratio ζ [1] (median and
  90 % interval, digits from :mod:`dampfit.output.format`).

Drawn only when the recording has several modes (``n_modes`` ≥ 2): for one mode it returns
None — no file, an older one removed — so a one-mode result folder is exactly what it was
before the modes existed. Every value read from the summary is checked for its type (an
edited summary.json may hold anything); a mode without finite f_n quantiles is not marked.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from dampfit.output.figures import layout as L
from dampfit.output.figures.data import MissingData, as_data
from dampfit.output.format import interval, quantiles

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

_COLORS = ("tab:red", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive",
           "tab:cyan", "tab:orange")


def marked_modes(summary: dict) -> list[dict[str, Any]] | None:
    """The modes a figure marks, from the summary's ``n_modes`` and ``modes``: None unless
    ``n_modes`` is a whole number ≥ 2 and ``modes`` a list of at least two entries; else one
    dict per mode with finite f_n quantiles — ``number`` (1-based position in ``modes``),
    ``f_n`` and ``zeta`` (q50, q05, q95) [Hz], [1] (``zeta`` None when not finite) and
    ``mass_mode`` (bool)."""
    n, modes = summary.get("n_modes"), summary.get("modes")
    if not (isinstance(n, int) and not isinstance(n, bool) and n >= 2
            and isinstance(modes, list) and len(modes) >= 2):
        return None
    out = []
    for i, mode in enumerate(modes):
        if not isinstance(mode, dict):
            continue
        f = quantiles(mode.get("f_n"))
        if f is None:
            continue
        out.append({"number": i + 1, "f_n": f, "zeta": quantiles(mode.get("zeta")),
                    "mass_mode": mode.get("mass_mode") is True})
    return out


def _label(mode: dict[str, Any], beyond: bool) -> str:
    med, lo, hi = interval(*mode["f_n"])
    text = f"mode {mode['number']}: f_n = {med} [{lo}, {hi}] Hz"
    if mode["zeta"] is not None:
        zm, zl, zh = interval(*mode["zeta"])
        text += f", ζ = {zm} [{zl}, {zh}]"
    if mode["mass_mode"]:
        text += " (the mass's mode)"
    return text + (" — beyond the stored spectrum" if beyond else "")


def modes_figure(an: Any) -> "Figure | None":
    """The amplitude spectrum [dB re peak] of the selected signal with each identified mode
    marked: f_n [Hz] median (line) and 90 % interval (band), labelled with f_n and ζ [1].

    None for a result with one mode (or a summary without ``modes``: written before them).
    :class:`~dampfit.output.figures.data.MissingData` when the spectrum arrays or every
    mode's f_n are missing. ``an``: an analysis or its
    :class:`~dampfit.output.figures.data.FigureData`.
    """
    d = as_data(an)
    modes = marked_modes(d.summary)
    if modes is None:
        return None
    if not modes:
        raise MissingData(f"modes.png cannot be drawn: {d.where} has no mode with a usable "
                          "f_n in its summary")
    a = d.arrays("modes", "spectrum")
    f, amp = np.asarray(a["spectrum_f"], float), np.asarray(a["spectrum_amp"], float)
    peak = float(np.max(amp)) if amp.size and np.max(amp) > 0 else 1.0
    db = 20 * np.log10(np.maximum(amp, 1e-12 * peak) / peak)
    f_top = float(f[-1]) if f.size else 0.0
    f_max = max([f_top] + [1.15 * m["f_n"][2] for m in modes])

    fig = L.new_figure(10.0, 5.5)
    ax = fig.subplots(1, 1)
    ax.plot(f, db, lw=0.9, color="tab:blue", label="amplitude spectrum re peak")
    for j, mode in enumerate(modes):
        color = _COLORS[j % len(_COLORS)]
        q50, q05, q95 = mode["f_n"]
        ax.axvspan(q05, q95, color=color, alpha=0.25, lw=0)
        ax.axvline(q50, color=color, lw=1.0, ls="--",
                   label=_label(mode, q50 > f_top))
        ax.annotate(str(mode["number"]), xy=(q50, 1.0), xycoords=ax.get_xaxis_transform(),
                    xytext=(3, -12), textcoords="offset points", color=color, fontsize=9)
    floor = float(np.percentile(db, 1)) if db.size else -100.0
    ax.set_ylim(max(floor - 10.0, -160.0), 10.0)
    ax.set_xlim(0, f_max if math.isfinite(f_max) and f_max > 0 else 1.0)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("level re peak [dB]")
    ax.grid(alpha=0.3)
    rows = L.legend_above(ax, 1)
    L.suptitle(fig, f"Spectrum with the {len(modes)} identified modes — {d.recording_name()}")
    L.place(L.gridspec(ax), left=L.y_room([ax]), right=0.2, bottom=L.x_room(),
            top=L.top(L.above(ax, None, legend_rows=rows)))
    return fig
